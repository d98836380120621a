"""Lighting and appearance (§4.4 second half): the light layout rules, the initial radiance sweep, the joint
material–lighting fit on a room rendered with known materials and lights, the exported scene (Mitsuba XML
renders what the fit rendered; the .glb loads and validates), and psdr-room-edit."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import torch

from psdr_room_core.applications.edit import main as edit_main
from psdr_room_core.engine import shipped
from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import (
    Camera,
    Image,
    Light,
    Lights,
    MaterialAssignment,
    Panoptic,
    PartAppearance,
    PartMaterial,
    Placements,
    PointCloud,
    RoomBox,
    Segment,
)
from psdr_room_core.method.lighting import behind_camera, in_view
from psdr_room_core.method.material_priors import PaintPrior
from psdr_room_core.method.rgb_scene import build_scene, initial_parts, part_meshes, render_part_ids, room_quads
from psdr_room_core.method.shading import linear_to_srgb, srgb_to_linear
from psdr_room_core.method.stages.appearance import (
    AppearanceModel,
    eq4_targets,
    eq4_terms,
    fit_appearance,
    picture,
    plain_parts,
)
from psdr_room_core.method.stages.export import export_scene
from psdr_room_core.method.stages.lighting import init_lights, white_balance
from psdr_room_core.method.stages.settings import FitAppearance
from psdr_room_plugins.denoisers import OidnDenoiser
from psdr_room_plugins.material_graph.library import TorchGraphLibrary
from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer
from psdr_room_plugins.optimizer_adam import Adam
from psdr_room_plugins.texture.random_cnn import RandomCnnDescriptor

ROOT = Path(__file__).resolve().parents[1]


def model_settings() -> dict[str, Any]:
    """The shipped ``fit_appearance`` settings an :class:`AppearanceModel` takes (besides its map size)."""
    fit = shipped.settings(FitAppearance, "fit_appearance")
    return {"radiance_range": fit.radiance_range, "colour_range": fit.colour_range, "paint": fit.paint}


def _c2w(z: float, pitch_deg: float) -> np.ndarray:
    c2w = np.eye(4)
    tilt = math.radians(pitch_deg)
    pitch = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
    c2w[:3, :3] = np.diag([-1.0, -1.0, 1.0]) @ pitch  # OpenCV camera looking along world +Z, Y up, pitched down
    c2w[:3, 3] = [0.0, 1.5, z]
    return c2w


C2W = _c2w(-0.5, -25.0)
ROOM = RoomBox(camera_to_world=C2W, center=np.array([0.0, 1.5, 0.0]), half_size=np.array([3.0, 1.5, 3.0]), yaw=0.0)
CAMERA = Camera.from_vfov(96, 72, 60.0)
TRUE_SRGB = {
    "floor": (0.45, 0.36, 0.30),
    "ceiling": (0.85, 0.85, 0.82),
    "wall_x_neg": (0.70, 0.55, 0.40),
    "wall_x_pos": (0.40, 0.55, 0.70),
    "wall_z_neg": (0.6, 0.6, 0.6),
    "wall_z_pos": (0.55, 0.65, 0.45),
}
TRUE_RADIANCE = 2.5
LIGHT_PARAMS = {**shipped.node("init_lights"), "render_width": 96}
FIT_PARAMS = {
    **shipped.node("fit_appearance"),
    "iterations": 40,
    "render_width": 96,
    "spp": 8,
    "grad_spp": 4,
    "final_spp": 128,
    "map_size": 32,
    "min_region_px": 16,
    "plain_check": False,
}  # the graph's own fit; the plain check has its own test


@pytest.fixture(scope="module")
def library() -> TorchGraphLibrary:
    return TorchGraphLibrary(use_plugins=False)


def _implementations(library: TorchGraphLibrary) -> dict:
    return {
        "renderer": MitsubaRenderer(spp=4),
        "material_graph": library,
        "texture": RandomCnnDescriptor(),
        "optimizer": Adam(),
        "denoiser": OidnDenoiser(quality="fast"),
    }


def _assignment(albedo: dict[str, tuple[float, float, float]]) -> MaterialAssignment:
    return MaterialAssignment(parts=[PartMaterial(name, "homogeneous", albedo[name]) for name in TRUE_SRGB])


@pytest.fixture(scope="module")
def photo(library: TorchGraphLibrary) -> tuple[Image, Panoptic, Lights]:
    """The room rendered with the true albedo and every initial light at the true radiance, and its labels."""
    ctx = StageContext("init_lights", LIGHT_PARAMS, 0, Path("photo.png"), _implementations(library))
    empty = Panoptic(ids=np.zeros((72, 96), np.int32), segments=[])
    grey = _assignment({n: (0.5, 0.5, 0.5) for n in TRUE_SRGB})
    layout = init_lights(
        ctx, Image(rgb=np.full((72, 96, 3), 0.5, np.float32)), empty, CAMERA, ROOM, Placements(objects=[]), grey
    )
    lights = [Light(l.name, l.kind, l.mesh, (TRUE_RADIANCE,) * 3, l.part) for l in layout.lights]
    parts = initial_parts(_assignment(TRUE_SRGB), library)
    scene = build_scene(part_meshes(ROOM, Placements(objects=[])), parts, lights, layout.fixtures, library, 32)
    with torch.no_grad():
        linear = scene.renderer(MitsubaRenderer(), CAMERA, C2W, 96).render_rgb(spp=1024).numpy()
    meshes = part_meshes(ROOM, Placements(objects=[]))
    ids, _ = render_part_ids(MitsubaRenderer(spp=4), CAMERA, C2W, meshes, 96)
    names = list(meshes)
    category = {n: n.split("_")[0] for n in names}
    seg_ids = {"floor": 1, "ceiling": 2, "wall": 3}
    labels = np.array([0] + [seg_ids[category[n]] for n in names], np.int32)[ids + 1]
    panoptic = Panoptic(
        ids=labels,
        segments=[Segment(1, "floor", "floor"), Segment(2, "ceiling", "ceiling"), Segment(3, "wall", "wall")],
    )
    return Image(rgb=linear_to_srgb(linear).astype(np.float32), original_size=(96, 72)), panoptic, layout


def test_light_layout_follows_the_paper(photo: tuple[Image, Panoptic, Lights]) -> None:
    _, _, layout = photo
    kinds = [l.kind for l in layout.lights]
    # 3x3 ceiling cells: the row behind the camera goes, none of the others is in the (downward) view.
    assert kinds.count("ceiling") == 6 and kinds.count("behind_camera") == 1
    # Only the far wall is in view (the side walls lie outside the 75° horizontal field of view).
    assert sorted(l.name for l in layout.lights if l.kind == "invisible_wall") == [
        "light_wall_x_neg",
        "light_wall_x_pos",
        "light_wall_z_neg",
    ]
    for light in layout.lights:
        quad = light.mesh.vertices
        assert not in_view(quad, CAMERA, C2W) and not behind_camera(quad, C2W) or light.kind != "ceiling"
        normal = np.cross(quad[1] - quad[0], quad[2] - quad[0])
        assert np.dot(normal, ROOM.center - quad.mean(axis=0)) > 0, light.name  # every panel lights the room
    behind = next(l for l in layout.lights if l.kind == "behind_camera").mesh.vertices
    assert np.all(behind[:, 2] < C2W[2, 3]) and np.all(behind[:, 2] > -3.0)  # between the camera and its back wall
    # Tilted up, the camera sees the ceiling: the cells in view are removed.
    up = _c2w(-0.5, 20.0)
    cells = [q for q in room_quads(ROOM)["ceiling"][None]]
    assert in_view(cells[0], CAMERA, up) and not in_view(cells[0], CAMERA, C2W)


def test_initial_radiance_is_recovered_from_one_render(
    library: TorchGraphLibrary, photo: tuple[Image, Panoptic, Lights]
) -> None:
    image, panoptic, _ = photo
    ctx = StageContext("init_lights", LIGHT_PARAMS, 0, Path("photo.png"), _implementations(library))
    lights = init_lights(ctx, image, panoptic, CAMERA, ROOM, Placements(objects=[]), _assignment(TRUE_SRGB))
    radiances = {l.radiance for l in lights.lights}
    assert len(radiances) == 1
    rgb = np.array(radiances.pop())
    chosen = float(rgb @ [0.2126, 0.7152, 0.0722])
    step = (LIGHT_PARAMS["sweep"]["max"] / LIGHT_PARAMS["sweep"]["min"]) ** (1 / (LIGHT_PARAMS["sweep"]["count"] - 1))
    assert 1 / step <= chosen / TRUE_RADIANCE <= step, chosen
    assert np.allclose(rgb / chosen, 1.0, atol=0.03), rgb  # white lights made the photo: white lights come back
    assert set(lights.images) == {"initial_render", "radiance_sweep"}


@pytest.fixture(scope="module")
def fitted(library: TorchGraphLibrary, photo: tuple[Image, Panoptic, Lights]) -> dict:
    """fit_appearance from dim lights, the parts starting at the photo's median colours (grey where unseen); the
    floor starts as a procedural graph."""
    image, panoptic, layout = photo
    meshes = part_meshes(ROOM, Placements(objects=[]))
    ids, _ = render_part_ids(MitsubaRenderer(spp=4), CAMERA, C2W, meshes, 96)
    medians = {
        n: tuple(float(c) for c in np.median(image.rgb[ids == k], axis=0))
        for k, n in enumerate(meshes)
        if (ids == k).any()
    }
    parts = []
    for name in TRUE_SRGB:
        colour = medians.get(name, (0.6, 0.6, 0.6))
        if name == "floor":
            parts.append(
                PartMaterial(
                    name, "procedural", colour, material="herringbone_oak", scale=2.0, crops=((20, 50, 76, 72),)
                )
            )
        else:
            parts.append(
                PartMaterial(name, "homogeneous", colour, crops=((40, 2, 70, 20),) if name == "wall_z_pos" else ())
            )
    start = Lights(
        lights=[Light(l.name, l.kind, l.mesh, (1.0, 1.0, 1.0), l.part) for l in layout.lights], fixtures=layout.fixtures
    )
    ctx = StageContext("fit_appearance", FIT_PARAMS, 0, Path("photo.png"), _implementations(library))
    out = fit_appearance(ctx, image, CAMERA, ROOM, Placements(objects=[]), MaterialAssignment(parts=parts), start)
    return {"out": out, "start": start, "materials": MaterialAssignment(parts=parts)}


def test_fit_appearance_matches_the_photo_better(fitted: dict, library: TorchGraphLibrary) -> None:
    log = fitted["out"]["log"]
    s = log.summary
    assert s["rmse"] < 0.3 * s["rmse_init"], s  # (SSIM: the flat photo floor against a textured one decides it)
    assert s["flip"] < s["flip_init"] and s["denoiser"].startswith("oidn"), s
    assert s["ssim"] > s["ssim_noisy"], s  # the denoised picture is the closer one
    first, last = log.history[0], log.history[-1]
    assert last["image"] < first["image"] and last["colour"] < first["colour"]
    appearance = fitted["out"]["appearance"]
    radiance = np.mean([v[0] for v in appearance.radiance.values()])
    assert radiance > 1.2  # the dim start brightens towards the truth (2.5)
    chroma = np.array([np.asarray(v) / np.sum(v) for v in appearance.radiance.values()])
    assert len(chroma) > 1 and np.ptp(chroma, axis=0).max() < 1e-5  # intensities differ, the colour is shared
    floor = appearance.part("floor")
    start = library.material("herringbone_oak").bounds
    moved = [k for k, v in floor.params.items() if not np.allclose(v, start[k].value.numpy(), atol=1e-4)]
    assert floor.kind == "procedural" and moved  # gradients reached the graph's parameters
    for key, value in floor.params.items():
        lo, hi = (np.asarray(start[key].lo, np.float64), np.asarray(start[key].hi, np.float64))
        assert np.all(np.asarray(value) >= lo - 1e-6) and np.all(np.asarray(value) <= hi + 1e-6)
    # The far wall (seen) takes its true chroma (green > red > blue); the walls out of view keep their start.
    far = appearance.part("wall_z_pos").base_color
    assert far[1] > far[0] > far[2]
    start = {p.part: p for p in initial_parts(fitted["materials"], library)}
    for hidden in ("wall_x_neg", "wall_x_pos", "wall_z_neg"):
        assert appearance.part(hidden) == start[hidden]
    assert set(log.images) == {"photo_init_final", "crop_pairs", "loss"}


def test_the_photo_itself_scores_zero_on_every_term_of_eq4(
    library: TorchGraphLibrary, photo: tuple[Image, Panoptic, Lights]
) -> None:
    """Each part's colour target is the photo's mean over the pixels the render's mean is taken over, so a render
    equal to the photo leaves no term of eq. 4 to lower. The paper's C_i, the median photo colour of those
    pixels, is not the mean of a lit wall: it would ask the render for a colour the photo does not have."""
    image, _, _ = photo
    meshes = part_meshes(ROOM, Placements(objects=[]))
    assignment = MaterialAssignment(
        parts=[
            PartMaterial(n, "homogeneous", (0.5, 0.5, 0.5), crops=((40, 2, 70, 20),) if n == "wall_z_pos" else ())
            for n in TRUE_SRGB
        ]
    )
    ctx = StageContext("fit_appearance", FIT_PARAMS, 0, Path("photo.png"), _implementations(library))
    settings, descriptor = ctx.settings(FitAppearance), RandomCnnDescriptor()
    renderer = MitsubaRenderer(spp=4)
    targets = eq4_targets(image, CAMERA, C2W, assignment, meshes, meshes, renderer, descriptor, settings, 96)
    assert len(targets.regions) == 2 and targets.crops  # the floor and the far wall
    terms = eq4_terms(srgb_to_linear(torch.from_numpy(targets.photo)), targets, descriptor, settings.downsample)
    assert set(terms) == {"image", "colour", "texture"}
    assert all(float(value) < 1e-5 for value in terms.values()), terms
    medians = [np.median(targets.photo[mask.numpy()], axis=0) for mask, _ in targets.regions]
    assert max(float(np.abs(m - c.numpy()).mean()) for m, (_, c) in zip(medians, targets.regions)) > 0.002


def test_fit_appearance_stops_on_a_plateau(library: TorchGraphLibrary, photo: tuple[Image, Panoptic, Lights]) -> None:
    image, _, layout = photo
    parts = MaterialAssignment(parts=[PartMaterial(name, "homogeneous", (0.5, 0.5, 0.5)) for name in TRUE_SRGB])
    # Any two windows of 2 iterations whose means differ by less than 90%: flat at once, after the minimum.
    params = {**FIT_PARAMS, "convergence": {"window": 2, "tolerance": 0.9, "min_iterations": 5}, "final_spp": 16}
    ctx = StageContext("fit_appearance", params, 0, Path("photo.png"), _implementations(library))
    out = fit_appearance(ctx, image, CAMERA, ROOM, Placements(objects=[]), parts, layout)
    assert len(out["log"].history) == out["log"].summary["iterations"] == 5 < params["iterations"]


@pytest.mark.parametrize("photo_pattern", [False, True], ids=["plain photo floor", "patterned photo floor"])
def test_a_pattern_the_photo_does_not_show_is_made_plain(
    library: TorchGraphLibrary, photo: tuple[Image, Panoptic, Lights], photo_pattern: bool
) -> None:
    image, _, layout = photo
    lights = Lights(
        lights=[Light(l.name, l.kind, l.mesh, (TRUE_RADIANCE,) * 3, l.part) for l in layout.lights],
        fixtures=layout.fixtures,
    )
    floor = PartMaterial("floor", "procedural", TRUE_SRGB["floor"], material="herringbone_oak", scale=2.0)
    assignment = MaterialAssignment(
        parts=[floor] + [PartMaterial(n, "homogeneous", TRUE_SRGB[n]) for n in TRUE_SRGB if n != "floor"]
    )
    parts = initial_parts(assignment, library)
    meshes = part_meshes(ROOM, Placements(objects=[]))
    geometry = build_scene(meshes, parts, lights.lights, lights.fixtures, library, 32).renderer(
        MitsubaRenderer(), CAMERA, C2W, 96
    )
    model = AppearanceModel(parts, lights, library, map_size=32, **model_settings())
    denoiser = OidnDenoiser(quality="fast")
    patterned = picture(geometry, denoiser, model.inputs(), 128, 1)
    # the photo: the same room with a plain floor, or with the pattern (independent samples)
    target = picture(geometry, denoiser, model.inputs(), 512, 7)[1] if photo_pattern else image.rgb
    ids, _ = render_part_ids(MitsubaRenderer(spp=4), CAMERA, C2W, meshes, 96)
    final = plain_parts(model, geometry, denoiser, 128, target, patterned, {n: ids == k for k, n in enumerate(meshes)})
    assert model.plain == (set() if photo_pattern else {"floor"})
    floor_pixels = ids == list(meshes).index("floor")
    spread = final[1][floor_pixels].std(0).max()
    assert (spread > 0.03) if photo_pattern else (spread < patterned[1][floor_pixels].std(0).max())
    written = {p.part: p for p in model.result()[0]}["floor"]
    assert written.kind == ("procedural" if photo_pattern else "homogeneous")


@pytest.fixture(scope="module")
def exported(fitted: dict, library: TorchGraphLibrary, tmp_path_factory: pytest.TempPathFactory) -> Path:
    ctx = StageContext(
        "export_scene",
        {"spp": 64, "max_depth": 3, "texture_size": 64, "glb": True, "usd": True},
        0,
        Path("photo.png"),
        {"material_graph": library},
    )
    cloud = PointCloud(
        points=np.zeros((1, 3)), colors=np.zeros((1, 3), np.uint8), segment=np.zeros(1, np.int32), segments=[]
    )
    files = export_scene(ctx, CAMERA, ROOM, cloud, Placements(objects=[]), fitted["start"], fitted["out"]["appearance"])
    folder = tmp_path_factory.mktemp("scene")
    for name, data in files.files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)
    return folder


def test_exported_xml_renders_what_the_fit_rendered(exported: Path, fitted: dict) -> None:
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    scene = mi.load_file(str(exported / "scene.xml"), spp=256)
    image = linear_to_srgb(np.array(mi.render(scene)))
    fit = fitted["out"]["appearance"].images["render"].astype(np.float64) / 255.0
    small = [cv2.resize(np.asarray(x, np.float32), (24, 18), interpolation=cv2.INTER_AREA) for x in (image, fit)]
    assert image.shape == fit.shape
    assert np.abs(small[0] - small[1]).mean() < 0.02


def test_every_part_is_a_shape_mitsuba_reaches_by_id(tmp_path: Path) -> None:
    """Parts of one material (two walls, a door's panel and handles) stay apart when Mitsuba loads the XML with
    its default optimisations, which merge meshes of equal materials into one unnamed shape: every part and
    light is a shape of its own id that ``mi.traverse`` reaches, and the exported meshes read back."""
    import mitsuba as mi

    from psdr_room_core.method.geometry import quad_mesh
    from psdr_room_core.method.rgb_scene import RgbScene
    from psdr_room_core.method.shading import Surface
    from psdr_room_core.method.stages.export import read_mesh_ply, scene_folder, scene_state

    quads = {
        name: quad_mesh(np.array([[x, 0, 3], [x + 1, 0, 3], [x + 1, 1, 3], [x, 1, 3]], float))
        for x, name in enumerate(["wall_a", "wall_b", "door_panel", "door_handles"])
    }
    scene = RgbScene(
        meshes=quads,
        surfaces={name: Surface((0.6, 0.6, 0.6), 0.5, 0.5) for name in quads},
        emitters={"light_a": (quads["wall_a"], (3.0, 3.0, 3.0)), "light_b": (quads["wall_b"], (3.0, 3.0, 3.0))},
    )
    state = scene_state(CAMERA, C2W, [], [], [], 64)
    for name, data in scene_folder(scene, state, spp=4, max_depth=3, glb=False, usd=False).items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(data)
    mi.set_variant("scalar_rgb")
    loaded = mi.load_file(str(tmp_path / "scene.xml"))
    ids = sorted(shape.id() for shape in loaded.shapes())
    assert ids == sorted([*quads, "light_a", "light_b"])
    keys = set(mi.traverse(loaded).keys())
    assert all(f"{name}.vertex_positions" in keys for name in ids)
    mesh, uv = read_mesh_ply((tmp_path / "meshes" / "door_panel.ply").read_bytes(), "door_panel.ply")
    assert np.allclose(mesh.vertices, quads["door_panel"].vertices) and (mesh.faces == quads["door_panel"].faces).all()
    assert uv is None


def test_glb_loads_and_validates(exported: Path) -> None:
    import trimesh

    state = json.loads((exported / "appearance.json").read_text())
    scene = trimesh.load(exported / "scene.glb")
    assert len(scene.geometry) == len(state["parts"]) + len(state["lights"]) + len(state["fixtures"])
    floor = scene.geometry["floor"]
    assert floor.visual.uv is not None and floor.visual.material.baseColorTexture is not None
    validator = ROOT / ".venv" / "node_modules" / "gltf-validator"
    node = shutil.which("node")
    if node is None or not validator.is_dir():
        pytest.skip(
            "the Khronos glTF validator is not installed (scripts/setup.sh --test installs it where npm exists)"
        )
    script = (
        "const v = require(process.argv[1]); const fs = require('fs');"
        "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[2]))).then(r => console.log(JSON.stringify("
        "{errors: r.issues.numErrors, warnings: r.issues.numWarnings, messages: r.issues.messages})));"
    )
    result = subprocess.run(
        [node, "-e", script, str(validator), str(exported / "scene.glb")], capture_output=True, text=True, timeout=120
    )
    report = json.loads(result.stdout)
    assert report["errors"] == 0 and report["warnings"] == 0, report["messages"][:5]


def _glb_json(path: Path) -> dict:
    data = path.read_bytes()
    length = int.from_bytes(data[12:16], "little")
    return json.loads(data[20 : 20 + length])


def test_glb_carries_the_fitted_specular_the_lights_and_the_photo_aspect(exported: Path) -> None:
    """What Blender and three.js read from the glb: each part's specular (0.08 s at normal incidence = 2 s of
    glTF's 0.04), a spot light standing in for each area light beside its emissive panel, the camera's aspect."""
    state = json.loads((exported / "appearance.json").read_text())
    gltf = _glb_json(exported / "scene.glb")
    materials = {m["name"]: m for m in gltf["materials"]}
    for part in state["parts"]:
        factor = materials[part["part"]]["extensions"]["KHR_materials_specular"]["specularColorFactor"]
        assert factor == pytest.approx([2 * part["specular"]] * 3, rel=1e-6)
    lights = gltf["extensions"]["KHR_lights_punctual"]["lights"]
    assert sorted(light["name"] for light in lights) == sorted(f"{l['name']}_stand_in" for l in state["lights"])
    assert all(light["type"] == "spot" and light["intensity"] > 0 for light in lights)
    assert {"KHR_lights_punctual", "KHR_materials_specular"} <= set(gltf["extensionsUsed"])
    camera = state["camera"]
    assert gltf["cameras"][0]["perspective"]["aspectRatio"] == pytest.approx(camera["width"] / camera["height"])
    names = [node["name"] for node in gltf["nodes"]]
    assert len(names) == len(set(names)) and {p["part"] for p in state["parts"]} <= set(names)


def test_the_studios_glb_keeps_everything_but_the_punctual_lights(exported: Path) -> None:
    """The studio's viewer lights the scene itself: its copy of the glb drops the photometric stand-ins (which it
    would read as its own units, a white room) and keeps every mesh, material, emissive panel and the camera."""
    import trimesh

    from psdr_room_core.method.gltf import without_lights

    whole = (exported / "scene.glb").read_bytes()
    unlit = without_lights(whole)
    gltf, original = (
        json.loads(unlit[20 : 20 + int.from_bytes(unlit[12:16], "little")]),
        _glb_json(exported / "scene.glb"),
    )
    assert "KHR_lights_punctual" not in json.dumps(gltf) and "KHR_lights_punctual" in json.dumps(original)
    assert gltf["meshes"] == original["meshes"] and gltf["materials"] == original["materials"]
    assert [n["name"] for n in gltf["nodes"]] == [n["name"] for n in original["nodes"]]
    assert len(unlit) % 4 == 0 and int.from_bytes(unlit[8:12], "little") == len(unlit)
    scene = trimesh.load(trimesh.util.wrap_as_stream(unlit), file_type="glb")
    assert set(scene.geometry) == set(trimesh.load(exported / "scene.glb").geometry)


def test_usd_stage_opens_validates_and_reads_back(exported: Path) -> None:
    """scene.usda: no error from any of USD's registered validators; metres, Y up; every part a mesh bound to its
    UsdPreviewSurface (maps where the part is procedural); every light a UsdLux light of its radiance; the camera's
    aperture has the photo's aspect."""
    from pxr import Usd, UsdGeom, UsdLux, UsdShade, UsdValidation

    from psdr_room_core.method.usd import specular_ior

    stage = Usd.Stage.Open(str(exported / "scene.usda"))
    registry = UsdValidation.ValidationRegistry()
    errors = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators()).Validate(stage)
    assert [e.GetMessage() for e in errors] == []
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    state = json.loads((exported / "appearance.json").read_text())
    for part in state["parts"]:
        mesh = UsdGeom.Mesh.Get(stage, f"/Scene/Parts/{part['part']}")
        assert mesh and len(mesh.GetFaceVertexCountsAttr().Get()) > 0
        material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
        surface = UsdShade.Shader(stage.GetPrimAtPath(f"{material.GetPath()}/surface"))
        assert surface.GetInput("ior").Get() == pytest.approx(specular_ior(part["specular"]), rel=1e-5)
        colour = surface.GetInput("diffuseColor")
        if part["kind"] == "procedural":
            assert colour.HasConnectedSource()
            assert UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetPrimvar("st").IsDefined()
        else:
            assert tuple(colour.Get()) == pytest.approx(part["base_color"], rel=1e-5)
    for light in state["lights"]:
        prim = stage.GetPrimAtPath(f"/Scene/Lights/{light['name']}")
        api = UsdLux.LightAPI(prim)
        assert prim.HasAPI(UsdLux.LightAPI) or prim.IsA(UsdLux.BoundableLightBase)
        radiance = np.asarray(api.GetColorAttr().Get()) * api.GetIntensityAttr().Get()
        assert radiance == pytest.approx(light["radiance"], rel=1e-5)
    camera = UsdGeom.Camera.Get(stage, "/Scene/Camera").GetCamera()
    assert camera.aspectRatio == pytest.approx(state["camera"]["width"] / state["camera"]["height"], rel=1e-4)


def test_blender_panels_block_light_as_in_mitsuba(exported: Path, tmp_path: Path) -> None:
    """The back wall's light sits behind the panel behind the camera: Mitsuba's black panel hides it, and so does
    Blender's (a panel that cast no shadow let it light the room from the front)."""
    from psdr_room_core.applications.blender import build_blend
    from psdr_room_core.applications.edit import render_folder
    from psdr_room_core.engine.plugins import plugin_system

    blender = shutil.which("blender")
    if blender is None:
        pytest.skip("Blender is not installed (scripts/setup.sh --test installs Debian's blender as root)")
    state = json.loads((exported / "appearance.json").read_text())
    assert {"light_behind_camera", "light_wall_z_neg"} <= {light["name"] for light in state["lights"]}
    darkened = [f"light.{light['name']}.radiance=0" for light in state["lights"] if light["name"] != "light_wall_z_neg"]
    scene = tmp_path / "back_wall"
    assert edit_main([str(exported), "--out", str(scene), "--spp", "4", *darkened]) == 0
    registry = plugin_system().registry
    reference = (
        render_folder(
            scene,
            256,
            registry.implementation("renderer", "mitsuba").factory(),
            registry.implementation("denoiser", "oidn").factory(),
        ).astype(np.float64)
        / 255
    )
    build_blend(scene, tmp_path / "back_wall.blend", blender, tmp_path / "cycles.png", "cycles", 128)
    image = cv2.imread(str(tmp_path / "cycles.png"))[..., ::-1].astype(np.float64) / 255
    luminance = np.array([0.2126, 0.7152, 0.0722])
    assert (reference @ luminance).mean() < 0.03  # Mitsuba: only what leaks past the panel's edges
    assert abs((image @ luminance).mean() - (reference @ luminance).mean()) < 0.01


def test_blender_builds_the_scene_lit_in_cycles_and_eevee(exported: Path, tmp_path: Path) -> None:
    """``psdr-room-blender`` writes a .blend whose camera view renders like psdr-room's own render in Cycles (the
    same light and materials; denoised as psdr-room's render is, it matches it) and lit in EEVEE (area lights,
    not only emissive panels)."""
    from psdr_room_core.applications.blender import build_blend, denoise_png
    from psdr_room_core.applications.edit import render_folder
    from psdr_room_core.engine.plugins import plugin_system
    from psdr_room_core.method.image_metrics import ssim

    blender = shutil.which("blender")
    if blender is None:
        pytest.skip("Blender is not installed (scripts/setup.sh --test installs Debian's blender as root)")
    registry = plugin_system().registry
    denoiser = registry.implementation("denoiser", "oidn").factory()
    reference = (
        render_folder(exported, 256, registry.implementation("renderer", "mitsuba").factory(), denoiser).astype(
            np.float64
        )
        / 255
    )
    luminance = np.array([0.2126, 0.7152, 0.0722])
    for engine, spp in (("cycles", 256), ("eevee", 16)):
        png = tmp_path / f"{engine}.png"
        build_blend(exported, tmp_path / f"{engine}.blend", blender, png, engine, spp)
        image = cv2.imread(str(png))[..., ::-1].astype(np.float64) / 255
        assert image.shape == reference.shape and (tmp_path / f"{engine}.blend").is_file()
        ratio = (image @ luminance).mean() / (reference @ luminance).mean()
        assert 0.7 < ratio < 1.3, (engine, ratio)
        if engine == "cycles":
            assert ssim(image, reference) > 0.85 and 0.9 < ratio < 1.1
            denoise_png(png, denoiser)
            assert ssim(cv2.imread(str(png))[..., ::-1].astype(np.float64) / 255, reference) > 0.95
    broken = tmp_path / "broken"
    shutil.copytree(exported, broken)
    (broken / "scene.glb").write_bytes((exported / "scene.glb").read_bytes()[:200])
    with pytest.raises(PsdrRoomError, match="Blender failed") as failure:
        build_blend(broken, tmp_path / "broken.blend", blender)
    assert "\n" not in str(failure.value) and not (tmp_path / "broken.blend").exists()


def test_edits_rerender_without_optimising(exported: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    base = tmp_path / "base"
    assert edit_main([str(exported), "--out", str(base), "--spp", "32"]) == 0
    brighter = tmp_path / "brighter"
    assert (
        edit_main(
            [
                str(exported),
                "light.scale=2",
                "material.floor=red_brick",
                "material.floor.scale=4",
                "material.wall_x_pos.base_color=[0.8,0.1,0.1]",
                "camera.fov=70",
                "--out",
                str(brighter),
                "--spp",
                "32",
            ]
        )
        == 0
    )
    state = json.loads((brighter / "appearance.json").read_text())
    floor = next(p for p in state["parts"] if p["part"] == "floor")
    assert floor["material"] == "red_brick" and floor["scale"] == 4.0
    assert math.degrees(2 * math.atan(0.5 * state["camera"]["height"] / state["camera"]["fy"])) == pytest.approx(70)
    a, b = (cv2.imread(str(d / "render.png")).astype(float) for d in (base, brighter))
    assert b.mean() > 1.3 * a.mean()
    warm = tmp_path / "warm"  # a colour filter on every light: red up, blue down (options before the edits)
    assert edit_main([str(exported), "--out", str(warm), "--spp", "32", "light.scale=[1.5,1,0.5]"]) == 0
    c = cv2.imread(str(warm / "render.png")).astype(float)  # BGR
    assert c[..., 2].mean() > 1.15 * a[..., 2].mean() and c[..., 0].mean() < 0.85 * a[..., 0].mean()
    assert (brighter / "textures" / "floor_base_color.png").is_file() and (brighter / "scene.glb").is_file()
    noisy = tmp_path / "noisy"  # render.png is denoised unless --denoiser none
    assert edit_main([str(exported), "--out", str(noisy), "--spp", "32", "--denoiser", "none"]) == 0
    grain = lambda img: float(np.abs(img - cv2.medianBlur(img.astype(np.uint8), 3)).mean())  # noqa: E731
    assert grain(a) < 0.6 * grain(cv2.imread(str(noisy / "render.png")).astype(float))
    capsys.readouterr()
    assert edit_main([str(exported), "material.sofa=red_brick", "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err
    assert "no part 'sofa'" in err and err.count("\n") == 1 and not (tmp_path / "bad").exists()
    with pytest.raises(PsdrRoomError, match="not a library material"):
        from psdr_room_core.applications.edit import apply_edit, load_state

        library = TorchGraphLibrary(use_plugins=False)
        apply_edit(load_state(exported, library), "material.floor", "no_such_graph", library)


def test_edit_never_replaces_a_folder_it_did_not_write(
    exported: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    capsys.readouterr()
    assert edit_main([str(exported), "light.scale=1.2", "--out", str(mine), "--spp", "4"]) == 2
    err = capsys.readouterr().err
    assert "psdr-room did not write" in err and str(mine) in err and err.count("\n") == 1
    assert [p.name for p in mine.iterdir()] == ["thesis.tex"] and not list(tmp_path.glob(".edit-*"))
    ours = tmp_path / "ours"  # an earlier edit's folder (marked) may be replaced
    assert edit_main([str(exported), "--out", str(ours), "--spp", "4"]) == 0
    assert edit_main([str(exported), "light.scale=1.2", "--out", str(ours), "--spp", "4"]) == 0
    assert (ours / ".psdr-room").is_file() and (ours / "render.png").is_file()


@pytest.mark.parametrize("field", ["part", "light", "fixture"])
def test_edit_refuses_names_that_leave_the_scene_folder(
    exported: Path, tmp_path: Path, field: str, capsys: pytest.CaptureFixture
) -> None:
    scene = tmp_path / "scene"
    shutil.copytree(exported, scene)
    state = json.loads((scene / "appearance.json").read_text())
    if field == "part":
        state["parts"][0]["part"] = "../../outside"
    elif field == "light":
        state["lights"][0]["name"] = "/etc/passwd"
    else:
        state["fixtures"] = [*state["fixtures"], "../x"]
    (scene / "appearance.json").write_text(json.dumps(state))
    capsys.readouterr()
    assert edit_main([str(scene), "--out", str(tmp_path / "out"), "--spp", "4"]) == 2
    err = capsys.readouterr().err
    assert f"{field} " in err and "not a plain name" in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("extreme", [-20.0, 20.0])
def test_walls_and_ceiling_stay_paint_whatever_the_fit_does(library: TorchGraphLibrary, extreme: float) -> None:
    """A wall's or the ceiling's base colour keeps a paint's luminance (0.1-0.9), no channel above 0.9, the hue it
    started with (each channel of its chromaticity within ``hue_range``, 1.1x) and its specular at most 0.5 for any parameter
    value; the floor and objects keep their full ranges; a dark, glossy wall is brought into range with its hue
    before the fit starts."""
    from psdr_room_core.method.material_priors import LUMINANCE, within_paint

    parts = [
        PartAppearance("wall_x_neg", "homogeneous", (0.004, 0.002, 0.001), 0.3, 0.95),
        PartAppearance("ceiling", "homogeneous", (0.9, 0.9, 0.9), 0.5, 0.5),
        PartAppearance("floor", "homogeneous", (0.004, 0.002, 0.001), 0.3, 0.95),
    ]
    prior = shipped.settings(PaintPrior, "fit_appearance.paint")
    start = within_paint(parts[0], prior)
    assert float(np.dot(start.base_color, LUMINANCE)) == pytest.approx(0.1) and start.specular == 0.5
    assert np.argmax(start.base_color) == 0 and within_paint(parts[2], prior) == parts[2]
    model = AppearanceModel(parts, Lights(lights=[]), library, map_size=16, **model_settings())
    with torch.no_grad():
        for value in model.theta.values():
            value.fill_(extreme)
    inputs = model.inputs()
    for name, part in zip(("wall_x_neg", "ceiling"), (start, parts[1])):
        colour = inputs["base_color"][name].detach().numpy()
        assert 0.1 - 1e-4 <= float(colour @ LUMINANCE) <= 0.9 + 1e-4 and float(inputs["specular"][name].detach()) <= 0.5
        assert colour.max() <= 0.9 + 1e-6
        ratio = (colour / colour.max()) / (np.asarray(part.base_color) / max(part.base_color))
        assert np.all((ratio > 1 / prior.hue_range**2 - 1e-4) & (ratio < prior.hue_range**2 + 1e-4)), ratio
    floor = float(inputs["base_color"]["floor"].detach() @ torch.tensor(LUMINANCE))
    assert (floor < 0.01) if extreme < 0 else (floor > 0.99)
    assert float(inputs["specular"]["floor"].detach()) == pytest.approx(0.0 if extreme < 0 else 1.0, abs=1e-6)


def test_white_balance_gives_a_warm_photo_warm_lights() -> None:
    rng = np.random.default_rng(3)
    render = torch.from_numpy(rng.uniform(0.02, 0.3, (40, 50, 3)).astype(np.float32))
    render[:5] = 0.0  # pixels the render does not cover do not count
    warm = np.array([1.25, 1.0, 0.7])
    photo = linear_to_srgb(render * 2.0 * torch.tensor(warm, dtype=torch.float32))
    photo[:5] = 1.0
    gains = white_balance(render, photo, max_gain=2.0)
    assert gains == pytest.approx(warm / (warm @ [0.2126, 0.7152, 0.0722]), rel=0.01)
    assert white_balance(render, photo, max_gain=1.1) == pytest.approx(np.clip(gains, 1 / 1.1, 1.1))


def test_srgb_curves_invert_each_other() -> None:
    x = np.linspace(0, 1, 101)
    assert np.allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-6)
    t = torch.linspace(0, 1, 11, requires_grad=True)
    linear_to_srgb(srgb_to_linear(t)).sum().backward()
    assert torch.isfinite(t.grad).all()


def test_a_lamp_emits_from_its_largest_visible_part(
    library: TorchGraphLibrary, photo: tuple[Image, Panoptic, Lights]
) -> None:
    """A lamp object's most visible material group becomes an emitter (§4.4), and the appearance fit runs
    with it as a light rather than a surface."""
    from psdr_room_core.method.artifacts import ObjectMesh, Placement
    from psdr_room_core.method.geometry import box_mesh

    shade, base = (
        box_mesh(np.array([0.0, 0.6, 0.0]), np.array([0.25, 0.2, 0.25])),
        box_mesh(np.array([0.0, 0.2, 0.0]), np.array([0.05, 0.2, 0.05])),
    )
    mesh = ObjectMesh(
        vertices=np.vstack([shade.vertices, base.vertices]),
        faces=np.vstack([shade.faces, base.faces + 8]),
        face_group=np.repeat([0, 1], 12),
        groups=("shade", "base"),
        colors=np.array([[0.9, 0.9, 0.8], [0.2, 0.2, 0.2]]),
    )
    lamp = Placement(
        segment_id=4,
        label="lamp",
        model_id="test/lamp",
        mesh=mesh,
        position=(0.5, 0.0, 1.5),
        yaw=0.0,
        scale=1.0,
        support="floor",
    )
    image, panoptic, _ = photo
    ids, _ = render_part_ids(MitsubaRenderer(spp=4), CAMERA, C2W, part_meshes(ROOM, Placements(objects=[lamp])), 96)
    labels = panoptic.ids.copy()
    labels[ids >= 6] = 4  # the lamp's pixels (after the six room sides)
    segments = [*panoptic.segments, Segment(4, "lamp", "lamp")]
    with_lamp = Panoptic(ids=labels, segments=segments)
    placements = Placements(objects=[lamp])
    assignment = MaterialAssignment(
        parts=[
            *_assignment(TRUE_SRGB).parts,
            PartMaterial("object_4_shade", "homogeneous", (0.9, 0.9, 0.8)),
            PartMaterial("object_4_base", "homogeneous", (0.2, 0.2, 0.2)),
        ]
    )
    ctx = StageContext("init_lights", LIGHT_PARAMS, 0, Path("photo.png"), _implementations(library))
    lights = init_lights(ctx, image, with_lamp, CAMERA, ROOM, placements, assignment)
    lamps = [l for l in lights.lights if l.kind == "lamp"]
    assert [(l.name, l.part) for l in lamps] == [("light_lamp_4", "object_4_shade")]
    ctx = StageContext(
        "fit_appearance",
        {**FIT_PARAMS, "iterations": 2, "final_spp": 8},
        0,
        Path("photo.png"),
        _implementations(library),
    )
    out = fit_appearance(ctx, image, CAMERA, ROOM, placements, assignment, lights)
    assert "light_lamp_4" in out["appearance"].radiance and out["appearance"].part("object_4_shade") is None
    assert out["appearance"].part("object_4_base") is not None
