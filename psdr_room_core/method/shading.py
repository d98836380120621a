"""What RGB renders need besides geometry: a surface's principled-BSDF parameters (constant or UV-mapped),
planar texture coordinates in the convention of the material search, and the sRGB transfer curve."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import torch

from .geometry import TriangleMesh

Array = TypeVar("Array", np.ndarray, torch.Tensor)

SPECULAR_F0 = 0.08
"""Normal-incidence reflectance of a principled BSDF per unit ``specular`` (Mitsuba's and Blender's: 0.5 is 4%)."""


@dataclass(frozen=True)
class Surface:
    """A shape's look in RGB renders: a two-sided principled BSDF.

    ``base_color`` is a linear RGB triple or a linear [H, W, 3] map, ``roughness`` a number or a [H, W, 1]
    map; maps need ``uv`` (N×2, per vertex of the shape's mesh; 1 = one repeat, wrapped).
    """

    base_color: tuple[float, float, float] | np.ndarray = (0.5, 0.5, 0.5)
    roughness: float | np.ndarray = 0.5
    specular: float = 0.5
    uv: np.ndarray | None = None

    @property
    def mapped(self) -> bool:
        return any(np.ndim(v) == 3 for v in (self.base_color, self.roughness))


def srgb_to_linear(x: Array) -> Array:
    """The sRGB decoding curve on values in [0, 1] (numpy or torch, differentiable)."""
    if isinstance(x, torch.Tensor):  # each branch clamped to its own domain: finite gradients in both
        x = x.clamp(0.0, 1.0)
        return torch.where(x <= 0.04045, x / 12.92, ((x.clamp(min=0.04045) + 0.055) / 1.055) ** 2.4)
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(x: Array) -> Array:
    """The sRGB encoding curve, clipping to [0, 1] first (numpy or torch, differentiable)."""
    if isinstance(x, torch.Tensor):
        x = x.clamp(0.0, 1.0)
        return torch.where(x <= 0.0031308, 12.92 * x, 1.055 * x.clamp(min=0.0031308) ** (1.0 / 2.4) - 0.055)
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1.0 / 2.4) - 0.055)


def planar_frame(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(tangent, bitangent) of the planar texture mapping of a surface with this normal: world x and z on
    horizontal surfaces (within 45° of the floor), else the horizontal tangent ``up × n`` and down
    (texture v runs down, as in an image). :func:`psdr_room_core.method.material_search.surface_coordinates` uses
    the same frame."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / max(float(np.linalg.norm(n)), 1e-12)
    if abs(n[1]) > math.cos(math.radians(45)):
        return np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    tangent = np.cross([0.0, 1.0, 0.0], n)
    return tangent / np.linalg.norm(tangent), np.array([0.0, -1.0, 0.0])


def texture_transform(uv_metres: np.ndarray, tile_size: float, scale: float, rotation: float) -> np.ndarray:
    """Texture coordinates (1 = one repeat) for planar coordinates in metres: ``tile_size / scale`` metres
    per repeat, rotated by ``rotation`` degrees (the transform of the material search)."""
    a = math.radians(rotation)
    u, v = uv_metres[:, 0] * (scale / tile_size), uv_metres[:, 1] * (scale / tile_size)
    return np.stack([math.cos(a) * u - math.sin(a) * v, math.sin(a) * u + math.cos(a) * v], axis=1)


def planar_uv(mesh: TriangleMesh) -> tuple[TriangleMesh, np.ndarray]:
    """The mesh split where its faces change mapping direction, and per-vertex planar coordinates in
    metres. Faces are grouped by :func:`planar_frame` of their normal (horizontal, or the nearest of the
    four horizontal directions), so the coordinates are continuous inside each group."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    horizontal = np.abs(normals[:, 1]) > math.cos(math.radians(45))
    direction = np.round(np.arctan2(normals[:, 2], normals[:, 0]) / (math.pi / 2)).astype(int) % 4
    group = np.where(horizontal, 4, direction)
    frames = {4: planar_frame(np.array([0.0, 1.0, 0.0]))}
    for d in range(4):
        angle = d * math.pi / 2
        frames[d] = planar_frame(np.array([math.cos(angle), 0.0, math.sin(angle)]))
    out_vertices, out_uv, out_faces, offset = [], [], [], 0
    for g in np.unique(group):
        picked = faces[group == g]
        used, local = np.unique(picked, return_inverse=True)
        tangent, bitangent = frames[int(g)]
        points = vertices[used]
        out_vertices.append(points)
        out_uv.append(np.stack([points @ tangent, points @ bitangent], axis=1))
        out_faces.append(local.reshape(-1, 3) + offset)
        offset += len(used)
    return (
        TriangleMesh(np.concatenate(out_vertices), np.concatenate(out_faces)),
        np.concatenate(out_uv).astype(np.float64),
    )
