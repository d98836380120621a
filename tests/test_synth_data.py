"""The data engine's 3D labels: each instance's box in the camera frame, how much of it is seen, whether the frame
cuts it, and the camera's pitch and roll, checked against what the generator placed and drew."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from psdr_room_core.applications.synth_data import write_sample
from psdr_room_core.libraries.synth.furnish import Furnisher
from psdr_room_core.libraries.synth.instances import InstanceBox, camera_angles, camera_frame_boxes
from psdr_room_core.libraries.synth.room import camera_pose
from psdr_room_core.method.artifacts import Placement, rotation_y
from psdr_room_plugins.eyes import labels
from psdr_room_plugins.eyes.data import build_pack

SEED = 5
"""A sample with a rolled camera, objects the frame cuts and objects wholly in view."""


def _wrapped(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, np.ndarray], list[Placement], Path]:
    """(the arrays of sample :data:`SEED` written at 64×48, the room-frame placements the furnisher made for it,
    the data set folder)."""
    placed: list[Placement] = []
    furnish = Furnisher.furnish

    def recording(self: Furnisher, theme: str) -> list[tuple[Placement, float]]:
        made = furnish(self, theme)
        placed.extend(placement for placement, _ in made)
        return made

    folder = tmp_path_factory.mktemp("synth_data")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Furnisher, "furnish", recording)
        write_sample(SEED, folder, spp=2, width=64, height=48, textures=[])
    with np.load(folder / f"{SEED:06d}.npz") as data:
        return dict(data), placed, folder


def test_each_placed_model_is_labelled_with_its_box_in_the_camera_frame(
    written: tuple[dict[str, np.ndarray], list[Placement], Path],
) -> None:
    data, placed, folder = written
    room_center, room_yaw = data["room"][:3], float(data["room"][6])
    pose = data["camera_to_world"]
    rotation, origin = pose[:3, :3], pose[:3, 3]
    heading = math.atan2(rotation[0, 2], rotation[2, 2])
    ids = data["instance_ids"].tolist()
    assert set(np.unique(data["instance"]).tolist()) - {0} <= set(ids)
    assert [k for k in ids if k < 1000] == [p.segment_id for p in placed] and len(placed) > 5
    for placement in placed:  # room frame → world → camera frame, by hand
        k = ids.index(placement.segment_id)
        low, high = placement.mesh.vertices.min(axis=0), placement.mesh.vertices.max(axis=0)
        yaw = room_yaw + placement.yaw
        position = room_center * np.array([1.0, 0.0, 1.0]) + rotation_y(room_yaw) @ np.array(placement.position)
        center = position + rotation_y(yaw) @ (placement.scale * (low + high) / 2)
        np.testing.assert_allclose(data["instance_center"][k], rotation.T @ (center - origin), rtol=1.2e-7, atol=1e-9)
        np.testing.assert_allclose(data["instance_size"][k], placement.scale * (high - low), rtol=1.2e-7)
        assert abs(_wrapped(float(data["instance_yaw"][k]) - (yaw - heading))) < 1e-6
        assert -math.pi <= data["instance_yaw"][k] < math.pi
        assert data["instance_model"][k] == placement.model_id
        assert data["instance_category"][k] == labels.CATEGORIES.index(placement.category) + 1
    for k in (i for i, instance in enumerate(ids) if instance >= 1000):  # ceiling panels: flat lamps
        assert data["instance_model"][k] == "" and data["instance_size"][k][1] == 0
        assert data["instance_category"][k] == labels.CATEGORIES.index("lamp") + 1
    assert len(build_pack(folder, folder / "pack.npz")) == 1  # the trainer reads its maps, the rest is ignored


def test_what_the_frame_cuts_is_flagged_and_partly_seen(
    written: tuple[dict[str, np.ndarray], list[Placement], Path],
) -> None:
    data = written[0]
    instance, ids, visible, cut = (
        data["instance"],
        data["instance_ids"].tolist(),
        data["instance_visible"],
        data["instance_cut"],
    )
    edges = np.concatenate([instance[0], instance[-1], instance[:, 0], instance[:, -1]])
    at_the_edge = set(np.unique(edges).tolist()) - {0}
    assert at_the_edge
    for k in at_the_edge:
        assert cut[ids.index(k)] and visible[ids.index(k)] < 1, k
    assert ((visible >= 0) & (visible <= 1)).all()
    pixels = {k: int(np.count_nonzero(instance == k)) for k in ids}
    assert all(visible[i] > 0 for i, k in enumerate(ids) if pixels[k] >= 4)
    assert (~cut & (visible == 1)).any()  # a model wholly in view and in front of everything


def test_pitch_and_roll_rebuild_the_camera_pose_the_generator_drew(
    written: tuple[dict[str, np.ndarray], list[Placement], Path],
) -> None:
    data = written[0]
    pose = data["camera_to_world"]
    pitch, roll = float(data["camera_pitch"]), float(data["camera_roll"])
    assert pitch < 0 and roll != 0
    np.testing.assert_allclose(camera_pose(pose[1, 3], math.degrees(pitch), math.degrees(roll)), pose, atol=1e-12)
    turn = rotation_y(0.7)  # the whole world turned about +Y: the camera heads 0.7, its labels stay
    turned = np.eye(4)
    turned[:3, :3], turned[:3, 3] = turn @ pose[:3, :3], turn @ pose[:3, 3]
    np.testing.assert_allclose(camera_angles(turned), (0.7, pitch, roll), atol=1e-12)
    box = InstanceBox(np.array([1.0, 0.4, 3.0]), np.array([0.5, 0.8, 0.6]), 2.9, "m", 3)
    moved = InstanceBox(turn @ box.center, box.size, box.yaw + 0.7, "m", 3)
    here, there = camera_frame_boxes({1: box}, pose), camera_frame_boxes({1: moved}, turned)
    np.testing.assert_allclose(here["center"], there["center"], atol=1e-6)
    assert abs(_wrapped(float(here["yaw"][0] - there["yaw"][0]))) < 1e-6
