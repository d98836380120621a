"""Exact silhouettes and depth maps of triangle meshes by ray casting (no gradients): for pose searches,
retrieval and overlays.

A :class:`MeshCaster` builds one bounding-volume hierarchy (open3d) of a mesh in its own frame and moves each
pixel's ray into that frame for a pose (a similarity ``T R S``), so a mesh is posed thousands of times in a
search without rebuilding anything. Rays go through pixel centres (``u + 0.5``, as the renderer and the
back-projection of depth maps).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Sequence

import numpy as np

from .artifacts import Camera

Window = tuple[int, int, int, int]
"""(x0, y0, x1, y1): the pixels ``[y0:y1, x0:x1]`` of an image."""


def world_to_camera(points: np.ndarray, camera_to_world: np.ndarray) -> np.ndarray:
    """(N, 3) world points in the OpenCV camera frame."""
    rotation, origin = camera_to_world[:3, :3], camera_to_world[:3, 3]
    return (points - origin) @ rotation


_RAYS: OrderedDict[tuple[int, int, float, float, float, float], np.ndarray] = OrderedDict()
_RAYS_KEPT = 8
_RAYS_LOCK = threading.Lock()


def camera_rays(camera: Camera) -> np.ndarray:
    """:meth:`Camera.pixel_rays` (read-only), shared by every caster and kept for the last few cameras: a
    retrieval casts each of its models under each object's camera, and a copy per caster held 1.7 GB at 640 px."""
    key = (camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy)
    with _RAYS_LOCK:
        rays = _RAYS.get(key)
        if rays is None:
            rays = _RAYS[key] = camera.pixel_rays()
            rays.flags.writeable = False
            while len(_RAYS) > _RAYS_KEPT:
                _RAYS.popitem(last=False)
        _RAYS.move_to_end(key)
        return rays


class MeshCaster:
    """Camera depth of one mesh under any similarity pose, by ray casting against a hierarchy built once."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        import open3d as o3d  # heavy: imported when a mesh is first cast

        self._o3d = o3d
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(
            o3d.core.Tensor(np.ascontiguousarray(vertices, np.float32)),  # type: ignore[call-overload]  # open3d's stub lacks Tensor(ndarray)
            o3d.core.Tensor(np.ascontiguousarray(faces, np.uint32)),  # type: ignore[call-overload]  # open3d's stub lacks Tensor(ndarray)
        )

    def rays(self, camera: Camera, window: Window) -> np.ndarray:
        """[h*w, 3] camera-frame directions with unit z through the window's pixel centres
        (:func:`camera_rays`)."""
        x0, y0, x1, y1 = window
        return camera_rays(camera)[y0:y1, x0:x1].reshape(-1, 3)

    def depth(
        self,
        camera: Camera,
        camera_to_world: np.ndarray,
        to_world: np.ndarray | None = None,
        window: Window | None = None,
    ) -> np.ndarray:
        """(h, w) float32 z-depth of the nearest surface of the mesh posed by ``to_world`` (4×4 similarity:
        rotation times a uniform scale, plus translation; identity when None), 0 where no surface is hit,
        over ``window`` (default: the whole image)."""
        return self.depth_many(camera, camera_to_world, [np.eye(4) if to_world is None else to_world], window)[0]

    def depth_many(
        self, camera: Camera, camera_to_world: np.ndarray, poses: Sequence[np.ndarray], window: Window | None = None
    ) -> np.ndarray:
        """(K, h, w) float32 depths of the mesh under each of ``poses`` (as :meth:`depth`), cast in one call:
        each pose's rays are the same numbers :meth:`depth` casts, so the maps are equal to K single casts."""
        window = window or (0, 0, camera.width, camera.height)
        x0, y0, x1, y1 = window
        if x1 <= x0 or y1 <= y0:
            return np.zeros((len(poses), max(0, y1 - y0), max(0, x1 - x0)), np.float32)
        directions = self.rays(camera, window) @ camera_to_world[:3, :3].T
        n = len(directions)
        rays = np.empty((len(poses) * n, 6), np.float32)
        for k, to_world in enumerate(poses):  # into the mesh's frame: x_local = A^-1 (x_world - t); t is kept
            linear = to_world[:3, :3]
            inverse = linear.T / float(linear[:, 0] @ linear[:, 0])  # A = s R: A^-1 = A^T / s^2
            rays[k * n : (k + 1) * n, :3] = inverse @ (camera_to_world[:3, 3] - to_world[:3, 3])
            rays[k * n : (k + 1) * n, 3:] = directions @ inverse.T
        hit = self._scene.cast_rays(self._o3d.core.Tensor(rays))["t_hit"].numpy()  # type: ignore[call-overload]  # open3d's stub lacks Tensor(ndarray)
        return np.where(np.isfinite(hit), hit, 0.0).astype(np.float32).reshape(len(poses), y1 - y0, x1 - x0)


def depth_map(camera: Camera, camera_to_world: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(H, W) float32 z-depth of the nearest surface of the mesh (world ``vertices``, ``faces``), 0 where none."""
    return MeshCaster(vertices, faces).depth(camera, camera_to_world)


def silhouette(camera: Camera, camera_to_world: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(H, W) bool mask of the mesh (world ``vertices``, ``faces``) seen by ``camera``."""
    return depth_map(camera, camera_to_world, vertices, faces) > 0


def mask_l1(rendered: np.ndarray, target: np.ndarray) -> float:
    """Mean absolute difference of two masks (the paper's yaw-sweep criterion)."""
    return float(np.mean(np.abs(rendered.astype(np.float32) - target.astype(np.float32))))
