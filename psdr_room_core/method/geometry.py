"""Triangle meshes for differentiable geometry: welded, position-only (one vertex per corner).

Split vertices (at UV or normal seams) make every split edge a silhouette for projective-sampling
renderers and double their boundary gradients (``RENDERING-NOTES.md``); geometry renders use
:func:`weld`-ed copies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TriangleMesh:
    """Vertices (N×3 float, world units) and triangles (M×3 int, counter-clockwise seen from the front)."""

    vertices: np.ndarray
    faces: np.ndarray


def weld(mesh: TriangleMesh, tolerance: float = 1e-6) -> TriangleMesh:
    """Merge vertices closer than ``tolerance`` (relative to the mesh's size) and drop degenerate faces."""
    extent = float(np.ptp(mesh.vertices, axis=0).max()) or 1.0
    keys = np.round(mesh.vertices / (tolerance * extent)).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[mesh.faces]
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    return TriangleMesh(vertices=mesh.vertices[first], faces=faces[keep])


def quad_mesh(quad: np.ndarray) -> TriangleMesh:
    """A welded two-triangle mesh for a planar quad given as 4 corners in order."""
    return TriangleMesh(vertices=np.asarray(quad, dtype=np.float64), faces=np.array([[0, 1, 2], [0, 2, 3]]))


def box_mesh(center: np.ndarray, half_size: np.ndarray, rotation: np.ndarray | None = None) -> TriangleMesh:
    """A closed, welded box (8 vertices, 12 triangles, normals outward)."""
    signs = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)]) * 2.0 - 1.0
    rotation = np.eye(3) if rotation is None else rotation
    vertices = np.asarray(center) + (signs * np.asarray(half_size)) @ rotation.T
    faces = np.array(
        [
            [0, 4, 6],
            [0, 6, 2],  # x-
            [1, 3, 7],
            [1, 7, 5],  # x+
            [0, 1, 5],
            [0, 5, 4],  # y-
            [2, 6, 7],
            [2, 7, 3],  # y+
            [0, 2, 3],
            [0, 3, 1],  # z-
            [4, 5, 7],
            [4, 7, 6],  # z+
        ]
    )
    return TriangleMesh(vertices=vertices, faces=faces)
