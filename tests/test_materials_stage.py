"""Material initialisation (§4.4): crop windows, the user's crops file, retrieval, voting, the texture
transform search, and the assign_materials stage on a rendered room whose floor wears a library material."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import torch

from psdr_room_core.engine import shipped
from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import Camera, Image, MaterialAssignment, Panoptic, Placements, RoomBox, Segment
from psdr_room_core.method.crops import crop_windows, largest_rectangle, read_crops, write_crops
from psdr_room_core.method.material_search import (
    MaterialIndex,
    luminance,
    search_transform,
    surface_coordinates,
    surface_view,
    tiled_view,
    vote,
)
from psdr_room_core.method.rgb_scene import render_part_ids
from psdr_room_core.method.stages.materials import assign_materials, scene_parts
from psdr_room_core.method.surface_colours import dominant_colour, texture_energy
from psdr_room_plugins.material_graph.library import TorchGraphLibrary
from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer
from psdr_room_plugins.texture.random_cnn import RandomCnnDescriptor

C2W = np.eye(4)
C2W[:3, :3] = np.diag([-1.0, -1.0, 1.0])  # OpenCV camera looking along world +Z, Y up ...
tilt = math.radians(-25)  # ... pitched down to see the floor
C2W[:3, :3] = C2W[:3, :3] @ np.array(
    [[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]]
)
C2W[:3, 3] = [0.0, 1.5, -2.5]
ROOM = RoomBox(camera_to_world=C2W, center=np.array([0.0, 1.5, 0.0]), half_size=np.array([3.0, 1.5, 3.0]), yaw=0.0)
CAMERA = Camera.from_vfov(200, 150, 60.0)
WALL = (0.62, 0.52, 0.40)
PARAMS = {
    **shipped.node("assign_materials"),
    "render_width": 200,
    "map_size": 128,
}
SHELF = (slice(20, 52), slice(70, 130))
"""Rows and columns of the photo where a bookshelf the segmentation calls wall stands before the far wall."""


@pytest.fixture(scope="module")
def library() -> TorchGraphLibrary:
    return TorchGraphLibrary(use_plugins=False)


@pytest.fixture(scope="module")
def descriptor() -> RandomCnnDescriptor:
    return RandomCnnDescriptor()


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("min_side", [1, 3])
def test_largest_rectangle_matches_brute_force(seed: int, min_side: int) -> None:
    mask = np.random.default_rng(seed).random((30, 40)) > 0.08
    best = 0
    for y0 in range(30):
        for y1 in range(y0 + min_side, 31):
            run = 0
            for full in mask[y0:y1].all(axis=0):
                run = run + 1 if full else 0
                if run >= min_side:
                    best = max(best, run * (y1 - y0))
    (x0, y0, x1, y1), area = largest_rectangle(mask, min_side)
    assert area == best == (x1 - x0) * (y1 - y0) and mask[y0:y1, x0:x1].all()
    assert min(x1 - x0, y1 - y0) >= min_side


def test_crop_windows_are_disjoint_inside_and_large_enough() -> None:
    region = np.zeros((120, 160), bool)
    region[10:70, 10:150] = True
    region[70:115, 60:100] = True
    region[0:5, 0:160] = True  # too thin for a crop
    windows = crop_windows(region, max_crops=5, min_side=20, min_area=400)
    assert windows[0] == (10, 10, 150, 70) and len(windows) == 2
    taken = np.zeros_like(region, int)
    for x0, y0, x1, y1 in windows:
        assert region[y0:y1, x0:x1].all() and min(x1 - x0, y1 - y0) >= 20
        taken[y0:y1, x0:x1] += 1
    assert taken.max() == 1


def test_crops_file_is_scaled_to_the_working_image_and_checked(tmp_path: Path) -> None:
    path = tmp_path / "photo.crops.yaml"
    path.write_text(
        "crops:\n  - {image: [100, 50, 300, 250], part: floor}\n  - {image: [0, 0, 80, 60], render: [10, 10, 50, 40]}\n"
    )
    crops = read_crops(path, (800, 600), (400, 300))
    assert crops[0].image == (50, 25, 150, 125) and crops[0].part == "floor" and crops[0].render is None
    assert crops[1].render == (5, 5, 25, 20) and crops[1].part is None
    for text, words in (
        ("crops:\n  - {image: [100, 50, 900, 250], part: floor}\n", "inside the 800x600 photo"),
        ("crops:\n  - {image: [1, 2, 3], part: floor}\n", "[x0, y0, x1, y1]"),
        ("crops:\n  - {image: [0, 0, 9, 9], part: floor, render: [0, 0, 9, 9]}\n", "exactly one of"),
        ("crops: [\n", "unreadable crops file"),
    ):
        path.write_text(text)
        with pytest.raises(PsdrRoomError, match=words) as info:
            read_crops(path, (800, 600), (400, 300))
        assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_a_written_crops_file_reads_back_and_a_wrong_one_is_not_written(tmp_path: Path) -> None:
    path = tmp_path / "photo.crops.yaml"
    entries: list[dict[str, object]] = [
        {"image": [100.0, 50.0, 300.0, 250.0], "part": "floor"},
        {"image": [0, 0, 80, 60], "render": [10, 10, 50, 40]},
    ]
    write_crops(path, entries, (800, 600))
    assert [c.image for c in read_crops(path, (800, 600), (800, 600))] == [(100, 50, 300, 250), (0, 0, 80, 60)]
    before = path.read_text()
    with pytest.raises(PsdrRoomError, match="inside the 800x600 photo"):
        write_crops(path, [{"image": [700, 0, 900, 60], "part": "floor"}], (800, 600))
    assert path.read_text() == before and sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_vote_prefers_materials_listed_by_several_crops() -> None:
    ranked = vote([[("a", 0.9), ("b", 0.6)], [("c", 0.8), ("b", 0.7)], [("b", 0.5), ("d", 0.95)]])
    assert ranked == [("b", pytest.approx(0.6))]
    assert vote([[("a", 0.4), ("b", 0.6)]])[0] == ("b", 0.6)


def test_index_retrieves_a_library_material_from_a_turned_view(
    library: TorchGraphLibrary, descriptor: RandomCnnDescriptor
) -> None:
    index = MaterialIndex.build(library, descriptor, 128)
    assert index.names == library.names() and index.spacing > 0
    for name in ("red_brick", "herringbone_oak"):
        view = tiled_view(library, library.appearance(name, 128), (96, 120), 2.0, 20.0)
        distances = index.distances(descriptor, descriptor.describe(view))
        best = int(torch.argmin(distances))
        assert index.names[best] == name and index.similarity(float(distances[best])) > 0.33


def test_transform_search_recovers_the_scale_and_rotation(
    library: TorchGraphLibrary, descriptor: RandomCnnDescriptor
) -> None:
    camera = Camera.from_vfov(160, 120, 60.0)
    c2w = np.eye(4)
    c2w[:3, :3] = np.diag([-1.0, -1.0, 1.0])
    depth = np.full((120, 160), 2.0, np.float32)  # a wall 2 m ahead, seen head-on
    rects = [(10, 10, 90, 70), (90, 40, 150, 110)]
    look = library.appearance("wallpaper_stripes", 128)
    tile = library.material("wallpaper_stripes").tile_size
    crops = []
    for rect in rects:
        coords = surface_coordinates(camera, c2w, depth, rect)
        assert coords is not None
        photo = (surface_view(library, look, coords, tile, 2.0, 45.0) * 0.8).clamp(0, 1)
        crops.append((photo, descriptor.describe(photo), coords))
    fit = search_transform(library, descriptor, look, tile, crops, [0.5, 1.0, 2.0, 4.0, 8.0], [-45.0, 0.0, 45.0, 90.0])
    assert (fit.scale, fit.rotation) == (2.0, 45.0)
    assert luminance(fit.views[0]) == pytest.approx(luminance(crops[0][0]), rel=0.05)


def _rendered_room(
    tmp_path: Path, library: TorchGraphLibrary, material: str, scale: float, shelf: bool = False
) -> tuple[StageContext, Image, Panoptic]:
    """A photo of the room: the floor wears ``material`` (planar x/z mapping, ``scale``), the walls and
    ceiling flat colours with a little noise; the panoptic labels come from the same render. With ``shelf``,
    a dark bookshelf with pale shelves stands at :data:`SHELF`, labelled wall (clutter the segmentation
    missed)."""
    ctx = StageContext(
        "assign_materials",
        PARAMS,
        0,
        tmp_path / "photo.png",
        {"renderer": MitsubaRenderer(spp=4), "material_graph": library, "texture": RandomCnnDescriptor()},
    )
    empty = Panoptic(ids=np.zeros((150, 200), np.int32), segments=[])
    parts = scene_parts(ROOM, Placements(objects=[]), empty, PARAMS["room_colours"])
    ids, depth = render_part_ids(
        ctx.impl("renderer"), CAMERA, ROOM.camera_to_world, {p.name: p.mesh for p in parts}, PARAMS["render_width"]
    )
    names = [p.name for p in parts]
    segment_of = np.array([0] + [1 if n == "floor" else 2 if n == "ceiling" else 3 for n in names], np.int32)
    panoptic_ids = segment_of[ids + 1]  # part index (-1: none) → segment 1 floor, 2 ceiling, 3 wall
    rgb = np.empty((150, 200, 3), np.float32)
    rgb[:] = WALL
    rgb[panoptic_ids == 2] = (0.85, 0.85, 0.83)
    rgb += np.random.default_rng(0).normal(0, 0.004, rgb.shape).astype(np.float32)
    k = scale / library.material(material).tile_size
    look = library.appearance(material, 128)
    sub = 4  # the floor's texture is integrated over each pixel (4x4 rays), as a camera does
    grid = (np.arange(200 * sub) + 0.5) / sub, (np.arange(150 * sub) + 0.5) / sub
    xs, ys = np.meshgrid(*grid)
    rays = np.stack([(xs - CAMERA.cx) / CAMERA.fx, (ys - CAMERA.cy) / CAMERA.fy, np.ones_like(xs)], -1) @ C2W[:3, :3].T
    hit = C2W[:3, 3] + rays * (-C2W[1, 3] / np.minimum(rays[..., 1:2], -1e-6))  # on the floor plane y = 0
    texture = library.sample(look, torch.from_numpy(hit[..., 0] * k).float(), torch.from_numpy(hit[..., 2] * k).float())
    texture = torch.nn.functional.avg_pool2d(texture[None], sub)[0].permute(1, 2, 0).numpy()
    floor = panoptic_ids == 1
    rgb[floor] = texture[floor]
    if shelf:
        rgb[SHELF] = (0.25, 0.16, 0.10)
        rgb[SHELF[0].start : SHELF[0].stop : 8, SHELF[1]] = (0.80, 0.74, 0.60)
    panoptic = Panoptic(
        ids=panoptic_ids,
        segments=[Segment(1, "floor", "floor"), Segment(2, "ceiling", "ceiling"), Segment(3, "wall", "wall")],
    )
    return ctx, Image(rgb=np.clip(rgb, 0, 1), original_size=(200, 150)), panoptic


def test_assign_materials_finds_the_floor_material_and_keeps_plain_walls_homogeneous(
    tmp_path: Path, library: TorchGraphLibrary
) -> None:
    ctx, image, panoptic = _rendered_room(tmp_path, library, "herringbone_oak", 2.0)
    out = assign_materials(ctx, image, panoptic, CAMERA, ROOM, Placements(objects=[]))
    floor = out.part("floor")
    assert floor is not None and floor.crops and floor.kind == "procedural", floor
    assert floor.material == "herringbone_oak" and floor.scale == 2.0
    assert floor.scores["texture_loss"] < floor.scores["homogeneous_loss"]
    walls = [p for p in out.parts if p.part.startswith("wall") and p.crops]
    assert walls and all(p.kind == "homogeneous" for p in walls)
    assert all(np.allclose(p.albedo, WALL, atol=0.02) for p in walls)
    hidden = out.part("wall_z_neg")  # behind the camera: the median of its whole segment, the walls' (§4.4)
    assert hidden is not None and not hidden.crops and np.allclose(hidden.albedo, WALL, atol=0.02)
    assert set(out.images) == {"crops", "crop_pairs"}
    (tmp_path / "saved").mkdir()
    out.save(tmp_path / "saved")
    again = MaterialAssignment.load(tmp_path / "saved")
    assert again.parts == out.parts


def test_a_room_side_is_retrieved_only_from_its_categories(tmp_path: Path, library: TorchGraphLibrary) -> None:
    """A leather-looking floor is not given leather (room_categories.floor has no leather), unless the config
    lets floors be leather."""
    ctx, image, panoptic = _rendered_room(tmp_path, library, "black_leather", 1.0)
    floor = assign_materials(ctx, image, panoptic, CAMERA, ROOM, Placements(objects=[])).part("floor")
    allowed = set(PARAMS["room_categories"]["floor"])
    assert floor is not None and floor.crops and floor.material != "black_leather", floor
    assert floor.candidates and all(library.material(name).category in allowed for name, _ in floor.candidates)
    leather = {**PARAMS, "room_categories": {**PARAMS["room_categories"], "floor": [*allowed, "leather"]}}
    ctx = StageContext("assign_materials", leather, 0, ctx.photo, ctx.implementations)
    floor = assign_materials(ctx, image, panoptic, CAMERA, ROOM, Placements(objects=[])).part("floor")
    assert floor is not None and floor.material == "black_leather", floor


def test_user_crops_replace_the_automatic_ones(tmp_path: Path, library: TorchGraphLibrary) -> None:
    ctx, image, panoptic = _rendered_room(tmp_path, library, "herringbone_oak", 2.0)
    (tmp_path / "photo.crops.yaml").write_text(
        "crops:\n  - {image: [60, 120, 140, 148], part: floor}\n"
        "  - {image: [10, 10, 40, 40], render: [10, 10, 40, 40]}\n"
    )
    out = assign_materials(ctx, image, panoptic, CAMERA, ROOM, Placements(objects=[]))
    assert out.part("floor").crops == ((60, 120, 140, 148),)  # type: ignore[union-attr]
    assert sum(len(p.crops) for p in out.parts) == 2
    (tmp_path / "photo.crops.yaml").write_text("crops:\n  - {image: [60, 120, 140, 148], part: sofa}\n")
    with pytest.raises(PsdrRoomError, match="part 'sofa' is not in the scene"):
        assign_materials(ctx, image, panoptic, CAMERA, ROOM, Placements(objects=[]))


def test_crops_and_colours_avoid_clutter_the_segmentation_called_wall(
    tmp_path: Path, library: TorchGraphLibrary
) -> None:
    ctx, image, panoptic = _rendered_room(tmp_path, library, "herringbone_oak", 2.0, shelf=True)
    assert set(np.unique(panoptic.ids[SHELF])) == {3}  # the shelf is all "wall" in the segmentation
    out = assign_materials(ctx, image, panoptic, CAMERA, ROOM, Placements(objects=[]))
    far = out.part("wall_z_pos")
    assert far is not None and far.crops and far.kind == "homogeneous"
    rows, cols = SHELF
    for x0, y0, x1, y1 in (c for p in out.parts for c in p.crops):
        assert x1 <= cols.start or x0 >= cols.stop or y1 <= rows.start or y0 >= rows.stop, (x0, y0, x1, y1)
    assert np.allclose(far.albedo, WALL, atol=0.02)  # the clean pixels' median, not pulled by the shelf
    hidden = out.part("wall_z_neg")
    assert hidden is not None and np.allclose(hidden.albedo, WALL, atol=0.02)


def test_flatness_tells_plain_paint_from_texture(library: TorchGraphLibrary) -> None:
    """Plain crops (a colour, a shading gradient, sensor noise) measure under ``flat_energy``; library
    textures seen as a camera would (64-px crops of the material's appearance) above it."""
    rng = np.random.default_rng(1)
    threshold = PARAMS["flat_energy"]
    ys, xs = np.mgrid[0:80, 0:120] / 120.0
    for colour in ((0.85, 0.82, 0.75), (0.45, 0.5, 0.55), (0.12, 0.1, 0.1)):
        shading = (0.7 + 0.3 * xs + 0.1 * ys)[..., None]
        plain = np.clip(np.asarray(colour) * shading + rng.normal(0, 0.01, (80, 120, 3)), 0, 1)
        assert texture_energy(plain) < threshold, colour
    for name in ("herringbone_oak", "wool_basketweave", "white_square_tiles", "white_painted_brick"):
        look = library.appearance(name, 128)
        crop = look.clamp(0, 1).permute(1, 2, 0).numpy()[:96, :96]
        assert texture_energy(crop) > threshold, name


def test_dominant_colour_is_the_colour_most_pixels_share() -> None:
    rgb8 = np.zeros((10, 10, 3), np.uint8)
    rgb8[:6] = (230, 225, 210)  # a pale wall ...
    rgb8[6:8] = (200, 120, 60)  # ... a cork board ...
    rgb8[8:] = (20, 20, 25)  # ... a dark desk front: the channel medians would mix them
    assert dominant_colour(rgb8, np.ones((10, 10), bool)) == pytest.approx((230 / 255, 225 / 255, 210 / 255))
