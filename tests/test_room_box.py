"""Room-box initialisation (psdr_room_core/method/room_box.py) on synthetic point clouds with known geometry."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from psdr_room_core.engine import shipped
from psdr_room_core.method.room_box import RoomInitParams, RoomInitResult, box_iou_3d, fit_floor_plane, init_room_box

PARAMS = shipped.settings(RoomInitParams, "room_init")

# Ground-truth room (truth frame: Y up, floor y = 0): 5 x 2.8 x 4 m, yawed 20 degrees.
BOX_CENTER = np.array([0.7, 1.4, -0.4])
BOX_HALF = np.array([2.5, 1.4, 2.0])
BOX_YAW = np.radians(20.0)
NOISE = 0.01


def rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def camera_rotation(heading_deg: float, pitch_down_deg: float, roll_deg: float) -> np.ndarray:
    """Camera-to-truth rotation of an OpenCV camera (x right, y down, z forward)."""
    opencv_to_y_up = np.diag([-1.0, -1.0, 1.0])
    return (
        rot_y(np.radians(heading_deg))
        @ rot_x(np.radians(pitch_down_deg))
        @ rot_z(np.radians(roll_deg))
        @ opencv_to_y_up
    )


def render_room(
    camera_local: np.ndarray,
    heading_deg: float,
    pitch_down_deg: float,
    roll_deg: float,
    rng: np.random.Generator,
    focal: float = 40.0,
    depth_error: float = 0.0,
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Ray-cast a 80 x 60 depth image (90 x 71 deg FoV at ``focal`` 40) from inside the box.

    ``camera_local`` is the camera centre in box-local coordinates (y measured from the floor); the heading is
    relative to the box yaw; ``depth_error`` scales depth by 1 ± that much from the top of the image to the bottom,
    as an estimator's smooth error (it tilts the walls). Returns camera-frame points per label, the camera rotation
    and centre (truth).
    """
    rotation = camera_rotation(np.degrees(BOX_YAW) + heading_deg, pitch_down_deg, roll_deg)
    centre = BOX_CENTER + rot_y(BOX_YAW) @ (camera_local - np.array([0.0, BOX_HALF[1], 0.0]))
    u, v = np.meshgrid(np.arange(80) + 0.5, np.arange(60) + 0.5)
    rays = np.column_stack([(u.ravel() - 40) / focal, (v.ravel() - 30) / focal, np.ones(u.size)])
    origin = rot_y(BOX_YAW).T @ (centre - BOX_CENTER)
    directions = rays @ (rot_y(BOX_YAW).T @ rotation).T
    with np.errstate(divide="ignore"):
        exits = (np.sign(directions) * BOX_HALF - origin) / directions
    face = np.argmin(exits, axis=1)
    depth_along_ray = exits[np.arange(len(rays)), face]
    points = rays * depth_along_ray[:, None]
    points *= (1 + rng.normal(0.0, NOISE, len(points)) / points[:, 2])[:, None]
    points *= (1 + depth_error * (v.ravel() / 30.0 - 1.0))[:, None]
    going_up = directions[np.arange(len(rays)), face] > 0
    labels = np.where(face == 1, np.where(going_up, "ceiling", "floor"), "wall")
    clouds = {name: points[labels == name] for name in ("floor", "wall", "ceiling")}
    return clouds, rotation, centre


def estimated_box_in_truth(result: RoomInitResult, rotation: np.ndarray, centre: np.ndarray):
    """The estimated box expressed in the truth frame (the two world frames differ by a yaw + shift)."""
    est_to_truth = rotation @ result.camera_to_world[:3, :3].T
    offset = centre - est_to_truth @ result.camera_to_world[:3, 3]
    yaw_offset = np.arctan2(est_to_truth[0, 2], est_to_truth[0, 0])
    return est_to_truth @ result.center + offset, result.half_size, result.yaw + yaw_offset


def test_ransac_floor_with_clutter() -> None:
    rng = np.random.default_rng(7)
    rotation = camera_rotation(0.0, 15.0, 3.0)
    centre = np.array([0.0, 1.4, 0.0])
    n_floor, n_clutter = 7000, 3000
    floor = np.column_stack([rng.uniform(-2, 2, n_floor), rng.normal(0, NOISE, n_floor), rng.uniform(1, 5, n_floor)])
    clutter = np.column_stack(
        [rng.uniform(-2, 2, n_clutter), rng.uniform(0.05, 1.0, n_clutter), rng.uniform(1, 5, n_clutter)]
    )
    points = (np.concatenate([floor, clutter]) - centre) @ rotation  # truth -> camera frame

    scale = np.median(np.linalg.norm(points, axis=1))
    plane, inliers = fit_floor_plane(points, 0.02 * scale, 1000, seed=0)

    true_normal = rotation.T @ np.array([0.0, 1.0, 0.0])
    assert np.degrees(np.arccos(np.clip(plane[:3] @ true_normal, -1, 1))) < 1.0
    assert abs(plane[3] - 1.4) < 0.02
    assert inliers[:n_floor].mean() > 0.95 and inliers[n_floor:].mean() < 0.1


@pytest.mark.parametrize(
    ("pitch_down_deg", "ceiling_visible"),
    [pytest.param(10.0, True, id="ceiling"), pytest.param(20.0, False, id="no-ceiling")],
)
def test_box_recovery(pitch_down_deg: float, ceiling_visible: bool) -> None:
    rng = np.random.default_rng(3)
    clouds, rotation, centre = render_room(np.array([0.5, 1.4, -1.3]), -6.0, pitch_down_deg, 2.0, rng)
    assert (len(clouds["ceiling"]) > 0) == ceiling_visible

    result = init_room_box(clouds, PARAMS, seed=0)

    assert result.ceiling_visible == ceiling_visible
    assert abs(result.camera_height - 1.4) < 0.03
    assert len(result.wall_planes) == 3
    np.testing.assert_allclose(result.center[1], result.half_size[1])  # floor at y = 0
    center, half, yaw = estimated_box_in_truth(result, rotation, centre)
    assert abs(np.degrees((yaw - BOX_YAW + np.pi / 4) % (np.pi / 2) - np.pi / 4)) < 1.0  # yaw is mod 90 deg
    if ceiling_visible:
        assert box_iou_3d(center, half, yaw, BOX_CENTER, BOX_HALF, BOX_YAW) >= 0.85
    else:  # 1.2 x the top of the walls, and at least height_ratio camera heights: the walls go on above the frame
        top = max(((clouds["wall"] @ rotation.T)[:, 1] + centre[1]).max(), centre[1])
        assert 2 * half[1] == pytest.approx(max(1.2 * top, PARAMS.height_ratio * 1.4), rel=0.03)
        same_height = np.array([center[0], BOX_CENTER[1], center[2]]), np.array([half[0], BOX_HALF[1], half[2]])
        assert box_iou_3d(*same_height, yaw, BOX_CENTER, BOX_HALF, BOX_YAW) >= 0.85


def test_walls_tilted_by_an_estimated_depth_still_give_the_box() -> None:
    """A smooth 25% depth error from the top of the photo to the bottom tilts the walls by more than 10 deg."""
    clouds, rotation, centre = render_room(
        np.array([0.5, 1.4, -1.3]), -6.0, 10.0, 2.0, np.random.default_rng(3), depth_error=0.25
    )
    result = init_room_box(clouds, PARAMS, seed=0)
    assert len(result.wall_planes) >= 2
    _, _, yaw = estimated_box_in_truth(result, rotation, centre)
    assert abs(np.degrees((yaw - BOX_YAW + np.pi / 4) % (np.pi / 2) - np.pi / 4)) < 3.0
    assert not init_room_box(
        clouds, replace(PARAMS, vertical_tolerance_deg=5.0), seed=0
    ).wall_planes  # the old tolerance


def test_an_unseen_side_wall_lies_a_room_width_beyond_the_frame() -> None:
    """A narrow view of the far wall: the side walls are out of view. The one behind the camera stays just
    behind it; the sides the camera faces go ``size_ratio`` camera heights from the walls opposite them."""
    clouds, rotation, centre = render_room(
        np.array([0.0, 1.4, -1.6]), 0.0, 15.0, 0.0, np.random.default_rng(3), focal=120.0
    )
    result = init_room_box(clouds, PARAMS, seed=0)
    assert len(result.wall_planes) == 1  # the far wall only
    size = PARAMS.size_ratio * result.camera_height
    assert 2 * result.half_size[0] == pytest.approx(size, rel=0.02)  # no side wall seen: the typical width
    behind = result.center[2] - result.half_size[2]
    assert -1.0 < behind < 0.0  # the wall the photo was taken from: just behind the camera (behind_margin)


def test_scale_free() -> None:
    clouds, _, _ = render_room(np.array([0.5, 1.4, -1.3]), -6.0, 10.0, 2.0, np.random.default_rng(3))
    result = init_room_box(clouds, PARAMS, seed=0)
    scaled = init_room_box({name: 0.1 * cloud for name, cloud in clouds.items()}, PARAMS, seed=0)

    np.testing.assert_allclose(scaled.center, 0.1 * result.center, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(scaled.half_size, 0.1 * result.half_size, rtol=1e-9)
    assert scaled.yaw == pytest.approx(result.yaw, abs=1e-12)
    assert scaled.camera_height == pytest.approx(0.1 * result.camera_height, rel=1e-9)


def test_deterministic() -> None:
    clouds, _, _ = render_room(np.array([0.5, 1.4, -1.3]), -6.0, 10.0, 2.0, np.random.default_rng(5))
    first, second = init_room_box(clouds, PARAMS, seed=11), init_room_box(clouds, PARAMS, seed=11)

    for field in ("camera_to_world", "center", "half_size", "floor_plane"):
        assert np.array_equal(getattr(first, field), getattr(second, field)), field
    assert first.yaw == second.yaw and first.camera_height == second.camera_height
    assert len(first.wall_planes) == len(second.wall_planes)
    assert all(np.array_equal(a, b) for a, b in zip(first.wall_planes, second.wall_planes))


def test_without_a_floor_the_room_stands_on_the_ceiling_or_the_walls() -> None:
    clouds, rotation, centre = render_room(np.array([0.5, 1.4, -1.3]), -6.0, 10.0, 2.0, np.random.default_rng(3))
    true_up = rotation.T @ np.array([0.0, 1.0, 0.0])  # in the camera frame
    for dropped, source in ((("floor",), "ceiling"), (("floor", "ceiling"), "walls")):
        result = init_room_box({k: (v[:12] if k in dropped else v) for k, v in clouds.items()}, PARAMS, seed=0)
        assert result.floor_source == source
        assert np.degrees(np.arccos(np.clip(result.floor_plane[:3] @ true_up, -1, 1))) < 3.0, source
        assert result.camera_height > 0.5
    on_ceiling = init_room_box({**clouds, "floor": clouds["floor"][:0]}, PARAMS, seed=0)
    ceiling_distance = 2 * BOX_HALF[1] - 1.4
    assert on_ceiling.camera_height == pytest.approx(ceiling_distance / (PARAMS.height_ratio - 1), rel=0.05)


def test_a_room_stands_on_one_wall_or_the_camera_when_nothing_else_shows_the_floor() -> None:
    clouds, rotation, _ = render_room(np.array([0.5, 1.4, -1.3]), -6.0, 10.0, 2.0, np.random.default_rng(3))
    true_up = rotation.T @ np.array([0.0, 1.0, 0.0])
    wall = clouds["wall"][np.abs(clouds["wall"][:, 0] - np.median(clouds["wall"][:, 0])) < 0.01]  # a sliver
    one_wall = init_room_box({"floor": clouds["floor"][:0], "wall": wall}, PARAMS, seed=0)
    assert one_wall.floor_source in ("wall", "camera")
    assert np.degrees(np.arccos(np.clip(one_wall.floor_plane[:3] @ true_up, -1, 1))) < 12.0  # the camera's tilt
    lowest = float(np.max(-(wall @ one_wall.floor_plane[:3])))
    assert one_wall.camera_height >= max(1.1 * lowest, PARAMS.camera_height) - 1e-9
    lower = wall + 3 * one_wall.floor_plane[:3] * -1  # something lower
    beside = init_room_box({"wall": wall, "objects": lower}, PARAMS, seed=0)
    assert beside.camera_height > one_wall.camera_height
    with pytest.raises(ValueError, match="no wall, floor or ceiling point"):
        init_room_box({}, PARAMS, seed=0)


def test_box_iou_3d() -> None:
    center, half = np.array([0.0, 1.0, 0.0]), np.array([1.0, 1.0, 2.0])
    assert box_iou_3d(center, half, 0.3, center, half, 0.3) == pytest.approx(1.0)
    assert box_iou_3d(center, half, 0.0, center, half, np.pi) == pytest.approx(1.0)
    shifted = center + np.array([1.0, 0.0, 0.0])  # half the footprint overlaps: 1/3
    assert box_iou_3d(center, half, 0.0, shifted, half, 0.0) == pytest.approx(1 / 3)
    lower = center + np.array([0.0, 1.0, 0.0])  # half the height overlaps: 1/3
    assert box_iou_3d(center, half, 0.0, lower, half, 0.0) == pytest.approx(1 / 3)
    square = np.array([1.0, 1.0, 1.0])  # unit-offset squares rotated 45 deg: octagon area 8(sqrt 2 - 1)
    octagon = 8 * (np.sqrt(2) - 1)
    assert box_iou_3d(center, square, 0.0, center, square, np.pi / 4) == pytest.approx(octagon / (8 - octagon))
    assert box_iou_3d(center, half, 0.0, center + np.array([5.0, 0, 0]), half, 0.0) == 0.0
