"""segmentation=layout and depth=layout on a synthetic box room with a known camera, and GrabCut prompts."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from boxroom import checker_floor
from psdr_room_core.engine import shipped
from psdr_room_core.engine.records import RunRecord
from psdr_room_core.libraries.vanishing_points import VanishingPointParams, estimate_camera
from psdr_room_core.method.artifacts import Camera, DepthMap, Detection, Detections, Image, Panoptic, Segment
from psdr_room_core.method.guesses import FLOOR_GUESSES, fov_guesses
from psdr_room_plugins.layout import box
from psdr_room_plugins.layout.depth import LayoutDepth, object_depth
from psdr_room_plugins.layout.fit import _room_labels, fit_layout, floor_colour_region
from psdr_room_plugins.layout.manhattan import ManhattanFrame, frame_from_vanishing_points
from psdr_room_plugins.layout.objects import grabcut_mask
from psdr_room_plugins.layout.segmentation import LayoutSegmentation
from psdr_room_plugins.layout.settings import GrabCutParams, LayoutDepthSettings, LayoutSegmentationSettings

PHOTO = Path("room.png")  # named in logs only
TRUE_BOX = np.array([-2.0, 1.6, 0.7, -3.0, 3.2])  # camera heights (see psdr_room_plugins.layout.box)
CATEGORY = {box.FLOOR: "floor", box.CEILING: "ceiling"}
GRABCUT = shipped.settings(GrabCutParams, "segmentation.layout.grabcut")


def _segmentation() -> LayoutSegmentation:
    """``segmentation=layout`` as shipped, quicker (1500 random hypotheses) and without clutter proposals."""
    shipped_layout = shipped.arguments(LayoutSegmentationSettings, "segmentation.layout")
    return LayoutSegmentation(**{**shipped_layout, "n_random": 1500, "proposals": None})


def _depth(**changes: object) -> LayoutDepth:
    """``depth=layout`` as shipped, quicker (1500 random hypotheses), with ``changes``."""
    return LayoutDepth(**{**shipped.arguments(LayoutDepthSettings, "depth.layout"), "n_random": 1500, **changes})


def _rotation(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Frame axes (columns) in camera coordinates for a camera turned by yaw and looking down by pitch."""
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    yaw = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    pitch = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    return pitch @ np.diag([-1.0, -1.0, 1.0]) @ yaw


def _camera(rotation: np.ndarray, width: int = 320, height: int = 240) -> Camera:
    camera = Camera.from_vfov(width, height, 55.0)
    vps = (camera.K @ rotation).T
    return Camera.from_vfov(
        width, height, 55.0, vanishing_points=[tuple(v) for v in vps / np.linalg.norm(vps, axis=1, keepdims=True)]
    )


def _render(camera: Camera, frame: ManhattanFrame) -> tuple[Image, np.ndarray, np.ndarray]:
    """A box room with a distinct grey per surface and a grid of dark lines on every surface (tiles, panels)."""
    rays = frame.rays(camera, camera.width, camera.height)
    labels, t = box.trace(rays.reshape(-1, 3), TRUE_BOX[None])
    labels, t = labels[0].reshape(camera.height, camera.width), t[0].reshape(camera.height, camera.width)
    points = rays * t[..., None]
    shade = np.array([0.55, 0.65, 0.35, 0.85, 0.6, 0.7])[labels]
    in_plane = [(1, 2), (1, 2), (0, 2), (0, 2), (0, 1), (0, 1)]  # frame axes spanning each surface
    line = np.zeros(labels.shape, dtype=bool)
    for surface, axes in enumerate(in_plane):
        on = labels == surface
        for a in axes:
            phase = np.abs(((points[..., a] * 2.0) + 0.5) % 1.0 - 0.5)  # a line every half camera height
            line |= on & (phase < 0.03 * t / 2.0 + 0.01)
    rgb = np.repeat(np.where(line, 0.15, shade)[..., None], 3, axis=2).astype(np.float32)
    rgb += np.random.default_rng(0).normal(0, 0.01, rgb.shape).astype(np.float32)
    return Image(rgb=np.clip(rgb, 0, 1), source=str(PHOTO), original_size=(camera.width, camera.height)), labels, t


@pytest.fixture(scope="module")
def room() -> tuple[Camera, Image, np.ndarray, np.ndarray]:
    rotation = _rotation(yaw_deg=28.0, pitch_deg=6.0)
    camera = _camera(rotation)
    frame = frame_from_vanishing_points(camera, camera.vanishing_points)
    image, labels, t = _render(camera, frame)
    return camera, image, labels, t


def test_frame_from_vanishing_points_recovers_gravity_and_walls() -> None:
    rotation = _rotation(yaw_deg=28.0, pitch_deg=6.0)
    camera = _camera(rotation)
    shuffled = np.array(camera.vanishing_points)[[2, 0, 1]] * [[1], [-1], [1]]  # order and sign free
    frame = frame_from_vanishing_points(camera, shuffled)
    assert frame.observed
    assert np.allclose(frame.rotation[:, 1], rotation[:, 1], atol=1e-6)  # up is up
    assert np.allclose(np.abs(frame.rotation.T @ rotation), np.eye(3), atol=1e-6)  # same axes
    assert np.linalg.det(frame.rotation) == pytest.approx(1.0)
    upright = frame_from_vanishing_points(camera, [])
    assert not upright.observed and np.allclose(upright.rotation[:, 1], [0, -1, 0])


def test_trace_labels_and_depth() -> None:
    rays = np.array([[0.0, -1.0, 1.0], [0.0, 1.0, 1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 0.2], [0.0, 0.0, -1.0]])
    labels, t = box.trace(rays, TRUE_BOX[None])
    assert labels[0].tolist() == [box.FLOOR, box.CEILING, box.WALL_X1, box.WALL_X0, box.WALL_Z0]
    assert t[0] == pytest.approx([1.0, 0.7, 1.6, 2.0, 3.0])


def _category_iou(panoptic: Panoptic, labels: np.ndarray) -> dict[str, float]:
    ious = {}
    for surface_ids, name in (((box.FLOOR,), "floor"), ((box.CEILING,), "ceiling"), (box.WALLS, "wall")):
        truth = np.isin(labels, surface_ids)
        found = panoptic.mask(name)
        ious[name] = float((truth & found).sum() / max((truth | found).sum(), 1))
    return ious


def test_layout_segmentation_recovers_the_room(room: tuple) -> None:
    camera, image, labels, _ = room
    panoptic = _segmentation().segment(image, camera, Detections(items=[]), PHOTO)
    ious = _category_iou(panoptic, labels)
    assert min(ious.values()) > 0.9, ious
    walls = [s for s in panoptic.segments if s.category == "wall"]
    assert len(walls) == len({box.SURFACES[s] for s in np.unique(labels) if s in box.WALLS})  # one per visible wall


def test_a_wall_segment_of_no_plane_may_lie_on_any_wall() -> None:
    """A layout's wall segment (``wall_x1``) is explained on one wall only; a network's ``wall``, one segment
    for every wall it sees, on any; windows and doors are on walls too."""
    labels = np.array([[box.WALL_X0, box.WALL_X0, box.WALL_Z1, box.WALL_Z1, box.FLOOR, box.FLOOR]], np.int8)
    room = np.array([1, 1, 1, 1, 2, 2])
    assert box.label_score(labels, room, np.zeros(6, np.int64), 1)[0] == pytest.approx(4 / 6)
    assert box.label_score(labels, room, np.full(6, -1, np.int64), 0)[0] == pytest.approx(1.0)
    ids = np.array([[1, 1, 2, 2, 3, 3]], np.int32)
    for wall, window, n_planes in (("wall", "window", 0), ("wall_x0", "door", 1)):
        panoptic = Panoptic(ids, [Segment(1, "wall", wall), Segment(2, window, window), Segment(3, "floor", "floor")])
        kinds, planes, n = _room_labels(panoptic, (1, 6))
        assert kinds.tolist() == [1, 1, 1, 1, 2, 2] and n == n_planes
        assert planes[:4].tolist() == [n_planes - 1] * 2 + [-1] * 2


def test_a_networks_walls_floor_and_ceiling_give_the_room_a_plain_photo_cannot(room: tuple) -> None:
    """A photo of plain walls and ceiling painted alike over a darker floor (no line where a wall meets another
    or the ceiling): the box fitted to it alone misses the room; fitted also to a network's surfaces (walls
    one segment, as ``segmentation=layout_eyes`` gives them) it is the room."""
    camera, _, labels, _ = room
    grey = np.where(labels == box.FLOOR, 0.35, 0.7).astype(np.float32)
    plain = Image(rgb=np.repeat(grey[..., None], 3, axis=2), source=str(PHOTO))
    names = np.array(["wall", "wall", "floor", "ceiling", "wall", "wall"])[labels]
    ids = np.zeros(labels.shape, np.int32)
    segments = []
    for k, name in enumerate(("wall", "floor", "ceiling")):
        ids[names == name] = k + 1
        segments.append(Segment(k + 1, name, name))
    layout = _segmentation()
    alone = _category_iou(layout.segment(plain, camera, Detections(items=[]), PHOTO), labels)
    seen = _category_iou(
        layout.segment(plain, camera, Detections(items=[]), PHOTO, seen=Panoptic(ids, segments)), labels
    )
    assert min(alone.values()) < 0.5, alone
    assert min(seen.values()) > 0.9, seen


def test_layout_depth_from_true_labels_is_the_room_depth(room: tuple) -> None:
    camera, image, labels, t = room
    segments = [Segment(int(s) + 1, CATEGORY.get(int(s), "wall"), box.SURFACES[int(s)]) for s in np.unique(labels)]
    panoptic = Panoptic(ids=labels.astype(np.int32) + 1, segments=segments)
    depth = _depth().estimate(image, camera, panoptic, PHOTO)
    assert depth.valid.all() and not depth.metric
    relative = np.abs(depth.depth / (1.5 * t) - 1.0)
    assert np.median(relative) < 0.02 and np.mean(relative < 0.05) > 0.9


def test_layout_depth_names_the_objects_it_found_no_floor_contact_for(room: tuple, tmp_path: Path) -> None:
    """An object standing on the floor is placed; one above the horizon is put just in front of the wall and named
    in ``DepthMap.unplaced``, which the artifact keeps."""
    camera, image, labels, _ = room
    ids = labels.astype(np.int32) + 1
    segments = [Segment(int(s) + 1, CATEGORY.get(int(s), "wall"), box.SURFACES[int(s)]) for s in np.unique(labels)]
    ids[120:200, 140:170] = 20  # its bottom row on the floor
    ids[10:30, 140:170] = 21  # a picture on the wall
    segments += [Segment(20, "object", "cabinet", 0.5), Segment(21, "object", "picture", 0.5)]
    depth = _depth().estimate(image, camera, Panoptic(ids, segments), PHOTO)
    assert depth.unplaced == (21,)
    depth.save(tmp_path)
    assert DepthMap.load(tmp_path).unplaced == (21,)


def test_a_networks_relative_depth_gives_an_object_with_no_floor_contact_its_own(room: tuple) -> None:
    """Given a depth up to scale (a network's), an object the layout cannot stand on the floor (a lamp hanging
    halfway to the wall) takes it, scaled to the layout's on the pixels the layout places, and is placed; the
    room and the object on the floor keep the layout's depth."""
    camera, image, labels, t = room
    ids = labels.astype(np.int32) + 1
    segments = [Segment(int(s) + 1, CATEGORY.get(int(s), "wall"), box.SURFACES[int(s)]) for s in np.unique(labels)]
    ids[120:200, 140:170] = 20
    ids[10:30, 140:170] = 21
    segments += [Segment(20, "object", "cabinet", 0.5), Segment(21, "object", "lamp", 0.5)]
    relative = 7.0 * t * np.where(ids == 21, 0.5, 1.0)  # the network's own units
    layout = _depth()
    alone = layout.estimate(image, camera, Panoptic(ids, segments), PHOTO)
    depth = layout.estimate(image, camera, Panoptic(ids, segments), PHOTO, relative=relative)
    assert depth.unplaced == ()
    lamp, room_pixels = ids == 21, ids < 20
    assert np.median(depth.depth[lamp] / (1.5 * 0.5 * t[lamp])) == pytest.approx(1.0, abs=0.03)
    assert np.array_equal(depth.depth[room_pixels], alone.depth[room_pixels])
    assert np.median(alone.depth[lamp] / (1.5 * t[lamp])) == pytest.approx(0.98, abs=0.03)  # against the wall


def test_a_networks_relative_depth_lays_an_object_back_from_where_it_meets_the_floor(room: tuple) -> None:
    """An object seen from above (a bed's top, receding as the floor under it does) is stood up as a slab on
    its contact plane by the layout alone; a network's relative depth, scaled to that plane where the object
    meets the floor, lays it back: no nearer than the plane, nor farther behind it than ``relative_extent``
    times its width."""
    camera, image, labels, t = room
    ids = labels.astype(np.int32) + 1
    segments = [Segment(int(s) + 1, CATEGORY.get(int(s), "wall"), box.SURFACES[int(s)]) for s in np.unique(labels)]
    ids[200:236, 60:200] = 20  # lying on the floor: its depth recedes up the photo
    assert np.all(labels[200:236, 60:200] == box.FLOOR)
    segments.append(Segment(20, "object", "bed", 0.5))
    panoptic, bed = Panoptic(ids, segments), ids == 20
    relative = 7.0 * t  # the network's own units
    alone = _depth().estimate(image, camera, panoptic, PHOTO)
    deep = _depth(relative_extent=2.0)  # a bed is deeper than wide
    shaped = deep.estimate(image, camera, panoptic, PHOTO, relative)
    assert np.median(alone.depth[200:204, 130] / (1.5 * t[200:204, 130])) < 0.85  # a slab, up to the top row
    assert np.median(np.abs(shaped.depth[bed] / (1.5 * t[bed]) - 1.0)) < 0.03  # lying on the floor
    assert np.all(shaped.depth[bed] >= alone.depth[bed] - 1e-5)
    assert np.array_equal(shaped.depth[~bed], alone.depth[~bed])
    flat = _depth(relative_extent=0.0)
    assert np.array_equal(flat.estimate(image, camera, panoptic, PHOTO, relative).depth, alone.depth)
    capped = _depth(relative_extent=0.02)
    behind = capped.estimate(image, camera, panoptic, PHOTO, relative).depth[bed] - alone.depth[bed]
    assert 0 < behind.max() <= 1.5 * 0.02 * 2.5  # the bed is under 2.5 camera heights wide


def test_object_stands_on_the_floor(room: tuple) -> None:
    camera, _, labels, t = room
    frame = frame_from_vanishing_points(camera, camera.vanishing_points)
    rays = frame.rays(camera, camera.width, camera.height)
    mask = np.zeros(labels.shape, dtype=bool)
    mask[120:200, 140:170] = True  # bottom row 199 lies on the floor
    assert labels[199, 155] == box.FLOOR
    depth, on_floor = object_depth(mask, rays, t)
    assert on_floor
    assert depth[199, 155] == pytest.approx(t[199, 155], rel=1e-4)  # touches the floor where it stands
    assert np.all(depth[mask] <= t[mask] + 1e-6) and np.all(depth[~mask] == 0)
    column = rays[120:200, 154] * depth[120:200, 154, None]  # frame coordinates up the contact column
    assert np.ptp(column[:, [0, 2]], axis=0).max() < 5e-3  # upright: on a vertical plane, nearly one line ...
    assert column[-1, 1] == pytest.approx(-1.0, abs=1e-3) and column[0, 1] > -0.8  # ... rising from the floor
    wall = np.zeros(labels.shape, dtype=bool)
    wall[10:30, 140:170] = True  # above the horizon: no floor contact, just in front of the wall
    above, on_floor = object_depth(wall, rays, t)
    assert np.allclose(above[wall], 0.98 * t[wall]) and not on_floor
    seat = np.zeros(labels.shape, dtype=bool)
    seat[120:170, 140:170] = True  # a box-prompted cut that lost the legs: its prompt box reaches row 199
    legs, _ = object_depth(seat, rays, t, box=(138.0, 118.0, 172.0, 200.0))
    assert legs[169, 155] == pytest.approx(depth[169, 155], rel=1e-4)  # the plane of the whole object
    assert object_depth(seat, rays, t)[0][169, 155] > 1.05 * legs[169, 155]  # the seat's edge taken for the floor


def test_grabcut_cuts_the_object_out_of_its_box() -> None:
    rng = np.random.default_rng(1)
    height, width = 200, 260
    yy, xx = np.mgrid[:height, :width]
    rgb = np.stack([0.3 + 0.3 * xx / width, 0.5 + 0.1 * yy / height, 0.4 * np.ones_like(xx, float)], axis=-1)
    truth = ((xx - 130) / 60.0) ** 2 + ((yy - 100) / 45.0) ** 2 < 1.0
    rgb[truth] = [0.8, 0.2, 0.25]
    rgb8 = np.clip((rgb + rng.normal(0, 0.03, rgb.shape)) * 255, 0, 255).astype(np.uint8)
    mask = grabcut_mask(rgb8, (62.0, 48.0, 198.0, 152.0), GRABCUT)
    assert mask is not None
    assert (mask & truth).sum() / (mask | truth).sum() > 0.9
    flat = np.full_like(rgb8, 128)
    assert grabcut_mask(flat, (62.0, 48.0, 198.0, 152.0), replace(GRABCUT, min_fill=0.9)) is None


def test_box_prompts_become_object_segments(room: tuple) -> None:
    camera, image, labels, _ = room
    rgb = image.rgb.copy()
    yy, xx = np.mgrid[: camera.height, : camera.width]
    sofa = ((xx - 160) / 40.0) ** 2 + ((yy - 170) / 25.0) ** 2 < 1.0
    rgb[sofa] = [0.8, 0.3, 0.2]
    prompts = Detections(items=[Detection("couch", "object", (112.0, 140.0, 208.0, 200.0), 0.8)])
    panoptic = _segmentation().segment(
        Image(rgb=rgb, source="room.png", original_size=(320, 240)), camera, prompts, PHOTO
    )
    couch = [s for s in panoptic.segments if s.label == "couch"]
    assert len(couch) == 1 and couch[0].category == "object"
    mask = panoptic.ids == couch[0].id
    assert (mask & sofa).sum() / (mask | sofa).sum() > 0.85
    assert _category_iou(panoptic, np.where(sofa, -1, labels))["floor"] > 0.85


def test_boxes_yaml_replaces_the_detector(tmp_path: Path) -> None:
    """With detector=auto a boxes file beside the photo is used instead of NanoDet with eyes (cached by its content);
    without eyes.onnx, NanoDet alone."""
    from psdr_room_core.engine.cli import compose_config
    from psdr_room_core.engine.plugins import plugin_system
    from psdr_room_core.engine.run import execute

    photo = tmp_path / "room.png"
    camera = _camera(_rotation(28.0, 6.0))
    image, _, _ = _render(camera, frame_from_vanishing_points(camera, camera.vanishing_points))
    cv2.imwrite(str(photo), image.to_uint8()[..., ::-1])
    plugins = plugin_system()
    overrides = [f"image={photo}", f"cache_dir={tmp_path / 'cache'}", "run.until=detect", "report.enabled=false"]
    record = execute(compose_config(overrides, plugins), tmp_path / "run1", plugins)
    assert record.implementations["detector"]["name"] == "nanodet_eyes"
    no_eyes = [*overrides, f"detector.eyes.path={tmp_path / 'none.onnx'}"]
    record = execute(compose_config(no_eyes, plugins), tmp_path / "run0", plugins)
    assert record.implementations["detector"]["name"] == "nanodet_onnx"
    assert "not nanodet_eyes: no eyes network at" in record.implementations["detector"]["selected_by"]
    photo.with_suffix(".boxes.yaml").write_text(
        "boxes:\n  - {label: sofa, category: object, box: [100, 120, 220, 200]}\n"
    )
    record = execute(compose_config(overrides, plugins), tmp_path / "run2", plugins)
    assert record.implementations["detector"]["name"] == "boxes_file"
    assert "not" not in record.implementations["detector"]["selected_by"]
    assert [d.label for d in record.artifacts["detections"].items] == ["sofa"]


def _run_bare(image: Image, tmp_path: Path, until: str) -> RunRecord:
    """``image`` alone through the offline layout segmentation and depth (no detector, a 55° FoV) until
    ``until``: the run record."""
    from psdr_room_core.engine.cli import compose_config
    from psdr_room_core.engine.plugins import plugin_system
    from psdr_room_core.engine.run import execute

    photo = tmp_path / "photo.png"
    cv2.imwrite(str(photo), image.to_uint8()[..., ::-1])
    plugins = plugin_system()
    overrides = [
        f"image={photo}",
        f"cache_dir={tmp_path / 'cache'}",
        f"run.until={until}",
        "report.enabled=false",
        "detector=none",
        "fov=fixed",
        "fov.fixed.vfov_deg=55.0",
        "segmentation=layout",
        "depth=layout",
        "segmentation.layout.n_random=1500",
        "depth.layout.n_random=1500",
    ]
    return execute(compose_config(overrides, plugins), tmp_path / "run", plugins)


def _render_true(rotation: np.ndarray) -> tuple[Image, np.ndarray]:
    """The room seen by a camera whose frame axes are ``rotation`` (rendered in that true frame, whichever
    axis the vanishing points would call up): the image and its surface labels."""
    camera = _camera(rotation)
    frame = ManhattanFrame(rotation=rotation, vanishing_points=np.asarray(camera.vanishing_points), observed=True)
    image, labels, _ = _render(camera, frame)
    return image, labels


def test_a_bare_photo_without_floor_or_prompts_still_gives_a_room(tmp_path: Path) -> None:
    """Looking up at a plain room: no floor in view, the detector finds nothing, no proposal stands out. The
    pipeline stands the room on its ceiling (logged) and places no object, without an error."""
    camera = _camera(_rotation(28.0, -25.0))  # pitched up: floor out of view
    image, labels, _ = _render(camera, frame_from_vanishing_points(camera, camera.vanishing_points))
    assert not (labels == box.FLOOR).any() and (labels == box.CEILING).any()
    record = _run_bare(image, tmp_path, "place_objects")
    room = record.artifacts["room_box"]
    assert room.extra["floor_source"] in ("ceiling", "walls")
    assert record.artifacts["placements"].objects == []
    guessed = json.loads((tmp_path / "run" / "metrics.json").read_text())["guessed"]
    assert guessed == [f"no floor in view: the floor plane from {FLOOR_GUESSES[room.extra['floor_source']]}"]


def test_a_bare_photo_looking_down_at_a_tiled_floor_stands_the_room_on_it(tmp_path: Path) -> None:
    """Looking 65° down at a tiled floor that fills the photo: its tile lines look like a wall's seen from level,
    so the upright layout shows no floor; fitted again looking down, the floor is found where it is the photo,
    and the room's floor plane is within 10° and 15% (of the 1.5 m camera height the layout assumes) of the
    truth."""
    rotation = _rotation(20.0, 65.0)
    image, labels = _render_true(rotation)
    assert (labels == box.FLOOR).mean() > 0.97
    record = _run_bare(image, tmp_path, "room_init")
    panoptic = record.artifacts["panoptic"]
    assert panoptic.mask("floor").mean() > 0.9
    room = record.artifacts["room_box"]
    assert room.extra["floor_source"] == "floor"
    floor = np.asarray(room.extra["floor_plane_camera"])
    assert np.degrees(np.arccos(np.clip(floor[:3] @ rotation[:, 1], -1, 1))) < 10.0
    assert floor[3] == pytest.approx(1.5, rel=0.15)


def test_a_tiled_floor_filling_the_photo_is_a_floor_not_a_wall_seen_from_below() -> None:
    """Big tiles seen 55° from above show nine long lines and no vertical one: enough for the FoV and both floor
    vanishing points (under twelve lines the FoV was the fallback and the room stood upright, the floor only
    its lower 40%), and the floor, not a wall seen 35° from below, fills the photo."""
    rgb = checker_floor(40.0, 55.0, 0.8)
    found = estimate_camera(rgb, shipped.settings(VanishingPointParams, "fov.vanishing_points"))
    camera = Camera.from_vfov(320, 240, found.vfov_deg, vanishing_points=found.vanishing_points)
    layout = fit_layout(
        Image(rgb=rgb, original_size=(320, 240)),
        camera,
        replace(shipped.settings(LayoutDepthSettings, "depth.layout"), n_random=1500),
    )
    labels, _ = layout.trace(camera, 160, 120)
    assert (labels == box.FLOOR).mean() > 0.95
    p = math.radians(55.0)
    up = np.array([0.0, -math.cos(p), -math.sin(p)])  # camera coordinates: y down, z ahead
    assert math.degrees(math.acos(abs(layout.frame.rotation[:, 1] @ up))) < 5.0


def test_a_bare_photo_of_the_ceiling_alone_still_gives_a_room(tmp_path: Path) -> None:
    """Looking 65° up at a panelled ceiling that fills the photo: nothing shows the floor, yet the run goes on
    to a room (its floor guessed below the camera, logged), it does not stop with an error."""
    image, labels = _render_true(_rotation(20.0, -65.0))
    assert (labels == box.CEILING).mean() > 0.97
    room = _run_bare(image, tmp_path, "room_init").artifacts["room_box"]
    assert np.all(np.asarray(room.half_size) > 0) and room.extra["camera_height"] > 0


def test_what_was_guessed_is_said() -> None:
    """The FoV of a photo whose lines give no vanishing points, or barely any, is a guess, and says so; a fixed
    FoV (the user's) and a well-supported one are not."""
    fallback = Camera.from_vfov(160, 120, 55.0, method="vanishing_points/fallback")
    weak = replace(Camera.from_vfov(160, 120, 58.0, method="vanishing_points/orthogonal_pair"), confidence=0.02)
    strong = replace(weak, confidence=0.6)
    assert "fallback 55.0°" in fov_guesses(fallback)[0] and "58.0° is uncertain" in fov_guesses(weak)[0]
    assert fov_guesses(strong) == [] == fov_guesses(Camera.from_vfov(160, 120, 55.0, method="fixed"))


def test_the_floor_colour_runs_up_from_the_bottom_band() -> None:
    """A plain carpet (no lines to say it is floor) running up to the far wall is floor evidence as far as its
    colour goes; the walls beside it, a rug of another colour and everything above the horizon are not."""
    height, width = 120, 160
    rgb = np.full((height, width, 3), (0.80, 0.78, 0.72), np.float32)  # pale walls
    carpet = np.zeros((height, width), dtype=bool)
    for y in range(60, height):  # a corridor floor narrowing towards its vanishing point at row 60
        half = (y - 60) * 1.6
        carpet[y, max(0, int(80 - half)) : int(80 + half) + 1] = True
    rgb[carpet] = (0.42, 0.33, 0.24)
    rug = np.zeros_like(carpet)
    rug[80:95, 70:90] = True
    rgb[rug] = (0.20, 0.30, 0.60)
    rgb += np.random.default_rng(0).normal(0, 0.02, rgb.shape).astype(np.float32)
    image = Image(rgb=np.clip(rgb, 0, 1), source=str(PHOTO), original_size=(width, height))
    below = np.zeros_like(carpet)
    below[62:] = True  # the horizon a little under the vanishing point
    band = np.zeros_like(carpet)
    band[-10:] = True
    region = floor_colour_region(image, below, band, tolerance=14.0)
    floor = carpet & ~rug & below
    assert (region & floor).sum() > 0.9 * floor.sum()  # the carpet up to near its vanishing point
    assert not region[~below].any() and (region & rug).sum() < 0.1 * rug.sum()
    assert (region & ~carpet).sum() < 0.05 * floor.sum()  # the walls stay out
    assert not floor_colour_region(image, below, np.zeros_like(band), 14.0).any()  # no band, no region
