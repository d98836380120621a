"""Objects as solids: how deep two posed objects interpenetrate, and whether they occupy the same space.

Masks and depth see surfaces; two fitted objects can still pass through each other (a chair sunk into the
table behind it, a bed found twice). Each model is turned once into a voxel solid in its canonical frame:
its surface voxels (triangles sampled at half the pitch) and the voxels that lie between surface voxels
along at least two of the three axes. That is the inside of a closed mesh, and it also fills a cabinet whose
bottom face is missing (half of the built-in models are not watertight) while leaving the space under a
table top or a chair seat empty: below it, along the vertical, is nothing. Every solid voxel knows its depth,
the distance to the nearest empty voxel.

Two posed solids **interpenetrate** by the thickness of their common part: the largest ``d_a(x) + d_b(x)``
over points ``x`` inside both, where ``d`` is the depth inside each (two boxes overlapping by 10 cm give 10
cm; a pillow resting on a bed, one voxel). They **occupy the same space** when their common part holds
a large share of the smaller one's volume.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .artifacts import Placement, rotation_y

if TYPE_CHECKING:
    import torch

PITCH = 0.025
"""Voxel size (metres of the model, before its scale)."""
MAX_CELLS = 96
"""At most this many voxels along a model's longest side (the pitch grows for very large models)."""


@dataclass(frozen=True)
class Solid:
    """A model's voxel solid in its canonical frame."""

    origin: np.ndarray
    """(3,) model coordinates of voxel (0, 0, 0)'s centre."""
    pitch: float
    inside: np.ndarray
    """(X, Y, Z) bool."""
    depth: np.ndarray
    """(X, Y, Z) float32: distance from each solid voxel's centre to the solid's boundary (model units), 0 outside."""
    centres: np.ndarray
    """(N, 3) float32 model coordinates of the solid voxels' centres."""
    depths: np.ndarray
    """(N,) float32 their depths."""

    @property
    def volume(self) -> float:
        return len(self.centres) * self.pitch**3

    def depth_at(self, points: np.ndarray) -> np.ndarray:
        """(N,) depth inside the solid of model-frame points (nearest voxel; 0 outside the grid)."""
        index = np.rint((points - self.origin) / self.pitch).astype(np.int64)
        shape = np.array(self.inside.shape)
        ok = np.all((index >= 0) & (index < shape), axis=1)
        out = np.zeros(len(points), np.float32)
        out[ok] = self.depth[index[ok, 0], index[ok, 1], index[ok, 2]]
        return out


def _surface_points(vertices: np.ndarray, faces: np.ndarray, spacing: float) -> np.ndarray:
    """Points on every triangle, no two neighbours farther apart than ``spacing``."""
    tri = vertices[faces]
    longest = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2), axis=1)
    steps = np.maximum(1, np.ceil(longest / spacing)).astype(int)
    points = [vertices]
    for k in np.unique(steps):
        group = tri[steps == k]
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = (i + j) <= k
        a, b = i[keep] / k, j[keep] / k
        weights = np.stack([1.0 - a - b, a, b], axis=1)  # (M, 3) barycentric
        points.append(np.einsum("mc,tcd->tmd", weights, group).reshape(-1, 3))
    return np.concatenate(points)


def voxel_solid(vertices: np.ndarray, faces: np.ndarray) -> Solid:
    """The voxel solid of a mesh (see the module docstring)."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    pitch = max(PITCH, float(np.max(hi - lo)) / MAX_CELLS)
    origin = lo - pitch
    shape = np.ceil((hi - lo) / pitch).astype(int) + 3
    index = np.rint((_surface_points(vertices, faces, pitch / 2.0) - origin) / pitch).astype(np.int64)
    index = np.clip(index, 0, shape - 1)
    surface = np.zeros(tuple(shape), bool)
    surface[index[:, 0], index[:, 1], index[:, 2]] = True
    between = np.zeros(surface.shape, np.uint8)
    for axis in range(3):
        before = np.logical_or.accumulate(surface, axis=axis)
        after = np.flip(np.logical_or.accumulate(np.flip(surface, axis=axis), axis=axis), axis=axis)
        between += before & after
    inside = surface | (between >= 2)
    from scipy import ndimage  # scipy loads when a solid is first made

    depth = ndimage.distance_transform_edt(inside).astype(np.float32) * pitch
    depth = np.where(inside, np.maximum(depth - pitch / 2.0, pitch / 2.0), 0.0).astype(np.float32)
    cells = np.argwhere(inside)
    return Solid(
        origin=origin,
        pitch=pitch,
        inside=inside,
        depth=depth,
        centres=(cells * pitch + origin).astype(np.float32),
        depths=depth[inside],
    )


class _SolidCache:
    """Solids by model id (a model's mesh is the same in every placement of it), the last 256 kept."""

    def __init__(self, size: int = 256) -> None:
        self.size = size
        self.items: OrderedDict[tuple[str, int], Solid] = OrderedDict()
        self.lock = threading.Lock()

    def get(self, placement: Placement) -> Solid:
        key = (placement.model_id, len(placement.mesh.vertices))
        with self.lock:
            if key in self.items:
                self.items.move_to_end(key)
                return self.items[key]
        solid = voxel_solid(placement.mesh.vertices, placement.mesh.faces)
        with self.lock:
            self.items[key] = solid
            while len(self.items) > self.size:
                self.items.popitem(last=False)
        return solid


solid_of = _SolidCache().get
"""The voxel solid of a placement's model (cached by model id)."""


def to_model(placement: Placement, world: np.ndarray) -> np.ndarray:
    """World points in the placement's model frame."""
    local = (world - np.asarray(placement.position)) @ rotation_y(placement.yaw)  # R^T applied to rows
    return local / placement.scale


def to_world(placement: Placement, model: np.ndarray) -> np.ndarray:
    return (model * placement.scale) @ rotation_y(placement.yaw).T + np.asarray(placement.position)


@dataclass(frozen=True)
class Overlap:
    """What two posed objects share."""

    thickness: float
    """Interpenetration depth, metres: the largest ``d_a + d_b`` over points inside both (0: apart)."""
    shared: float
    """The common volume's share of the smaller object's volume."""


def _one_way(a: Placement, b: Placement) -> tuple[float, float]:
    """(thickness, common volume in m³) seen from ``b``'s voxels inside ``a``."""
    solid_a, solid_b = solid_of(a), solid_of(b)
    rotation = rotation_y(a.yaw).T @ rotation_y(b.yaw) * (b.scale / a.scale)  # b's model frame -> a's
    offset = rotation_y(a.yaw).T @ (np.asarray(b.position) - np.asarray(a.position)) / a.scale
    in_a = solid_b.centres @ rotation.T.astype(np.float32) + offset.astype(np.float32)
    lo = solid_a.origin - solid_a.pitch
    hi = solid_a.origin + np.array(solid_a.inside.shape) * solid_a.pitch
    near = np.flatnonzero(np.all((in_a > lo) & (in_a < hi), axis=1))
    if not near.size:
        return 0.0, 0.0
    depth_a = solid_a.depth_at(in_a[near]) * a.scale
    hit = depth_a > 0
    if not hit.any():
        return 0.0, 0.0
    depth_b = solid_b.depths[near[hit]] * b.scale
    return float(np.max(depth_a[hit] + depth_b)), float(hit.sum()) * (solid_b.pitch * b.scale) ** 3


def _boxes_apart(a: Placement, b: Placement) -> bool:
    """Whether the two objects' world bounding spheres are apart (a quick test before the voxels)."""

    def sphere(p: Placement) -> tuple[np.ndarray, float]:
        v = p.mesh.vertices
        centre_model = (v.min(axis=0) + v.max(axis=0)) / 2.0
        return to_world(p, centre_model[None])[0], 0.5 * float(np.linalg.norm(np.ptp(v, axis=0))) * p.scale

    (ca, ra), (cb, rb) = sphere(a), sphere(b)
    return float(np.linalg.norm(ca - cb)) > ra + rb


def overlap(a: Placement, b: Placement) -> Overlap:
    """How deep ``a`` and ``b`` interpenetrate and how much of the smaller one they share (both ways round)."""
    if _boxes_apart(a, b):
        return Overlap(0.0, 0.0)
    thick_ab, common_ab = _one_way(a, b)
    thick_ba, common_ba = _one_way(b, a)
    smaller = min(solid_of(a).volume * a.scale**3, solid_of(b).volume * b.scale**3)
    common = max(common_ab, common_ba)
    return Overlap(max(thick_ab, thick_ba), common / smaller if smaller > 0 else 0.0)


def field_lookup(solid: Solid, grid: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """Trilinear depth inside ``solid`` at model-frame ``points`` [N, 3] (torch, differentiable in the points; 0
    outside), ``grid`` being its depth as a [1, 1, X, Y, Z] tensor."""
    import torch

    shape = torch.tensor(solid.inside.shape, dtype=points.dtype)
    index = (points - torch.as_tensor(solid.origin, dtype=points.dtype)) / solid.pitch
    normal = 2.0 * index / (shape - 1) - 1.0  # grid_sample's coordinates, (x, y, z) -> (W, H, D) order reversed
    sampled = torch.nn.functional.grid_sample(grid, normal.flip(-1).view(1, 1, 1, -1, 3), align_corners=True)
    return sampled.view(-1)
