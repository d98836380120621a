"""Fast binary silhouettes of triangle meshes (no gradients): for yaw sweeps and retrieval by mask agreement.

Triangles are projected with the pinhole camera and filled with OpenCV at 1/16-pixel precision; triangles
crossing the near plane are dropped (objects stand in front of the camera).
"""

from __future__ import annotations

import cv2
import numpy as np

from .artifacts import Camera

SHIFT = 4  # fillPoly's fractional bits


def world_to_camera(points: np.ndarray, camera_to_world: np.ndarray) -> np.ndarray:
    """(N, 3) world points in the OpenCV camera frame."""
    rotation, origin = camera_to_world[:3, :3], camera_to_world[:3, 3]
    return (points - origin) @ rotation


def silhouette(camera: Camera, camera_to_world: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
               near: float = 1e-3) -> np.ndarray:
    """(H, W) bool mask of the mesh (world ``vertices``, ``faces``) seen by ``camera``."""
    local = world_to_camera(vertices, camera_to_world)
    z = local[:, 2]
    mask = np.zeros((camera.height, camera.width), np.uint8)
    in_front = np.all(z[faces] > near, axis=1)
    if not in_front.any():
        return mask.astype(bool)
    zs = np.maximum(z, near)
    uv = np.stack([camera.fx * local[:, 0] / zs + camera.cx, camera.fy * local[:, 1] / zs + camera.cy], axis=1)
    triangles = np.round(uv[faces[in_front]] * (1 << SHIFT)).astype(np.int64)
    limit = 1 << 28  # keep far-off projections inside int32
    triangles = np.clip(triangles, -limit, limit).astype(np.int32)
    cv2.fillPoly(mask, list(triangles), 1, lineType=cv2.LINE_8, shift=SHIFT)
    return mask.astype(bool)


def mask_l1(rendered: np.ndarray, target: np.ndarray) -> float:
    """Mean absolute difference of two masks (the paper's yaw-sweep criterion)."""
    return float(np.mean(np.abs(rendered.astype(np.float32) - target.astype(np.float32))))


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / union) if union else 0.0
