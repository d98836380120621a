"""The eyes network's parts: the data engine's labels, the encoder read from the bundled ONNX, training, export."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from psdr_room_core.applications.synth_data import (
    Tools,
    label_maps,
    main,
    photo_textures,
    render_photo,
    sample_room,
    tools,
)
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.libraries.object_db.database import CATEGORIES
from psdr_room_core.method.artifacts import rotation_y
from psdr_room_plugins.eyes import labels
from psdr_room_plugins.eyes.data import Pack


@pytest.fixture(scope="module")
def made() -> Tools:
    return tools(plugin_system().registry)


def test_the_network_classes_are_the_databases_categories() -> None:
    assert labels.CATEGORIES == CATEGORIES


def _nearest_hits(origin: np.ndarray, directions: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance along each ray, index of the triangle hit first; inf / -1 where none): Möller-Trumbore on every
    ray-triangle pair, written here so that it shares nothing with the renderer."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e1, e2 = b - a, c - a
    best_t, best = np.full(len(directions), np.inf), np.full(len(directions), -1)
    for start in range(0, len(triangles), 512):
        s = slice(start, start + 512)
        p = np.cross(directions[:, None], e2[None, s])
        det = np.einsum("rtk,tk->rt", p, e1[s])
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = origin - a[s]
            u = np.einsum("rtk,tk->rt", p, tv) * inv
            q = np.cross(tv, e1[s])
            v = np.einsum("rk,tk->rt", directions, q) * inv
            t = np.einsum("tk,tk->t", q, e2[s])[None] * inv
        ok = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
        t = np.where(ok, t, np.inf)
        k = t.argmin(axis=1)
        nearer = t[np.arange(len(t)), k] < best_t
        best_t[nearer], best[nearer] = t[np.arange(len(t)), k][nearer], start + k[nearer]
    return best_t, best


def test_labels_of_a_generated_room_are_exact_at_pixel_centres(made: Tools) -> None:
    """Every pixel's class, instance and depth match an independent ray cast through its centre."""
    sample = sample_room(3, made.database, made.library, [], width=64, height=48)
    maps = label_maps(sample, made.renderer)
    meshes = {**sample.meshes, **{n: m for n, (m, _) in sample.emitters.items()}}
    triangles = np.concatenate([m.vertices[m.faces] for m in meshes.values()])
    owner = np.concatenate([np.full(len(m.faces), k) for k, m in enumerate(meshes.values())])
    camera, pose = sample.camera, sample.camera_to_world
    v, u = np.mgrid[0 : camera.height, 0 : camera.width] + 0.5
    rays = np.stack([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(u)], -1).reshape(-1, 3)
    depth, hit = _nearest_hits(pose[:3, 3], rays @ pose[:3, :3].T, triangles)  # t along a z = 1 ray is z-depth
    truth = np.array([sample.labels[n] for n in meshes])[owner[hit]]
    got = {k: maps[k].reshape(-1) for k in ("surface", "category", "instance")}
    agree = [float((got[k] == truth[:, i]).mean()) for i, k in enumerate(("surface", "category", "instance"))]
    assert min(agree) > 0.97, agree  # a pixel centre within a hair of an edge may go either way
    # depth is a filtered mean of the renderer's samples (Gaussian film filter, 2 px radius): it lies within the
    # true depths of the pixels around
    grid = depth.reshape(camera.height, camera.width)
    padded = np.pad(grid, 2, mode="reflect", reflect_type="odd")  # the border pixels reach beyond the last centre
    around = np.stack(
        [
            padded[2 + dy : 2 + dy + camera.height, 2 + dx : 2 + dx + camera.width]
            for dy in range(-2, 3)
            for dx in range(-2, 3)
        ]
    )
    low, high = (a.reshape(-1) for a in (around.min(axis=0), around.max(axis=0)))
    same = (got["instance"] == truth[:, 2]) & (got["surface"] == truth[:, 0]) & (maps["depth"].reshape(-1) > 0)
    assert same.mean() > 0.9
    got_depth = maps["depth"].reshape(-1).astype(float)
    inside = (got_depth >= low * 0.99) & (got_depth <= high * 1.01)  # float16 and the filter's tails
    assert inside[same].all(), np.abs(got_depth - depth)[same & ~inside]
    assert np.median(np.abs(got_depth - depth)[same] / depth[same]) < 5e-3
    assert {labels.SURFACES[s] for s in np.unique(got["surface"])} >= {"wall", "floor", "object"}


def test_the_data_engine_is_deterministic_and_writes_whole_samples(tmp_path: Path, made: Tools) -> None:
    main(["--out", str(tmp_path), "--seeds", "5", "--spp", "2", "--width", "48", "--height", "36"])
    first = (tmp_path / "000005.jpg").read_bytes(), dict(np.load(tmp_path / "000005.npz"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["000005.jpg", "000005.npz"]
    (tmp_path / "000005.jpg").unlink()
    main(["--out", str(tmp_path), "--seeds", "5", "--spp", "2", "--width", "48", "--height", "36"])
    again = dict(np.load(tmp_path / "000005.npz"))
    assert all(np.array_equal(first[1][k], again[k]) for k in first[1])
    image = render_photo(sample_room(5, made.database, made.library, [], 48, 36), made.renderer, made.denoiser, 2)
    assert image.shape == (36, 48, 3) and image.std() > 5


def test_windows_and_doors_are_dressed_as_real_ones_and_labelled_as_them(made: Tools) -> None:
    """Frames, mullions, blinds, curtains and the view beyond the glass are window; a door's casing and handle are
    door: none of them is furniture for the network to learn, and none reaches out of the room."""
    seen: set[str] = set()
    for seed in range(60):
        sample = sample_room(seed, made.database, made.library, [], width=64, height=48)
        room = sample.room
        meshes = {**sample.meshes, **{n: m for n, (m, _) in sample.emitters.items()}}
        for name, mesh in meshes.items():
            if name.startswith(("window", "door")):
                local = (mesh.vertices - room.center) @ rotation_y(room.yaw)  # world → the room's own axes
                assert (np.abs(local) <= room.half_size + 1e-6).all(), (seed, name)
        for name, label in sample.labels.items():
            kind, *part = name.split("_")
            if kind == "window":
                assert label == (labels.SURFACES.index("window"), 0, 0), name
                seen.add(part[1] if len(part) > 1 else "glass")
            elif kind == "door":
                assert label == (labels.SURFACES.index("door"), 0, 0), name
                seen.add(part[0] if part else "door")
    assert seen >= {"glass", "frame", "blind", "curtain", "view", "door", "trim", "handle"}, seen


def test_photo_textures_take_the_colour_map_of_a_set(tmp_path: Path) -> None:
    for name in ("set/wood_diff_1k.jpg", "set/wood_nor_gl_1k.jpg", "set/wood_rough_1k.jpg", "plain/brick.png"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    assert [p.name for p in photo_textures(tmp_path)] == ["brick.png", "wood_diff_1k.jpg"]


def test_the_encoder_read_from_the_onnx_gives_the_onnxs_feature_maps() -> None:
    import onnx
    import onnxruntime as ort
    import torch

    from psdr_room_plugins.eyes.encoder import FEATURES, OnnxEncoder, default_onnx

    model = onnx.load(str(default_onnx()))
    for tensor in FEATURES.values():
        model.graph.output.append(onnx.helper.make_tensor_value_info(tensor, onnx.TensorProto.FLOAT, None))
    x = np.random.default_rng(0).normal(size=(1, 3, 416, 416)).astype(np.float32)
    expected = ort.InferenceSession(model.SerializeToString()).run(list(FEATURES.values()), {"image": x})
    with torch.no_grad():
        got = OnnxEncoder()(torch.from_numpy(x))
    for (name, value), reference in zip(got.items(), expected):
        assert value.shape == reference.shape and np.abs(value.numpy() - reference).max() < 1e-4, name
    with torch.no_grad():  # any size runs: 240 rows are not a multiple of 32
        assert OnnxEncoder()(torch.zeros(1, 3, 240, 320))["p5"].shape == (1, 128, 8, 10)


@pytest.fixture(scope="module")
def eyes_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("eyes_data")
    main(["--out", str(folder), "--seeds", "1-4", "--spp", "2"])
    return folder


@pytest.fixture(scope="module")
def pack(eyes_data: Path) -> Pack:
    from psdr_room_plugins.eyes.data import build_pack

    return build_pack(eyes_data, eyes_data / "pack.npz")


def test_a_pack_keeps_each_samples_depth_to_the_centimetre(pack, eyes_data: Path, tmp_path: Path) -> None:
    from psdr_room_plugins.eyes.data import LABEL_SIZE, Pack, example

    again = Pack.load(pack.save(tmp_path / "pack.npz"))
    for index, seed in enumerate(again.seeds):
        depth = example(again, index, None)["depth"][0]
        full = np.load(eyes_data / f"{seed:06d}.npz")["depth"].astype(np.float32)
        rows = ((np.arange(LABEL_SIZE[0]) + 0.5) * full.shape[0] / LABEL_SIZE[0]).astype(int)
        cols = ((np.arange(LABEL_SIZE[1]) + 0.5) * full.shape[1] / LABEL_SIZE[1]).astype(int)
        truth = full[rows[:, None], cols[None, :]]  # the label at each quarter-resolution cell's centre
        assert depth.shape == LABEL_SIZE and (depth > 0).mean() > 0.5
        assert np.abs(depth - truth).max() <= 0.005 + 1e-6
        assert np.array_equal(depth > 0, truth >= 0.005)


def _whole_pack_batch(pack: Pack) -> dict:
    """Every sample of ``pack``, unaugmented, as one batch of torch tensors (images in [0, 1])."""
    import torch

    from psdr_room_plugins.eyes.data import example

    items = [example(pack, i, None) for i in range(len(pack))]
    batch = {k: torch.from_numpy(np.stack([it[k] for it in items])) for k in items[0]}
    batch["image"] = batch["image"].float() / 255.0
    return batch


@pytest.mark.parametrize("precision", ["fp32", "bf16"])
def test_two_training_steps_lower_the_loss(pack, precision: str) -> None:
    import torch

    from psdr_room_core.applications.train import LOSS_WEIGHTS, losses, predict
    from psdr_room_plugins.eyes.network import EyesNet

    torch.manual_seed(0)
    net = EyesNet()
    batch = _whole_pack_batch(pack)
    optimiser = torch.optim.AdamW(
        [{"params": net.head_parameters(), "lr": 1e-3}, {"params": net.encoder_parameters(), "lr": 1e-4}]
    )

    def total() -> torch.Tensor:
        return sum(LOSS_WEIGHTS[k] * v for k, v in losses(predict(net, batch["image"], precision), batch).items())

    first = total()
    for _ in range(2):
        optimiser.zero_grad()
        total().backward()
        optimiser.step()
    with torch.no_grad():
        assert float(total()) < float(first)


def _perfect_outputs(item: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The 3D heads' outputs equal to an example's targets (the yaw bins as near one-hot logits)."""
    from psdr_room_plugins.eyes.box3d import EMBEDDING, YAW_BINS

    bins = np.where(item["yaw_bin"] >= 0, item["yaw_bin"], 0)
    return {
        "box_depth": item["box_depth"],
        "box_size": item["box_size"],
        "yaw_bin": 30.0 * (np.arange(YAW_BINS)[:, None, None] == bins[None]).astype(np.float32),
        "yaw_residual": np.repeat(item["yaw_residual"][None], YAW_BINS, axis=0),
        "amodal": item["amodal"],
        "embedding": np.ones((EMBEDDING, *bins.shape), np.float32),
    }


@pytest.mark.parametrize("augmented", [False, True])
def test_the_3d_targets_read_back_give_each_instances_box(pack, augmented: bool) -> None:
    """The pack's boxes encoded as the 3D heads' per-pixel targets, read back as if the network had output them,
    give each box the generator placed: its depth, size, observation angle and amodal image box; through a crop
    and zoom (the focal grows by the zoom) and a mirror (the box turns the other way), the same depth, size and
    mirrored angle."""
    from psdr_room_plugins.eyes.box3d import read_box, wrap
    from psdr_room_plugins.eyes.data import example

    read = 0
    for index in range(len(pack)):
        item = example(pack, index, np.random.default_rng(index) if augmented else None)
        out = _perfect_outputs(item)
        for slot, row in enumerate(item["slot_row"][item["slot_row"] >= 0]):
            box = read_box(out, item["slot"] == slot, *pack.focal[index])  # focal: right for the plain example
            depth_scale = 1.0
            if augmented:  # the zoom of the cut image: the box's width on it over the original's
                depth_scale = (box.amodal[2] - box.amodal[0]) / (pack.box_amodal[row, 2] - pack.box_amodal[row, 0])
            assert box.center[2] * depth_scale == pytest.approx(
                pack.box_center[row, 2], rel=0.03 if augmented else 1e-4
            )
            assert box.size == pytest.approx(pack.box_size[row], rel=1e-4)
            alpha = float(wrap(box.yaw + np.arctan2(box.center[0], box.center[2])))
            if not augmented:
                assert alpha == pytest.approx(float(pack.box_alpha[row]), abs=1e-4)
                assert box.amodal == pytest.approx(pack.box_amodal[row], abs=1e-3)
            else:
                assert min(abs(wrap(alpha - pack.box_alpha[row])), abs(wrap(alpha + pack.box_alpha[row]))) < 1e-4
            read += 1
    assert read >= 8


def test_the_3d_heads_learn_in_two_steps_and_leave_the_image_plane_heads_as_they_were(pack) -> None:
    """With the encoder and the image-plane heads frozen (``--freeze plane``) on the shipped weights, two steps
    lower the 3D heads' loss, embedding included, and change none of the other outputs."""
    import torch

    from psdr_room_core.applications.train import LOSS_WEIGHTS, losses, predict
    from psdr_room_plugins.eyes.box3d import BOX_OUTPUTS, EMBEDDING
    from psdr_room_plugins.eyes.network import PLANE_OUTPUTS, EyesNet
    from psdr_room_plugins.eyes.perception import SHIPPED

    torch.manual_seed(0)
    net = EyesNet()
    net.load_onnx(SHIPPED)
    net.freeze_plane()
    proxies = torch.nn.Parameter(0.1 * torch.randn(len(pack.models), EMBEDDING))
    batch = _whole_pack_batch(pack)
    optimiser = torch.optim.AdamW([p for p in net.parameters() if p.requires_grad] + [proxies], lr=3e-3)
    assert {id(p) for p in net.parameters() if p.requires_grad} == {id(p) for p in net.box_parameters()}

    def box_loss() -> torch.Tensor:
        terms = losses(predict(net, batch["image"]), batch, proxies)
        return sum(LOSS_WEIGHTS[k] * terms[k] for k in BOX_OUTPUTS)

    with torch.no_grad():
        before = predict(net, batch["image"])
    first = box_loss()
    for _ in range(2):
        optimiser.zero_grad()
        box_loss().backward()
        optimiser.step()
    with torch.no_grad():
        assert float(box_loss()) < float(first)
        after = predict(net, batch["image"])
    assert all(torch.equal(before[name], after[name]) for name in PLANE_OUTPUTS)


def test_psdr_room_train_resumes_and_exports_a_network_onnxruntime_runs(pack, tmp_path: Path) -> None:
    import onnxruntime as ort
    import torch

    from psdr_room_core.applications.train import main as train
    from psdr_room_plugins.eyes.network import OUTPUTS

    pack_file = tmp_path / "pack.npz"
    pack.save(pack_file)
    run = ["--pack", str(pack_file), "--out", str(tmp_path / "run"), "--batch", "2", "--validation", "0.25"]
    run += ["--precision", "bf16"]
    train([*run, "--steps", "1"])
    train([*run, "--steps", "2"])  # --steps lengthens a run
    train([*run, "--epochs", "50"])  # a resumed run keeps its schedule: nothing more to do
    note = json.loads((tmp_path / "run" / "eyes.json").read_text())
    assert note["steps"] == 2 and note["samples"] == 4 and note["held_out"] == 1 and note["precision"] == "bf16"
    first = torch.load(tmp_path / "run" / "checkpoint.pt", weights_only=False)["history"][0]
    assert note["validation"]["seconds"] > first["seconds"] > 0  # the seconds of every call add up
    assert note["sha256"] == hashlib.sha256((tmp_path / "run" / "eyes.onnx").read_bytes()).hexdigest()
    assert (tmp_path / "run" / "curves.png").is_file()
    session = ort.InferenceSession(str(tmp_path / "run" / "eyes.onnx"))
    out = session.run(None, {"image": np.full((1, 3, 240, 320), 0.5, np.float32)})
    assert [o.shape[1] for o in out] == list(OUTPUTS.values()) and all(np.isfinite(o).all() for o in out)


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--seeds", "abc"], "--seeds abc: give a range"),
        (["--textures", "/no/such/folder"], "--textures /no/such/folder: no such folder"),
    ],
)
def test_the_data_engine_refuses_bad_arguments_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture, argv: list[str], says: str
) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["--out", str(tmp_path / "data"), *argv])
    assert exit_.value.code == 2 and says in capsys.readouterr().err
    assert not (tmp_path / "data").exists()


def test_psdr_room_train_refuses_a_folder_without_samples(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from psdr_room_core.applications.train import main as train

    with pytest.raises(SystemExit) as exit_:
        train(["--data", str(tmp_path), "--out", str(tmp_path / "run")])
    assert exit_.value.code == 2 and "no samples there" in capsys.readouterr().err


def test_psdr_room_train_refuses_a_pack_of_an_older_format_in_one_line(
    pack: Pack, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    from psdr_room_core.applications.train import main as train

    old = {k: getattr(pack, k) for k in pack.__dataclass_fields__ if k != "depth_cm"}
    np.savez_compressed(tmp_path / "old.npz", depth=pack.depth_cm.astype(np.float16) / 100, **old)
    with pytest.raises(SystemExit) as exit_:
        train(["--pack", str(tmp_path / "old.npz"), "--out", str(tmp_path / "run"), "--device", "cpu"])
    error = capsys.readouterr().err
    assert exit_.value.code == 2 and "older format (no depth_cm); delete it to rebuild" in error
    assert "Traceback" not in error and len(error.strip().splitlines()) == 1


def test_the_shipped_network_is_whole_and_sees_the_example_room() -> None:
    """The packaged eyes.onnx matches its note, fits the size budget, and on the bundled example (a real photo)
    finds walls and a floor, some furniture, and a depth that grows towards the far wall."""
    import cv2

    from conftest import EXAMPLE
    from psdr_room_core.method.artifacts import Camera, Detections, Image
    from psdr_room_plugins.eyes.perception import SHIPPED, EyesDepth, EyesSegmentation, shipped_note

    note = shipped_note()
    assert note["sha256"] == hashlib.sha256(SHIPPED.read_bytes()).hexdigest()
    assert SHIPPED.stat().st_size <= 25e6 and note["samples"] >= 800  # the 3D heads' renders
    assert note["init"]["note"]["samples"] >= 1000  # the renders the image-plane heads were trained on
    rgb = cv2.imread(str(EXAMPLE))[..., ::-1].astype(np.float32) / 255.0
    image = Image(rgb=rgb)
    camera = Camera(image.width, image.height, 519.0, 519.0, image.width / 2, image.height / 2)
    panoptic = EyesSegmentation().segment(image, camera, Detections([]), EXAMPLE)
    categories = {s.category for s in panoptic.segments}
    assert {"wall", "floor"} <= categories and categories & {"object", "lamp"}
    depth = EyesDepth().estimate(image, camera, panoptic, EXAMPLE)
    assert depth.valid.all() and not depth.metric
    floor = panoptic.ids == next(s.id for s in panoptic.segments if s.category == "floor")
    rows = np.nonzero(floor.any(axis=1))[0]
    near, far = rows.max(), rows.min()  # the floor recedes up the photo
    assert np.median(depth.depth[near][floor[near]]) < np.median(depth.depth[far][floor[far]])


def test_the_shipped_network_gives_each_instance_a_3d_box_and_its_catalogue_names_database_models() -> None:
    """onnxruntime runs the shipped network's 3D heads on the bundled example: each piece of furniture it finds
    has a box in front of the camera, of a furniture's size; the catalogue beside it matches its note and names
    models of the object database, each with a unit embedding."""
    import cv2

    from conftest import EXAMPLE
    from psdr_room_core.libraries.object_db.builtin import builtin_database
    from psdr_room_core.method.artifacts import Image
    from psdr_room_plugins.eyes.box3d import CATALOGUE, EMBEDDING, read_box
    from psdr_room_plugins.eyes.decode import instances
    from psdr_room_plugins.eyes.perception import SHIPPED, Eyes, shipped_note

    rgb = cv2.imread(str(EXAMPLE))[..., ::-1].astype(np.float32) / 255.0
    out = Eyes().outputs(Image(rgb=rgb))
    found = instances(out["surface"], out["category"], out["center"], out["offset"])
    focal = 519.0 * 240 / rgb.shape[0]  # the example's focal in the network's input pixels
    boxes = [read_box(out, item.mask, focal, focal) for item in found]
    assert len(boxes) >= 2
    for box in boxes:
        assert 0.3 < box.center[2] < 12 and ((box.size > 0.02) & (box.size < 5)).all()
        assert 0 < box.yaw_confidence <= 1 and box.embedding @ box.embedding == pytest.approx(1.0)
    catalogue = SHIPPED.with_name(CATALOGUE)
    assert shipped_note()["catalogue"]["sha256"] == hashlib.sha256(catalogue.read_bytes()).hexdigest()
    with np.load(catalogue) as data:
        ids, embeddings = data["model_ids"], data["embeddings"]
    assert set(ids) <= {r.id for r in builtin_database().records} and len(ids) >= 150
    assert embeddings.shape == (len(ids), EMBEDDING) and np.allclose(np.linalg.norm(embeddings, axis=1), 1, atol=1e-5)


def test_segmentation_eyes_gives_each_piece_of_furniture_its_3d_box_for_the_photos_camera() -> None:
    """``segmentation=eyes`` on the bundled example: every furniture segment carries the network's box, in front of
    the camera and saved with the segmentation; a camera of twice the focal sees each box twice as far (the same
    apparent size) at the same yaw."""
    import cv2

    from conftest import EXAMPLE
    from psdr_room_core.method.artifacts import Camera, Detections, Image
    from psdr_room_plugins.eyes.perception import EyesSegmentation

    rgb = cv2.imread(str(EXAMPLE))[..., ::-1].astype(np.float32) / 255.0
    image, height, width = Image(rgb=rgb), *rgb.shape[:2]
    camera = Camera(width=width, height=height, fx=519.0, fy=519.0, cx=width / 2, cy=height / 2)
    longer = Camera(width=width, height=height, fx=1038.0, fy=1038.0, cx=width / 2, cy=height / 2)
    segments = [s for s in EyesSegmentation().segment(image, camera, Detections([]), EXAMPLE).segments if s.seen]
    assert len(segments) >= 2 and all(s.category in ("object", "lamp") for s in segments)
    farther = {s.id: s.seen for s in EyesSegmentation().segment(image, longer, Detections([]), EXAMPLE).segments}
    for segment in segments:
        seen, far = segment.seen, farther[segment.id]
        assert seen is not None and far is not None and seen.center[2] > 0.3
        assert far.center[2] == pytest.approx(2 * seen.center[2], rel=1e-4)
        assert far.size == seen.size and 0 < seen.confidence <= 1


def test_the_shipped_embedding_ranks_a_rendered_model_near_the_top_of_its_category(made: Tools) -> None:
    """On rooms the network never saw (seeds beyond its data's), ``retrieval=eyes``' appearance ranks the model the
    generator placed near the top of its category's models for the well-seen objects (chance: the middle)."""

    from psdr_room_core.engine import shipped
    from psdr_room_core.method.objects import ObjectQuery
    from psdr_room_plugins.eyes.plugin import EyesRetrievalSettings
    from psdr_room_plugins.eyes.retrieval import EyesRetrieval

    eyes = EyesRetrieval(**shipped.arguments(EyesRetrievalSettings, "retrieval.eyes", "retrieval=eyes"))
    ranks, chance = [], []
    for seed in range(20000, 20006):
        sample = sample_room(seed, made.database, made.library, [], 320, 240)
        instance = label_maps(sample, made.renderer)["instance"]
        photo = render_photo(sample, made.renderer, made.denoiser, 16).astype(np.float32) / 255.0
        for value, box in sample.boxes.items():
            mask = instance == value
            if mask.sum() < 600 or not box.model_id:
                continue
            category = made.database.record(box.model_id).category
            none = np.zeros((0, 3))
            query = ObjectQuery(
                value, category, (category,), mask, none, np.zeros((4, 4, 3), np.uint8), none, photo=photo
            )
            seen = {m: v[0] for m, v in eyes.appearance(query).items() if eyes.category(m) == category}
            ranks.append(sorted(seen, key=lambda m: -seen[m]).index(box.model_id))
            chance.append((len(seen) - 1) / 2)
    assert len(ranks) >= 10
    assert np.median(ranks) <= 3 < np.median(chance) - 4
    assert np.mean(np.array(ranks) < 3) >= 0.4


def test_an_eyes_box_adds_to_nanodets_where_it_names_what_coco_cannot_or_nanodet_boxed_nothing() -> None:
    from psdr_room_core.method.artifacts import Detection, Detections
    from psdr_room_plugins.eyes.with_nanodet import COCO_NAMED, NanodetAndEyes, added_boxes

    coco = Detections(
        [Detection("bed", "object", (0, 0, 100, 100), 0.4), Detection("chair", "object", (200, 0, 300, 100), 0.3)]
    )
    eyes = Detections(
        [
            Detection("desk", "object", (0, 0, 100, 100), 0.9),  # on NanoDet's "bed", but COCO has no desk: added
            Detection("sofa", "object", (205, 0, 300, 100), 0.8),  # NanoDet boxed it (IoU 0.95), names sofas: left
            Detection("chair", "object", (240, 0, 340, 100), 0.7),  # IoU 0.43 with NanoDet's chair: added
            Detection("other", "object", (0, 0, 95, 100), 0.6),  # of no known kind, on NanoDet's box: left
            Detection("chair", "object", (500, 0, 600, 100), 0.5),  # nothing boxed there: added
        ]
    )
    named = NanodetAndEyes().named  # built with its own defaults, as an auto.order name without a config node
    assert named == frozenset(COCO_NAMED)
    added, left = added_boxes(coco, eyes, named, 0.5)
    assert [d.label for d in added] == ["desk", "chair", "chair"] and [d.label for d in left] == ["sofa", "other"]
    assert added_boxes(coco, eyes, named, 0.96)[0] == eyes.items  # no NanoDet box is that close to any
    assert added_boxes(Detections([]), eyes, named, 0.5)[0] == eyes.items
    assert "sofa" in [d.label for d in added_boxes(coco, eyes, frozenset({"chair"}), 0.5)[0]]  # NanoDet on chairs only


def test_nanodet_and_eyes_together_name_the_desks_nanodet_calls_beds() -> None:
    """``detector=nanodet_eyes`` built from its config: each member gets its own node's settings. On a classroom
    of desks (SUN RGB-D, held out) NanoDet calls the desks "bed" and "chair" (COCO has no desk); the combination
    keeps every NanoDet box and adds the eyes network's desks."""
    import dataclasses

    from conftest import SHARED_DATA
    from psdr_room_core.engine.cli import compose_config
    from psdr_room_core.engine.dag import typed_settings
    from psdr_room_core.engine.plugins import plugin_system
    from psdr_room_core.engine.run import resolve_config
    from psdr_room_core.method.artifacts import Image
    from psdr_room_core.method.photo import read_photo, resize_to_working

    photo = SHARED_DATA / "photos" / "sunrgbd_total3d_04" / "img.jpg"
    if not photo.is_file():
        pytest.skip(f"{photo} is not here")
    system = plugin_system()
    config = resolve_config(
        compose_config(
            [f"image={photo}", "detector=nanodet_eyes", "detector.nanodet_onnx.score_threshold=0.25"], system
        )
    )
    implementation = system.registry.implementation("detector", "nanodet_eyes")
    settings = typed_settings(implementation.params, config["detector"]["nanodet_eyes"])
    detector = implementation.factory(**{f.name: getattr(settings, f.name) for f in dataclasses.fields(settings)})
    assert detector.nanodet.score_threshold == 0.25 and detector.eyes.center_threshold == 0.3
    assert detector.unavailable(photo) is None and len(detector.external_files(photo)) == 2
    rgb = read_photo(photo, 10**8)
    image = Image(rgb=resize_to_working(rgb, 800), original_size=(rgb.shape[1], rgb.shape[0]))
    both = detector.detect(image, photo)
    coco, eyes = detector.nanodet.detect(image, photo), detector.eyes.detect(image, photo)
    assert both.source == f"{coco.source} + {eyes.source}"
    scores = [d.score for d in both.items]
    assert scores == sorted(scores, reverse=True)
    assert set(coco.items) <= set(both.items) <= set(coco.items) | set(eyes.items)
    assert "desk" not in {d.label for d in coco.items} and {"bed", "chair"} <= {d.label for d in coco.items}
    assert sum(d.label == "desk" for d in both.items) >= 3
    assert any(d not in both.items for d in eyes.items)  # an eyes chair NanoDet boxed too is left to NanoDet


def test_auto_takes_the_layout_helped_by_the_eyes_for_segmentation_and_depth(tmp_path: Path) -> None:
    """On a bare photo (the example without its files) ``segmentation=auto`` takes ``layout_eyes``: layout's box
    room, fitted to the eyes network's walls, floor and ceiling as well as to the lines, agrees with them better
    than layout's alone; ``depth=auto`` takes ``layout_eyes`` too, which places every object; without eyes.onnx,
    layout alone for both, and the run says why."""
    import shutil

    from conftest import EXAMPLE
    from psdr_room_core.engine.cli import compose_config
    from psdr_room_core.engine.dag import typed_settings
    from psdr_room_core.engine.run import execute, resolve_config
    from psdr_room_plugins.eyes.perception import Eyes

    photo = tmp_path / EXAMPLE.name
    shutil.copy(EXAMPLE, photo)
    plugins = plugin_system()
    overrides = [
        f"image={photo}",
        f"cache_dir={tmp_path / 'cache'}",
        "run.until=estimate_depth",
        "report.enabled=false",
        "segmentation.layout.n_random=800",
        "depth.layout.n_random=800",
    ]
    records = {
        name: execute(compose_config(overrides + extra, plugins), tmp_path / name, plugins)
        for name, extra in (
            ("eyes", []),
            (
                "alone",
                [f"segmentation.eyes.path={tmp_path / 'none.onnx'}", f"depth.eyes.path={tmp_path / 'none.onnx'}"],
            ),
        )
    }
    assert records["eyes"].implementations["segmentation"]["name"] == "layout_eyes"
    assert records["eyes"].implementations["depth"]["name"] == "layout_eyes"
    assert records["alone"].implementations["depth"]["name"] == "layout"
    assert records["eyes"].artifacts["depth"].unplaced == () and records["alone"].artifacts["depth"].unplaced
    config = resolve_config(compose_config([*overrides, "segmentation=layout_eyes"], plugins))
    implementation = plugins.registry.implementation("segmentation", "layout_eyes")
    settings = typed_settings(implementation.params, config["segmentation"]["layout_eyes"])
    assert settings.layout.n_random == 800 and settings.eyes.center_threshold == 0.3  # each member's own node
    assert records["alone"].implementations["segmentation"]["name"] == "layout"
    assert "not layout_eyes: no eyes network at" in records["alone"].implementations["segmentation"]["selected_by"]
    image = records["eyes"].artifacts["image"]
    eyes = Eyes()
    seen = eyes.surfaces(image, eyes.outputs(image))
    room = np.isin(seen, [labels.SURFACES.index(s) for s in ("wall", "floor", "ceiling")])
    agreement = {}
    for name, record in records.items():
        panoptic = record.artifacts["panoptic"]
        surfaces = {s: panoptic.mask(s) for s in ("wall", "floor", "ceiling")}
        both = room & np.logical_or.reduce(list(surfaces.values()))
        same = [surfaces[s] & (seen == labels.SURFACES.index(s)) for s in surfaces]
        agreement[name] = np.logical_or.reduce(same).sum() / both.sum()  # where both see the room
    assert agreement["eyes"] > agreement["alone"], agreement
