"""Fast silhouettes and depth maps of triangle meshes (no gradients): for pose sweeps and retrieval.

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


def _projected(camera: Camera, camera_to_world: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
               near: float) -> tuple[np.ndarray, np.ndarray]:
    """(fixed-point image triangles [F,3,2] int32, mean camera depth [F]) of the faces in front of the camera."""
    local = world_to_camera(vertices, camera_to_world)
    z = local[:, 2]
    in_front = np.all(z[faces] > near, axis=1)
    zs = np.maximum(z, near)
    uv = np.stack([camera.fx * local[:, 0] / zs + camera.cx, camera.fy * local[:, 1] / zs + camera.cy], axis=1)
    kept = faces[in_front]
    limit = 1 << 28  # keep far-off projections inside int32
    triangles = np.clip(np.round(uv[kept] * (1 << SHIFT)), -limit, limit).astype(np.int32)
    return triangles, z[kept].mean(axis=1)


def silhouette(camera: Camera, camera_to_world: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
               near: float = 1e-3) -> np.ndarray:
    """(H, W) bool mask of the mesh (world ``vertices``, ``faces``) seen by ``camera``."""
    return depth_map(camera, camera_to_world, vertices, faces, near) > 0


def depth_map(camera: Camera, camera_to_world: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
              near: float = 1e-3) -> np.ndarray:
    """(H, W) float32 camera depth of the mesh (0 where it is absent): faces drawn far to near, each at its
    mean depth (painter's algorithm). One fill per triangle: OpenCV fills a list of polygons by the even-odd
    rule, which would cut overlapping triangles out."""
    triangles, z = _projected(camera, camera_to_world, vertices, faces, near)
    depth = np.zeros((camera.height, camera.width), np.float32)
    for k in np.argsort(-z, kind="stable"):
        cv2.fillConvexPoly(depth, triangles[k], float(z[k]), cv2.LINE_8, SHIFT)
    return depth


def mask_l1(rendered: np.ndarray, target: np.ndarray) -> float:
    """Mean absolute difference of two masks (the paper's yaw-sweep criterion)."""
    return float(np.mean(np.abs(rendered.astype(np.float32) - target.astype(np.float32))))


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    union = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / union) if union else 0.0
