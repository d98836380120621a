"""room_fit (§4.2, eq. 2) recovers a perturbed room box on a synthetic scene with exact targets."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from psdr_room_core.engine import shipped
from psdr_room_core.engine.dag import StageContext
from psdr_room_core.libraries.synth.raycast import raycast
from psdr_room_core.libraries.synth.scene import generate
from psdr_room_core.method.artifacts import Camera, DepthMap, Image, Panoptic, RoomBox
from psdr_room_core.method.stages.room import room_fit, room_iou, room_targets
from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer
from psdr_room_plugins.optimizer_adam import Adam

PARAMS = {**shipped.node("room_fit"), "iterations": 80, "render_width": 96}


def truth_inputs(seed: int) -> tuple[RoomBox, Camera, DepthMap, Panoptic, Image]:
    room = generate(seed, width=192, height=144)
    depth, ids, segments = raycast(room)
    camera = Camera.from_vfov(room.width, room.height, room.vfov_deg)
    box = RoomBox(
        camera_to_world=np.asarray(room.camera_to_world),
        center=np.array(room.room.center),
        half_size=np.array(room.room.half),
        yaw=room.room.yaw,
    )
    image = Image(rgb=np.full((room.height, room.width, 3), 0.5, np.float32))
    return box, camera, DepthMap(depth=depth, valid=depth > 0), Panoptic(ids=ids, segments=segments), image


def perturbed(box: RoomBox) -> RoomBox:
    """Yaw +10°, shifted sideways, lower ceiling, front wall pulled in; the unseen back wall stays put."""
    half = box.half_size * np.array([1.15, 0.85, 0.9])
    back_shift = box.half_size[2] - half[2]  # keep the back (-z) wall where it was
    local = np.array([0.35, -0.15 * box.half_size[1], -back_shift])
    c, s = math.cos(box.yaw), math.sin(box.yaw)
    center = box.center + np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ local
    center[1] = half[1]
    return RoomBox(camera_to_world=box.camera_to_world, center=center, half_size=half, yaw=box.yaw + math.radians(10))


def iou(a: RoomBox, b: RoomBox) -> float:
    return room_iou(b, a)


def test_targets_are_area_filtered() -> None:
    _, _, depth, panoptic, _ = truth_inputs(1)
    targets = room_targets(panoptic, depth, (48, 36))
    assert targets.masks.shape == (3, 36, 48)
    assert ((targets.masks > 0) & (targets.masks < 1)).any()  # fractional edge pixels
    assert np.allclose(targets.masks.sum(0)[targets.visible > 0.999], 1.0, atol=1e-5)


@pytest.mark.parametrize("seed", [1])
def test_room_fit_recovers_perturbed_box(seed: int, tmp_path: Path) -> None:
    truth, camera, depth, panoptic, image = truth_inputs(seed)
    start = perturbed(truth)
    assert iou(start, truth) <= 0.7
    ctx = StageContext(
        stage="room_fit",
        params=PARAMS,
        seed=0,
        photo=tmp_path / "photo.png",
        implementations={"renderer": MitsubaRenderer(spp=4, spp_boundary=16), "optimizer": Adam()},
    )
    out = room_fit(ctx, room=start, camera=camera, depth=depth, panoptic=panoptic, image=image)
    fitted, log = out["room"], out["log"]
    assert iou(fitted, truth) >= 0.9, (iou(start, truth), iou(fitted, truth))
    assert log.history[-1]["loss"] < log.history[0]["loss"]
    assert set(log.images) == {"before", "after", "loss"}
