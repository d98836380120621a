"""The object model database: built-in library, canonical frame, on-disk format, readers, thumbnails, CLI."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.libraries.object_db import CATEGORIES, ObjectDatabase, parametric
from psdr_room_core.libraries.object_db.builtin import builtin_database
from psdr_room_core.libraries.object_db.database import build_index, write_model
from psdr_room_core.libraries.object_db.future3d import read_3dfuture
from psdr_room_core.libraries.object_db.objio import read_obj

FURNITURE = ("chair", "table", "sofa", "bed", "cabinet", "shelf", "desk", "lamp", "rug", "pillow")


@pytest.fixture(scope="module")
def db() -> ObjectDatabase:
    return builtin_database()


def _signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)


# ------------------------------------------------------------------------------------------ built-in library
def test_builtin_library_size_and_ids(db: ObjectDatabase) -> None:
    counts = db.categories()
    assert len(db) >= 100 and len(counts) >= 10
    assert all(counts.get(c, 0) >= 5 for c in FURNITURE), counts
    assert len({r.id for r in db.records}) == len(db)
    assert sum(r.id.startswith("kenney/") for r in db.records) == 54
    assert sum(r.id.startswith("polyhaven/") for r in db.records) == 6
    assert sum(r.id.startswith("parametric/") for r in db.records) >= 160
    assert all(counts.get(c, 0) >= 4 for c in ("ottoman", "refrigerator", "appliance", "frame", "box")), counts
    assert {"kenney/loungeSofa", "parametric/sofa_000", "parametric/pillow_011"} <= {r.id for r in db.records}
    assert [v.params for v in parametric.catalogue()] == [v.params for v in parametric.catalogue()]  # stable ids
    for record in db.records:
        assert record.category in CATEGORIES and record.licence and "\n" not in record.licence
    assert all(r.licence.startswith("CC0") for r in db.records if r.id.startswith("kenney/"))
    assert db.category("sofa") and all(r.category == "sofa" for r in db.category("sofa"))
    with pytest.raises(PsdrRoomError, match="category 'sofas'"):
        db.category("sofas")
    with pytest.raises(PsdrRoomError, match="no model 'kenney/sofa'"):
        db.mesh("kenney/sofa")


def test_builtin_loads_fast_from_its_record_cache(cache_dir: Path) -> None:
    builtin_database.cache_clear()
    first = builtin_database()
    builtin_database.cache_clear()
    start = time.perf_counter()
    again = builtin_database()
    assert time.perf_counter() - start < 1.0
    assert again.records == first.records and list(cache_dir.glob("object_db/builtin-*.json"))


def test_every_model_is_in_the_canonical_frame(db: ObjectDatabase) -> None:
    for record in db.records:
        mesh = db.mesh(record.id)
        mesh.check(record.id)
        v, f = mesh.vertices, mesh.faces
        assert v.dtype == np.float64 and f.dtype == np.int64 and mesh.face_group.dtype == np.int64, record.id
        lo, hi = v.min(axis=0), v.max(axis=0)
        assert lo[1] == pytest.approx(0.0, abs=1e-9), record.id  # bottom at y = 0
        assert (lo[0] + hi[0]) / 2 == pytest.approx(0.0, abs=1e-9) and (lo[2] + hi[2]) / 2 == pytest.approx(
            0.0, abs=1e-9
        )
        assert np.allclose(hi - lo, record.extent, atol=1e-4), record.id
        assert min(record.extent[0], record.extent[2]) > 0.0 and max(record.extent) < 4.0, (record.id, record.extent)
        assert mesh.groups == record.groups and len(mesh.colors) == len(mesh.groups)
        assert set(np.unique(mesh.face_group)) == set(range(len(mesh.groups))), record.id  # every group used
        area = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
        assert (area > 0).all(), record.id
        assert _signed_volume(v, f) > 0, record.id  # counter-clockwise seen from outside
    assert db.mesh("kenney/chair") is db.mesh("kenney/chair")  # cached


def test_kenney_models_are_in_metres_and_face_front(db: ObjectDatabase) -> None:
    chair = db.mesh("kenney/chair")
    assert 0.85 < chair.extent[1] < 1.0  # Kenney's half-size chair, doubled
    assert 1.8 < db.record("kenney/bedDouble").extent[2] < 2.4
    for model_id in ("kenney/chair", "kenney/loungeSofa", "kenney/bedDouble"):
        v = db.mesh(model_id).vertices
        high = v[v[:, 1] > 0.7 * v[:, 1].max()]
        assert high[:, 2].mean() < 0, model_id  # back rest / headboard behind, so the front faces +Z


def test_polyhaven_models_are_real_size(db: ObjectDatabase) -> None:
    assert 2.6 < db.record("polyhaven/sofa_03").extent[0] < 2.8
    assert 2.0 < db.record("polyhaven/wooden_bookshelf_worn").extent[1] < 2.1
    assert db.record("polyhaven/painted_wooden_cabinet").groups == ("body", "doors", "drawers")
    assert all(r.licence.startswith("CC0") for r in db.records if r.id.startswith("polyhaven/"))
    doors = db.mesh("polyhaven/painted_wooden_cabinet").group_mesh("doors")
    assert doors.vertices[np.unique(doors.faces)][:, 2].mean() > 0  # the doors at the front


def test_parametric_parts_face_front() -> None:
    def group_centre(mesh, name: str) -> np.ndarray:
        return mesh.vertices[np.unique(mesh.faces[mesh.face_group == mesh.groups.index(name)])].mean(axis=0)

    sofa = parametric.sofa()
    assert sofa.groups == ("frame", "cushion", "legs")
    bed = parametric.bed()
    assert group_centre(bed, "headboard")[2] < group_centre(bed, "bedding")[2]
    assert group_centre(parametric.cabinet(), "fronts")[2] > 0
    assert group_centre(parametric.tv(), "screen")[2] > 0
    chair = parametric.chair()
    high = chair.vertices[chair.vertices[:, 1] > 0.6]
    assert high[:, 2].mean() < 0  # the back rest is behind the seat
    assert parametric.chair(back_style="none").extent[1] < 0.5  # a stool
    for mesh, part in (
        (parametric.refrigerator(), "handles"),
        (parametric.frame(), "picture"),
        (parametric.oven(), "door"),
        (parametric.washer(), "door"),
        (parametric.microwave(), "door"),
        (parametric.monitor(), "screen"),
        (parametric.kitchen_unit(), "fronts"),
    ):
        assert group_centre(mesh, part)[2] > 0, part
    assert parametric.frame().extent[2] < 0.06 and parametric.kitchen_unit(kind="base").groups[-1] == "counter"


@pytest.mark.parametrize(
    "category, changes",
    [
        ("chair", {"back_style": "spindles"}),
        ("chair", {"leg_style": "swivel"}),
        ("chair", {"armrests": True}),
        ("sofa", {"seats": 2}),
        ("sofa", {"arm_style": "rolled"}),
        ("sofa", {"chaise": "left"}),
        ("sofa", {"leg_style": "plinth"}),
        ("table", {"shape": "round"}),
        ("table", {"leg_style": "pedestal"}),
        ("bed", {"headboard": "slats"}),
        ("cabinet", {"drawers": 3}),
        ("shelf", {"shelves": 3}),
        ("desk", {"drawers_side": "left"}),
        ("lamp", {"kind": "floor"}),
        ("lamp", {"shade": "globe"}),
        ("rug", {"shape": "round"}),
        ("pillow", {"shape": "bolster"}),
        ("plant", {"foliage": "tree"}),
        ("tv", {"stand": "pedestal"}),
        ("ottoman", {"shape": "round"}),
        ("ottoman", {"legs_height": 0.1}),
        ("kitchen_unit", {"kind": "wall"}),
        ("kitchen_unit", {"modules": 2}),
        ("container", {"kind": "basket"}),
        ("container", {"kind": "crate"}),
        ("frame", {"kind": "whiteboard"}),
        ("frame", {"mat": 0.05}),
        ("monitor", {"stand": "disc"}),
        ("refrigerator", {"style": "side_by_side"}),
        ("oven", {"kind": "wall"}),
        ("microwave", {"width": 0.6}),
        ("washer", {"finish": "black", "height": 0.9}),
    ],
)
def test_parametric_parameters_change_the_mesh(category: str, changes: dict) -> None:
    generate = parametric.GENERATORS[category]
    a, b = generate(), generate(**changes)
    assert a.vertices.shape != b.vertices.shape or not np.allclose(a.vertices, b.vertices)


def test_parametric_catalogue_variants_are_distinct(db: ObjectDatabase) -> None:
    seen: dict[str, str] = {}
    for record in db.records:
        if record.id.startswith("parametric/"):
            mesh = db.mesh(record.id)
            key = (
                f"{len(mesh.vertices)}:{np.round(mesh.vertices[:50], 4).tobytes().hex()}:{mesh.colors.tobytes().hex()}"
            )
            assert key not in seen, (record.id, seen.get(key))
            seen[key] = record.id


# --------------------------------------------------------------------------------------------- on-disk format
def test_format_round_trips(db: ObjectDatabase, tmp_path: Path) -> None:
    small = db.only(["kenney/loungeSofa", "parametric/sofa_003", "parametric/lamp_004", "parametric/rug_001"])
    small.save(tmp_path / "db")
    assert (tmp_path / "db" / "kenney" / "loungeSofa" / "model.json").is_file()
    loaded = ObjectDatabase.load(tmp_path / "db")
    assert [r.id for r in loaded.records] == [r.id for r in small.records]
    for record in small.records:
        back = loaded.record(record.id)
        assert (back.category, back.name, back.licence, back.groups) == (
            record.category,
            record.name,
            record.licence,
            record.groups,
        )
        assert np.allclose(back.extent, record.extent, atol=1e-5)
        a, b = small.mesh(record.id), loaded.mesh(record.id)
        assert np.allclose(a.vertices, b.vertices, atol=1e-5) and np.array_equal(a.faces, b.faces)
        assert np.array_equal(a.face_group, b.face_group) and np.allclose(a.colors, b.colors, atol=1e-5)
    assert loaded.digest != small.digest


def test_index_is_built_from_model_files_in_other_units_and_axes(tmp_path: Path) -> None:
    folder = tmp_path / "db" / "mine" / "crate"
    folder.mkdir(parents=True)
    # a 100 x 50 x 40 cm box in centimetres, Z up, front towards -Y; the lid is its own material
    (folder / "crate.obj").write_text(
        "mtllib crate.mtl\n"
        "v 0 0 0\nv 100 0 0\nv 100 40 0\nv 0 40 0\nv 0 0 50\nv 100 0 50\nv 100 40 50\nv 0 40 50\n"
        "usemtl wood\nf 1 4 3 2\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\nusemtl lid\nf -4 -3 -2 -1\n"
    )
    (folder / "crate.mtl").write_text("newmtl wood\nKd 0.6 0.4 0.2\nnewmtl lid\nKd 0.1 0.1 0.1\n")
    (folder / "model.json").write_text(
        json.dumps(
            {
                "category": "cabinet",
                "licence": "CC0",
                "mesh": "crate.obj",
                "up_axis": "+z",
                "front_axis": "-y",
                "unit_scale": 0.01,
            }
        )
    )
    build_index(tmp_path / "db")
    loaded = ObjectDatabase.load(tmp_path / "db")
    record = loaded.record("mine/crate")
    assert record.groups == ("wood", "lid") and np.allclose(record.extent, (1.0, 0.5, 0.4))
    mesh = loaded.mesh("mine/crate")
    assert np.allclose(mesh.colors, [[0.6, 0.4, 0.2], [0.1, 0.1, 0.1]])
    lid = mesh.vertices[np.unique(mesh.faces[mesh.face_group == 1])]
    assert np.allclose(lid[:, 1], 0.5)  # the file's +Z top is our +Y top
    assert _signed_volume(mesh.vertices, mesh.faces) == pytest.approx(0.2)  # winding kept


def test_obj_reader_polygons_negative_indices_and_default_group(tmp_path: Path) -> None:
    path = tmp_path / "m.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n  f 1/1/1 2/2/1 3/3/1 4/4/1\nusemtl red\nf -4 -2 -1\n")
    obj = read_obj(path)
    assert obj.groups == ("default", "red") and obj.faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 2, 3]]


def _good_db(root: Path) -> dict:
    record = _record("mine/a")
    write_model(root, record, parametric.rug(border=0.0))
    index = {"format": "psdr-room-object-db", "version": 1, "models": [record.to_json()]}
    (root / "index.json").write_text(json.dumps(index))
    return index


def _record(model_id: str):  # type: ignore[no-untyped-def]
    from psdr_room_core.libraries.object_db.database import ModelRecord

    mesh = parametric.rug(border=0.0)
    return ModelRecord(
        id=model_id, category="rug", name="a rug", source="test", licence="CC0", groups=mesh.groups, extent=mesh.extent
    )


@pytest.mark.parametrize(
    "damage, where, field",
    [
        (lambda r, i: (r / "index.json").unlink(), "index.json", "cannot read"),
        (lambda r, i: (r / "index.json").write_text("{not json"), "index.json", "not valid JSON"),
        (lambda r, i: (r / "index.json").write_text('{"models": 3}'), "index.json", "'models'"),
        (
            lambda r, i: (r / "index.json").write_text(json.dumps({"models": [{**i["models"][0], "licence": None}]})),
            "index.json",
            "'licence'",
        ),
        (
            lambda r, i: (r / "index.json").write_text(
                json.dumps({"models": [{k: v for k, v in i["models"][0].items() if k != "licence"}]})
            ),
            "index.json",
            "'licence' is missing",
        ),
        (
            lambda r, i: (r / "index.json").write_text(
                json.dumps({"models": [{**i["models"][0], "category": "couch"}]})
            ),
            "index.json",
            "'category'",
        ),
        (
            lambda r, i: (r / "index.json").write_text(json.dumps({"models": [{**i["models"][0], "extent": [1, 2]}]})),
            "index.json",
            "'extent'",
        ),
        (
            lambda r, i: (r / "index.json").write_text(json.dumps({"models": [{**i["models"][0], "id": "../x"}]})),
            "index.json",
            "'id'",
        ),
        (lambda r, i: (r / "index.json").write_text(json.dumps({"models": i["models"] * 2})), "index.json", "twice"),
        (
            lambda r, i: (r / "index.json").write_text(json.dumps({"format": "other", "models": i["models"]})),
            "index.json",
            "'format'",
        ),
    ],
)
def test_index_errors_name_the_file_and_field(tmp_path: Path, damage, where: str, field: str) -> None:
    index = _good_db(tmp_path)
    ObjectDatabase.load(tmp_path)  # sound before the damage
    damage(tmp_path, index)
    with pytest.raises(PsdrRoomError) as info:
        ObjectDatabase.load(tmp_path)
    message = str(info.value)
    assert where in message and field in message and "\n" not in message


@pytest.mark.parametrize(
    "damage, where, field",
    [
        (
            lambda folder: (folder / "model.json").write_text(
                json.dumps({**json.loads((folder / "model.json").read_text()), "up_axis": "up"})
            ),
            "model.json",
            "'up_axis'",
        ),
        (
            lambda folder: (folder / "model.json").write_text(
                json.dumps({**json.loads((folder / "model.json").read_text()), "unit_scale": -1})
            ),
            "model.json",
            "'unit_scale'",
        ),
        (
            lambda folder: (folder / "model.json").write_text(
                json.dumps({**json.loads((folder / "model.json").read_text()), "unit_scale": 2.0})
            ),
            "model.json",
            "'extent'",
        ),
        (lambda folder: (folder / "mesh.obj").write_text("v 0 0 0\nf 1 2 3\n"), "mesh.obj", "not defined"),
        (lambda folder: (folder / "mesh.obj").write_text("v 0 0 zero\n"), "mesh.obj:1", "cannot parse"),
        (lambda folder: (folder / "mesh.obj").unlink(), "mesh.obj", "cannot read"),
        (lambda folder: (folder / "mesh.mtl").write_text("newmtl field\nKd red\n"), "mesh.mtl:2", "Kd"),
    ],
)
def test_model_errors_name_the_file_and_field(tmp_path: Path, damage, where: str, field: str) -> None:
    _good_db(tmp_path)
    damage(tmp_path / "mine" / "a")
    db = ObjectDatabase.load(tmp_path)
    with pytest.raises(PsdrRoomError) as info:
        db.mesh("mine/a")
    message = str(info.value)
    assert where in message and field in message and "\n" not in message


# ------------------------------------------------------------------------------------------------ 3D-FUTURE
def _fake_3dfuture(root: Path) -> None:
    info = [
        {
            "model_id": "0a1b-sofa",
            "super-category": "Sofa",
            "category": "Three-Seat / Multi-seat Sofa",
            "style": "Modern",
            "theme": "Smooth Net",
            "material": "Cloth",
        },
        {
            "model_id": "2c3d-stool",
            "super-category": "Pier/Stool",
            "category": None,
            "style": "Nordic",
            "theme": None,
            "material": "Wood",
        },
        {
            "model_id": "4e5f-wardrobe",
            "super-category": "Cabinet/Shelf/Desk",
            "category": "Wardrobe",
            "style": "Others",
            "theme": None,
            "material": None,
        },
        {"model_id": "6a7b-gone", "super-category": "Bed", "category": "King-size Bed"},
    ]
    (root / "model_info.json").write_text(json.dumps(info))
    cube = "v -1 0 -0.5\nv 1 0 -0.5\nv 1 0.8 -0.5\nv -1 0.8 -0.5\nv -1 0 0.5\nv 1 0 0.5\nv 1 0.8 0.5\nv -1 0.8 0.5\n"
    faces = (
        "usemtl Fabric_01\nf 1 4 3\nf 1 3 2\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\n"
        "usemtl Wood_02\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\nf 5 6 7\nf 5 7 8\n"
    )
    for model_id, scale in (("0a1b-sofa", 1.0), ("2c3d-stool", 0.25), ("4e5f-wardrobe", 0.6)):
        folder = root / "3D-FUTURE-model" / model_id
        folder.mkdir(parents=True)
        lines = cube.splitlines()
        scaled = "\n".join("v " + " ".join(f"{float(x) * scale:g}" for x in ln.split()[1:]) for ln in lines)
        (folder / "raw_model.obj").write_text(f"mtllib model.mtl\no {model_id}\n{scaled}\nvt 0 0\n{faces}")
        (folder / "model.mtl").write_text(
            "newmtl Fabric_01\nKd 0.8 0.2 0.2\nmap_Kd texture.png\nnewmtl Wood_02\nKd 0.5 0.3 0.1\n"
        )
        (folder / "image.jpg").write_bytes(b"\xff\xd8\xff\xd9")


def test_3dfuture_reader_on_a_fake_tree(tmp_path: Path, cache_dir: Path, capsys, monkeypatch) -> None:
    _fake_3dfuture(tmp_path)
    db = read_3dfuture(tmp_path, workers=1)
    assert "1 of 4 models" in capsys.readouterr().err  # the missing one is skipped with a warning
    assert [r.id for r in db.records] == ["3dfuture/0a1b-sofa", "3dfuture/2c3d-stool", "3dfuture/4e5f-wardrobe"]
    assert [r.category for r in db.records] == ["sofa", "chair", "cabinet"]
    sofa = db.record("3dfuture/0a1b-sofa")
    assert sofa.groups == ("Fabric_01", "Wood_02") and np.allclose(sofa.extent, (2.0, 0.8, 1.0))
    assert "Modern" in sofa.name and "3D-FUTURE" in sofa.licence
    mesh = db.mesh("3dfuture/2c3d-stool")
    assert mesh.vertices[:, 1].min() == 0.0 and np.allclose(mesh.colors[0], (0.8, 0.2, 0.2))
    assert set(db.images) == {r.id for r in db.records}
    with pytest.raises(PsdrRoomError, match="1 of 4 models"):
        read_3dfuture(tmp_path, workers=1, strict=True)
    # a second read takes the measurements from the cache
    import psdr_room_core.libraries.object_db.future3d as future3d

    monkeypatch.setattr(future3d, "_measure", lambda job: pytest.fail("re-parsed a cached mesh"))
    assert read_3dfuture(tmp_path).records == db.records
    with pytest.raises(PsdrRoomError, match="model_info.json"):
        read_3dfuture(tmp_path / "nowhere")


# ---------------------------------------------------------------------------------------------------- subset
def test_subset_keeps_a_fraction_per_category(db: ObjectDatabase) -> None:
    small = db.subset(0.2, seed=3)
    assert set(small.categories()) == set(db.categories())  # at least one per category
    for category, count in db.categories().items():
        assert small.categories()[category] == max(1, round(0.2 * count))
    assert [r.id for r in small.records] == [r.id for r in db.records if r.id in small]  # original order
    assert small.subset(1.0, seed=0).records == small.records
    assert db.subset(0.2, seed=3).records == small.records and db.subset(0.2, seed=4).records != small.records
    assert small.digest == db.digest and small.mesh(small.records[0].id).faces.size
    with pytest.raises(PsdrRoomError, match="fraction"):
        db.subset(0.0, seed=0)


# ------------------------------------------------------------------------------------------------ thumbnails
def test_thumbnails_render_and_are_cached(db: ObjectDatabase, cache_dir: Path, monkeypatch) -> None:
    from psdr_room_core.libraries.object_db import thumbnails

    views = db.thumbnails("kenney/chair")
    assert len(views) == len(thumbnails.VIEWS) >= 3
    for image in views:
        assert image.shape == (128, 128, 3) and image.dtype == np.uint8
        background = (image > 245).all(axis=2)
        assert 0.03 < 1 - background.mean() < 0.9  # the object is there, and framed
        assert background[0].all() and background[-1].all()  # white around it
    files = sorted(cache_dir.glob("object_db/*/kenney/chair/view*.png"))
    assert len(files) == len(views)
    monkeypatch.setattr(thumbnails.ThumbnailRenderer, "render", lambda *args: pytest.fail("rendered again"))
    again = db.thumbnails("kenney/chair")
    assert all(np.array_equal(a, b) for a, b in zip(views, again))
    assert db.only(["kenney/chair"]).thumbnails("kenney/chair")[0].shape == (128, 128, 3)  # same cache


def test_a_contact_sheet_renders_only_the_view_it_shows(db: ObjectDatabase, cache_dir: Path, monkeypatch) -> None:
    from psdr_room_core.libraries.object_db import thumbnails

    rendered: list[list[int]] = []
    render = thumbnails.ThumbnailRenderer.render

    def counting(self, mesh, views=None):
        rendered.append(list(views))
        return render(self, mesh, views)

    monkeypatch.setattr(thumbnails.ThumbnailRenderer, "render", counting)
    first = db.thumbnails("kenney/chair", views=[0])
    assert rendered == [[0]] and len(first) == 1
    assert thumbnails.cached_thumbnails(db, "kenney/chair") is None  # the other views are not there yet
    views = db.thumbnails("kenney/chair")
    assert rendered == [[0], [1, 2, 3]] and np.array_equal(views[0], first[0])
    assert not np.array_equal(views[0], views[2])  # each view from its own camera


# ------------------------------------------------------------------------------------------------------- CLI
def test_cli_list_export_and_errors(tmp_path: Path, cache_dir: Path, capsys) -> None:
    from psdr_room_core.applications.db import main

    assert main(["list", "--category", "sofa"]) == 0
    out = capsys.readouterr()
    assert "kenney/loungeSofa\tsofa" in out.out and "parametric/sofa_000" in out.out
    assert main(["export", "--out", str(tmp_path / "db"), "--subset", "0.05", "--seed", "1"]) == 0
    capsys.readouterr()
    assert main(["list", "--root", str(tmp_path / "db")]) == 0
    assert len(capsys.readouterr().out.splitlines()) == len(ObjectDatabase.load(tmp_path / "db"))
    assert main(["show", "kenney/nope", "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("psdr-room-db:") and "kenney/nope" in err and "\n" not in err
    assert main(["list", "--root", str(tmp_path / "missing")]) == 2
    assert "index.json" in capsys.readouterr().err
