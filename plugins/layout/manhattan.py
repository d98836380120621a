"""The room's Manhattan frame in the camera: gravity and the two wall directions, from vanishing points.

Frame axes, as columns of ``rotation`` in OpenCV camera coordinates (x right, y down, z forward):
``x`` and ``z`` are the horizontal wall directions (``z`` the one closest to the optical axis) and ``y``
points up. A camera-frame direction ``d`` has frame coordinates ``rotation.T @ d``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psdr_room_core.method.artifacts import Camera


@dataclass(frozen=True)
class ManhattanFrame:
    """The room axes seen from the camera and the image vanishing points of each axis."""

    rotation: np.ndarray
    """3x3: columns are the frame's x (wall direction), y (up) and z (wall direction) in camera coordinates."""
    vanishing_points: np.ndarray
    """(3, 3): unit homogeneous image points ``K @ axis`` of the x, y and z axes (w = 0 at infinity)."""
    observed: bool
    """False when no vanishing points were found and an upright camera was assumed."""

    def rays(self, camera: Camera, width: int, height: int) -> np.ndarray:
        """(height, width, 3) frame-coordinate rays through the pixel centres of a ``width`` x ``height``
        grid covering the image, scaled so their camera z is 1 (a ray parameter t is then the z-depth)."""
        sx, sy = camera.width / width, camera.height / height
        u, v = np.meshgrid((np.arange(width) + 0.5) * sx, (np.arange(height) + 0.5) * sy)
        cam = np.stack([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(u)], axis=-1)
        return cam @ self.rotation


def _nearest_rotation(m: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(m)
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, 2] *= -1
        r = u @ vt
    return r


def frame_from_vanishing_points(camera: Camera, vanishing_points: np.ndarray | list) -> ManhattanFrame:
    """The frame whose axes best match the directions ``K^-1 v`` of two or three image vanishing points.

    The axis most aligned with the image's vertical becomes ``y`` (up); of the other two, the one closest
    to the optical axis becomes ``z``. With no vanishing points an upright, level camera is assumed.
    """
    vps = np.asarray(vanishing_points, dtype=np.float64).reshape(-1, 3)
    if len(vps) < 2:
        upright = np.diag([-1.0, -1.0, 1.0])  # x = y cross z keeps the frame right-handed
        return ManhattanFrame(rotation=upright, vanishing_points=_image_vps(camera, upright), observed=False)
    dirs = (np.linalg.inv(camera.K) @ vps.T).T
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    up = int(np.argmax(np.abs(dirs[:, 1])))
    y = -dirs[up] * np.sign(dirs[up, 1])  # image y points down: up has a negative camera y
    rest = [d for i, d in enumerate(dirs) if i != up]
    z = max(rest, key=lambda d: abs(d[2]))
    z = z * np.sign(z[2]) if abs(z[2]) > 1e-9 else z
    x = np.cross(y, z)
    rotation = _nearest_rotation(np.stack([x, y, z], axis=1))
    return ManhattanFrame(rotation=rotation, vanishing_points=_image_vps(camera, rotation), observed=True)


def looking_down(camera: Camera, frame: ManhattanFrame, min_pitch_deg: float) -> ManhattanFrame | None:
    """The same axes with another one as up: the horizontal axis nearest the optical axis, when it points
    below it by at least ``min_pitch_deg`` (a photo looking steeply down at a floor, whose lines look like
    a wall's seen from level). None when no axis does."""
    horizontal = (frame.rotation[:, 0], frame.rotation[:, 2])
    nearest = int(np.argmax([abs(axis[2]) for axis in horizontal]))
    down = horizontal[nearest] * np.sign(horizontal[nearest][2])
    if down[1] <= 0 or down[2] < np.sin(np.radians(min_pitch_deg)):
        return None
    y = -down
    forward = np.array([0.0, 0.0, 1.0]) + down[2] * y  # the optical axis on the new horizontal plane
    z = max((frame.rotation[:, 1], horizontal[1 - nearest]), key=lambda axis: abs(axis @ forward))
    z = z * np.sign(z @ forward)
    rotation = _nearest_rotation(np.stack([np.cross(y, z), y, z], axis=1))
    return ManhattanFrame(rotation=rotation, vanishing_points=_image_vps(camera, rotation), observed=frame.observed)


def _image_vps(camera: Camera, rotation: np.ndarray) -> np.ndarray:
    vps = (camera.K @ rotation).T
    return vps / np.linalg.norm(vps, axis=1, keepdims=True)
