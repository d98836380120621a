"""3D labels of the data engine's instances, from the generator's own placements and meshes: each instance's box
in the camera frame, how much of it is seen, whether the frame cuts it, and the camera's pitch and roll.

Frames and angles (the world is Y up; ``R, t`` are camera_to_world's rotation and translation):

- camera frame: OpenCV (x right, y down, z forward), metres: ``p_camera = Rᵀ (p_world - t)``;
- heading: the camera's optical axis projected on the floor, as the angle about world +Y that
  :func:`~psdr_room_core.method.artifacts.rotation_y` turns +Z by (``atan2(f_x, f_z)``);
- pitch: the optical axis's angle above the horizontal (+ looking up); roll: the camera's turn about its optical
  axis (+ its right side down, clockwise seen from behind it); radians, as
  :func:`~psdr_room_core.libraries.synth.room.camera_pose` takes them in degrees;
- an instance's box: its centre in the camera frame; its size (w, h, d) along the model's own x, y (up) and z
  (front) axes, the scaled model's extent; its yaw: the turn about world +Y from the camera's heading to the
  model's front, in [-π, π) (0: the model faces away from the camera, ±π: towards it, +π/2: to the camera's
  left). The box's axes in the camera frame are the columns of ``Rᵀ R_y(heading + yaw)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from psdr_room_core.method.artifacts import Camera, Placement, rotation_y
from psdr_room_core.method.geometry import TriangleMesh
from psdr_room_core.method.silhouette import MeshCaster, world_to_camera


@dataclass(frozen=True)
class InstanceBox:
    """One instance as the generator placed it: an oriented box in the world (corner = ``center + R_y(yaw) @
    (±size / 2)``), its catalogue model (empty for a shape the generator made) and its category value."""

    center: np.ndarray
    size: np.ndarray
    yaw: float
    model_id: str
    category: int

    @classmethod
    def of_placement(cls, placement: Placement, category: int) -> InstanceBox:
        """The box of a world placement's scaled model (its canonical bounding box, posed)."""
        vertices = placement.mesh.vertices
        low, high = vertices.min(axis=0), vertices.max(axis=0)
        middle = placement.scale * (low + high) / 2
        return cls(
            center=np.asarray(placement.position) + rotation_y(placement.yaw) @ middle,
            size=placement.scale * (high - low),
            yaw=placement.yaw,
            model_id=placement.model_id,
            category=category,
        )


def wrap_angle(angle: float) -> float:
    """``angle`` (radians) in [-π, π)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def camera_angles(camera_to_world: np.ndarray) -> tuple[float, float, float]:
    """(heading, pitch, roll) of a camera pose, radians (the module's conventions)."""
    rotation = camera_to_world[:3, :3]
    forward = rotation[:, 2]
    heading = math.atan2(forward[0], forward[2])
    pitch = math.atan2(forward[1], math.hypot(forward[0], forward[2]))
    roll = math.atan2(-rotation[1, 0], -rotation[1, 1])  # the world-up parts of the camera's x and y axes
    return heading, pitch, roll


def camera_frame_boxes(boxes: Mapping[int, InstanceBox], camera_to_world: np.ndarray) -> dict[str, np.ndarray]:
    """The boxes in the camera frame, in ``boxes`` order: ``center`` and ``size`` (K×3 float32), ``yaw`` (K
    float32), ``model`` (K str), ``category`` (K uint8)."""
    heading = camera_angles(camera_to_world)[0]
    items = list(boxes.values())
    centers = np.array([b.center for b in items], np.float64).reshape(-1, 3)
    return {
        "center": world_to_camera(centers, camera_to_world).astype(np.float32),
        "size": np.array([b.size for b in items], np.float32).reshape(-1, 3),
        "yaw": np.array([wrap_angle(b.yaw - heading) for b in items], np.float32),
        "model": np.array([b.model_id for b in items], dtype=str),
        "category": np.array([b.category for b in items], np.uint8),
    }


def camera_frame_corners(center: np.ndarray, size: np.ndarray, yaw: float, camera_to_world: np.ndarray) -> np.ndarray:
    """The 8 corners (8, 3) of a box in the camera frame (``center``, ``size``, heading-relative ``yaw``: as
    :func:`camera_frame_boxes` gives them) of a camera posed by ``camera_to_world``."""
    heading = camera_angles(camera_to_world)[0]
    axes = camera_to_world[:3, :3].T @ rotation_y(heading + yaw)
    signs = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    return np.asarray(center) + (signs * size) @ axes.T


def _pixel_span(low: float, high: float, pad: int, size: int) -> tuple[int, int]:
    """The pixel columns (or rows) ``[start, stop)`` of a padded canvas ``size`` wide whose centres may lie in
    image coordinates ``[low, high]``."""
    start = np.clip(np.floor(low) + pad, 0, size)
    stop = np.clip(np.ceil(high) + pad + 1, 0, size)
    return int(start), int(stop)


def visibility(
    camera: Camera, camera_to_world: np.ndarray, instances: Mapping[int, TriangleMesh], others: TriangleMesh
) -> tuple[np.ndarray, np.ndarray]:
    """(visible share float32, cut bool) of each instance mesh (world), in ``instances`` order, among the
    ``others`` (everything that is no instance), by ray casts through pixel centres.

    Visible share: the pixels where the instance is the nearest surface over the pixels its silhouette alone
    covers on the image plane extended by half the image on every side (a silhouette reaching beyond that counts
    only that far); 0 for an instance out of view. Cut: some of it lies outside the image (a vertex projects
    outside it or lies behind the camera), so also for one wholly out of view."""
    pad_x, pad_y = camera.width // 2, camera.height // 2
    canvas = replace(
        camera,
        width=camera.width + 2 * pad_x,
        height=camera.height + 2 * pad_y,
        cx=camera.cx + pad_x,
        cy=camera.cy + pad_y,
    )
    image = (pad_x, pad_y, pad_x + camera.width, pad_y + camera.height)
    nearest = MeshCaster(others.vertices, others.faces).depth(canvas, camera_to_world, window=image)
    nearest = np.where(nearest > 0, nearest, np.inf)
    owner = np.full(nearest.shape, -1)
    alone = np.zeros(len(instances), np.int64)
    cut = np.zeros(len(instances), bool)
    for k, mesh in enumerate(instances.values()):
        points = world_to_camera(mesh.vertices, camera_to_world)
        if (points[:, 2] > 0).all():
            u = camera.fx * points[:, 0] / points[:, 2] + camera.cx
            v = camera.fy * points[:, 1] / points[:, 2] + camera.cy
            cut[k] = u.min() < 0 or v.min() < 0 or u.max() > camera.width or v.max() > camera.height
            x0, x1 = _pixel_span(u.min(), u.max(), pad_x, canvas.width)
            y0, y1 = _pixel_span(v.min(), v.max(), pad_y, canvas.height)
        else:  # reaching behind the camera: its silhouette may lie anywhere
            cut[k] = True
            x0, y0, x1, y1 = 0, 0, canvas.width, canvas.height
        depth = MeshCaster(mesh.vertices, mesh.faces).depth(canvas, camera_to_world, window=(x0, y0, x1, y1))
        alone[k] = np.count_nonzero(depth)
        ix0, iy0, ix1, iy1 = max(x0, image[0]), max(y0, image[1]), min(x1, image[2]), min(y1, image[3])
        if ix1 <= ix0 or iy1 <= iy0:
            continue
        inside = depth[iy0 - y0 : iy1 - y0, ix0 - x0 : ix1 - x0]
        region = (slice(iy0 - pad_y, iy1 - pad_y), slice(ix0 - pad_x, ix1 - pad_x))
        closer = (inside > 0) & (inside < nearest[region])
        nearest[region][closer] = inside[closer]
        owner[region][closer] = k
    visible = np.bincount(owner[owner >= 0], minlength=len(instances))
    share = np.where(alone > 0, visible / np.maximum(alone, 1), 0.0).astype(np.float32)
    return share, cut
