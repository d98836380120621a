"""Synthetic rooms: exact ground truth, and the pipeline's frame conventions agree with it."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from psdr_room_core.engine.cli import compose_config
from psdr_room_core.engine.run import execute
from psdr_room_core.libraries.synth import write_scene
from psdr_room_core.libraries.synth.raycast import raycast
from psdr_room_core.libraries.synth.room import camera_pose
from psdr_room_core.libraries.synth.scene import CLOSE_UP_FRACTION, HARD_CASES, MIN_FRACTION, VISIBLE, generate
from psdr_room_core.method.artifacts import Panoptic
from psdr_room_core.method.room_box import box_iou_3d


def test_camera_pose_convention() -> None:
    pose = camera_pose(1.5, pitch_deg=-10.0, roll_deg=0.0)
    forward = pose[:3, :3] @ np.array([0.0, 0.0, 1.0])
    assert forward[1] == pytest.approx(-math.sin(math.radians(10)))  # pitched down
    assert forward[0] == pytest.approx(0.0) and forward[2] > 0  # world +Z is the projected optical axis
    assert pose[:3, 3] == pytest.approx([0.0, 1.5, 0.0])


@pytest.mark.parametrize("case", ["random", *HARD_CASES])
def test_raycast_ground_truth(case: str) -> None:
    room = generate(3, case, width=64, height=48)
    depth, ids, segments = raycast(room)
    assert depth.shape == ids.shape == (48, 64) and (depth > 0).all()
    seen = [s.category for s in segments if (ids == s.id).mean() >= MIN_FRACTION]
    floor, (least, most), ceiling = VISIBLE[case]
    assert floor in (None, "floor" in seen) and least <= seen.count("wall") <= most
    assert ceiling in (None, "ceiling" in seen)
    if case == "close_up":
        assert (
            max((ids == s.id).mean() for s in segments if s.category not in ("wall", "floor", "ceiling"))
            >= CLOSE_UP_FRACTION
        )
    assert set(np.unique(ids)) == {s.id for s in segments}
    # the camera is inside the room box
    center, half = np.array(room.room.center), np.array(room.room.half)
    local = np.array(
        [
            [math.cos(room.room.yaw), 0, -math.sin(room.room.yaw)],
            [0, 1, 0],
            [math.sin(room.room.yaw), 0, math.cos(room.room.yaw)],
        ]
    ) @ (np.asarray(room.camera_to_world)[:3, 3] - center)
    assert (np.abs(local) < half).all()


def test_generation_is_deterministic() -> None:
    assert generate(7).to_json() == generate(7).to_json()


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("synth") / "scene"
    write_scene(generate(5, width=160, height=120), directory, spp=16)
    return directory


def test_written_scene_reads_back(scene_dir: Path) -> None:
    truth = json.loads((scene_dir / "ground_truth.json").read_text())
    assert truth["intrinsics"]["height"] == 120 and 45 <= truth["vfov_deg"] <= 75
    for name in ("photo.png", "photo.depth.png", "photo.depth.json", "photo.panoptic.png", "photo.panoptic.json"):
        assert (scene_dir / name).is_file()


def test_room_init_recovers_the_synthetic_room(scene_dir: Path, tmp_path: Path, cache_dir: Path) -> None:
    """Through the whole preprocess and room_init with the true FoV: the frames agree with the ground truth."""
    truth = json.loads((scene_dir / "ground_truth.json").read_text())
    cfg = compose_config(
        [
            f"image={scene_dir / 'photo.png'}",
            "fov=fixed",
            f"fov.fixed.vfov_deg={truth['vfov_deg']}",
            "run.until=room_init",
        ]
    )
    record = execute(cfg, tmp_path / "run")
    box = record.artifacts["room_box"]
    gt = truth["room"]
    iou = box_iou_3d(np.array(gt["center"]), np.array(gt["half_size"]), gt["yaw"], box.center, box.half_size, box.yaw)
    assert box.extra["camera_height"] == pytest.approx(np.asarray(truth["camera_to_world"])[1][3], abs=0.03)
    assert iou > 0.6
    assert isinstance(record.artifacts["panoptic"], Panoptic)


def test_a_room_holds_the_number_of_objects_asked_for_where_they_fit() -> None:
    """psdr-room-synth --objects N (the speed benchmark's scaling rooms): N pieces where they fit; the default
    rooms are unchanged by the option's existence."""
    from psdr_room_core.libraries.synth.scene import generate

    two, many = generate(0, objects=2), generate(0, objects=16)
    assert len(two.furniture) == 2 and 8 <= len(many.furniture) <= 16
    assert 3 <= len(generate(0).furniture) <= 5 and generate(0).to_json() == generate(0, objects=None).to_json()
