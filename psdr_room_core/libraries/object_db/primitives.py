"""Closed primitives for the parametric furniture: boxes, rounded boxes, lathes (cylinders, cones, shades,
spheres), tubes between two points; collected by a :class:`MeshBuilder` into named material groups.

Every primitive is a closed surface with outward normals (triangles counter-clockwise seen from outside), so
the furniture built from them satisfies the database's winding convention; parts may intersect (a leg
entering a seat), which renderers do not mind.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .database import ObjectMesh, canonical_vertices

Vec = Sequence[float]


def _grid_faces(rows: int, cols: int, offset: int = 0) -> np.ndarray:
    """Two triangles per cell of a (rows+1)×(cols+1) vertex grid, row-major; counter-clockwise when the
    row index grows along the first tangent and the column index along the second with their cross
    product pointing outward."""
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = (r * (cols + 1) + c).reshape(-1)
    b, d, e = a + cols + 1, a + 1, a + cols + 2
    return np.concatenate([np.stack([a, b, e], 1), np.stack([a, e, d], 1)]) + offset


def box(center: Vec, size: Vec) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box (8 vertices, 12 triangles)."""
    signs = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)]) * 2.0 - 1.0
    vertices = np.asarray(center, dtype=np.float64) + signs * np.asarray(size, dtype=np.float64) / 2
    faces = np.array(
        [
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
        ]
    )
    return vertices, faces


def _axis_samples(half: float, radius: float, flat: int, arc: int) -> np.ndarray:
    """Coordinates along one axis of a rounded box's cube grid: the arc region, the flat span, the arc."""
    inner = half - radius
    tangent = inner + radius * np.tan(np.linspace(0.0, math.pi / 4, arc + 1))[1:]
    span = np.linspace(-inner, inner, flat + 1)
    return np.concatenate([-tangent[::-1], span, tangent])


def rounded_box(
    center: Vec, size: Vec, radius: float, arc: int = 3, flat: Sequence[int] = (1, 1, 1), puff: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """A box with edges and corners rounded to ``radius`` (``arc`` segments per eighth of a circle).

    ``flat`` subdivides the flat spans (x, y, z), for smooth ``puff``: a cushion bulge that pushes each
    face's middle outward by ``puff`` times the face's smaller half-size."""
    half = np.asarray(size, dtype=np.float64) / 2
    radius = float(min(radius, *(half * 0.999)))
    if radius <= 1e-9 and puff == 0.0:
        return box(center, size)
    radius = max(radius, 1e-4)
    samples = [_axis_samples(h, radius, max(1, f), arc) for h, f in zip(half, flat)]
    vertices, faces, offset = [], [], 0
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
        for sign in (-1.0, 1.0):
            us, vs = samples[u_axis], samples[v_axis]
            if sign < 0:  # keep (u, v, normal) right-handed: swap the in-plane axes
                us, vs, ua, va = vs, us, v_axis, u_axis
            else:
                ua, va = u_axis, v_axis
            grid = np.zeros((len(us), len(vs), 3))
            grid[..., ua] = us[:, None]
            grid[..., va] = vs[None, :]
            grid[..., axis] = sign * half[axis]
            vertices.append(grid.reshape(-1, 3))
            faces.append(_grid_faces(len(us) - 1, len(vs) - 1, offset))
            offset += len(us) * len(vs)
    q = np.concatenate(vertices)
    inner = np.clip(q, -(half - radius), half - radius)
    d = q - inner
    p = inner + radius * d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    if puff:
        t = np.clip(np.abs(p) / half, 0.0, 1.0)
        for axis in range(3):  # each face bulges where the other two coordinates are central
            others = [k for k in range(3) if k != axis]
            weight = (1 - t[:, others[0]] ** 2) * (1 - t[:, others[1]] ** 2)
            bulge = puff * min(half[others[0]], half[others[1]], 4 * half[axis]) * weight * (t[:, axis] ** 4)
            p[:, axis] += np.sign(p[:, axis]) * bulge
    vertices_out, faces_out = _weld(p, np.concatenate(faces))
    return vertices_out + np.asarray(center, dtype=np.float64), faces_out


def lathe(
    profile: Sequence[tuple[float, float]],
    segments: int = 24,
    center: Vec = (0.0, 0.0, 0.0),
    scale_z: float = 1.0,
    twist: float = 0.0,
    caps: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """A surface of revolution about the vertical axis through ``center``: ``profile`` is (radius, height)
    points with the solid on their left (bottom to top for an outer wall); with ``caps``, ends with
    radius > 0 are closed by flat discs. ``scale_z`` makes it elliptical; ``twist`` rotates the start
    angle (radians)."""
    prof = np.asarray(profile, dtype=np.float64)
    angles = twist + np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    rows = len(prof)
    grid = np.zeros((rows, segments, 3))
    grid[..., 0] = prof[:, 0:1] * ring[None, :, 0]
    grid[..., 2] = prof[:, 0:1] * ring[None, :, 1] * scale_z
    grid[..., 1] = prof[:, 1:2]
    vertices = grid.reshape(-1, 3)
    faces = []
    for r in range(rows - 1):
        a = r * segments + np.arange(segments)
        b = r * segments + (np.arange(segments) + 1) % segments
        c, d = a + segments, b + segments
        # up the profile and around from +x towards +z: (a, c, d) is counter-clockwise seen from outside
        faces += [np.stack([a, c, d], 1), np.stack([a, d, b], 1)]
    faces_array = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
    extra = []
    if caps and prof[0, 0] > 1e-9:  # bottom cap, facing down
        centre_index = len(vertices)
        vertices = np.vstack([vertices, [0.0, prof[0, 1], 0.0]])
        a = np.arange(segments)
        extra.append(np.stack([np.full(segments, centre_index), a, (a + 1) % segments], 1))
    if caps and prof[-1, 0] > 1e-9:  # top cap, facing up
        centre_index = len(vertices)
        vertices = np.vstack([vertices, [0.0, prof[-1, 1], 0.0]])
        a = (rows - 1) * segments + np.arange(segments)
        b = (rows - 1) * segments + (np.arange(segments) + 1) % segments
        extra.append(np.stack([np.full(segments, centre_index), b, a], 1))
    if extra:
        faces_array = np.concatenate([faces_array, *extra])
    vertices, faces_array = _weld(vertices, faces_array)
    return vertices + np.asarray(center, dtype=np.float64), faces_array


def cylinder(
    bottom: Vec, radius: float, height: float, segments: int = 20, radius_top: float | None = None, scale_z: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """A vertical (possibly tapered or elliptical) cylinder standing on ``bottom``."""
    top = radius if radius_top is None else radius_top
    return lathe([(radius, 0.0), (top, height)], segments, bottom, scale_z=scale_z)


def sphere(
    center: Vec, radius: float, segments: int = 16, scale: Vec = (1.0, 1.0, 1.0)
) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere (``scale`` makes an ellipsoid)."""
    rings = max(4, segments // 2)
    theta = np.linspace(0.0, math.pi, rings + 1)
    profile = [(radius * math.sin(t), -radius * math.cos(t)) for t in theta]
    vertices, faces = lathe(profile, segments)
    vertices = vertices * np.asarray(scale, dtype=np.float64)
    return vertices + np.asarray(center, dtype=np.float64), faces


def torus(center: Vec, radius: float, tube: float, segments: int = 32, sides: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A horizontal ring (a bar stool's footrest, a pillow's piping)."""
    phi = np.linspace(0.0, 2 * math.pi, sides + 1)
    profile = [(radius + tube * math.cos(p), tube * math.sin(p)) for p in phi]
    # a closed profile: its first and last rows coincide and are welded
    vertices, faces = lathe(profile, segments, caps=False)
    return vertices + np.asarray(center, dtype=np.float64), faces


def tube(
    p0: Vec, p1: Vec, radius: float, segments: int = 12, radius1: float | None = None, square: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """A round (or, with ``square``, square) strut from ``p0`` to ``p1``, e.g. a splayed leg."""
    start, end = np.asarray(p0, dtype=np.float64), np.asarray(p1, dtype=np.float64)
    axis = end - start
    length = float(np.linalg.norm(axis))
    if square:
        vertices, faces = lathe(
            [(radius * math.sqrt(2), 0.0), ((radius1 or radius) * math.sqrt(2), length)], 4, twist=math.pi / 4
        )
    else:
        vertices, faces = lathe([(radius, 0.0), (radius if radius1 is None else radius1, length)], segments)
    y = axis / max(length, 1e-12)
    helper = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    x = np.cross(y, helper)
    x /= np.linalg.norm(x)
    z = np.cross(x, y)
    rotation = np.stack([x, y, z], axis=1)  # local (x, y, z) → world; proper, keeps winding
    return vertices @ rotation.T + start, faces


def polyline_tube(points: Sequence[Vec], radius: float, segments: int = 10) -> list[tuple[np.ndarray, np.ndarray]]:
    """Tubes along a polyline (an arched lamp stem), with a sphere at each inner joint."""
    parts = [tube(a, b, radius, segments) for a, b in zip(points[:-1], points[1:])]
    parts += [sphere(p, radius, segments) for p in points[1:-1]]
    return parts


def transform(
    part: tuple[np.ndarray, np.ndarray],
    rotation: np.ndarray,
    pivot: Vec = (0.0, 0.0, 0.0),
    translate: Vec = (0.0, 0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """``part`` rotated about ``pivot`` by a proper rotation (winding kept), then translated."""
    centre = np.asarray(pivot, dtype=np.float64)
    vertices = (part[0] - centre) @ np.asarray(rotation, dtype=np.float64).T + centre + np.asarray(translate)
    return vertices, part[1]


def rot_x(degrees: float) -> np.ndarray:
    """Rotation about +x (positive tilts +y towards +z)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(degrees: float) -> np.ndarray:
    """Rotation about +y (positive turns +z towards +x)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(degrees: float) -> np.ndarray:
    """Rotation about +z (positive turns +x towards +y)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _weld(vertices: np.ndarray, faces: np.ndarray, tolerance: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident vertices and drop the triangles that collapse."""
    keys = np.round(vertices / tolerance).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    return vertices[first], faces[keep]


class MeshBuilder:
    """Parts added into named material groups, then one canonical :class:`ObjectMesh`."""

    def __init__(self) -> None:
        self._parts: list[tuple[str, np.ndarray, np.ndarray]] = []
        self._colors: dict[str, tuple[float, float, float]] = {}

    def group(self, name: str, color: Sequence[float]) -> MeshBuilder:
        """Declare a group and its sRGB base colour (groups are ordered by declaration)."""
        self._colors[name] = (float(color[0]), float(color[1]), float(color[2]))
        return self

    def add(self, group: str, part: tuple[np.ndarray, np.ndarray], mirror_x: bool = False) -> MeshBuilder:
        """Add a primitive to ``group``; ``mirror_x`` also adds its mirror image across x = 0."""
        if group not in self._colors:
            raise KeyError(f"group {group!r} is not declared")
        vertices, faces = part
        self._parts.append((group, np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)))
        if mirror_x:
            self._parts.append((group, vertices * np.array([-1.0, 1.0, 1.0]), np.asarray(faces)[:, ::-1].copy()))
        return self

    def add_all(self, group: str, parts: Sequence[tuple[np.ndarray, np.ndarray]]) -> MeshBuilder:
        for part in parts:
            self.add(group, part)
        return self

    def build(self) -> ObjectMesh:
        names = [n for n in self._colors if any(g == n for g, _, _ in self._parts)]
        index = {n: i for i, n in enumerate(names)}
        vertices, faces, groups, offset = [], [], [], 0
        for name in names:  # faces sorted by group
            for group, v, f in self._parts:
                if group == name:
                    vertices.append(v)
                    faces.append(f + offset)
                    groups.append(np.full(len(f), index[name], dtype=np.int64))
                    offset += len(v)
        all_vertices = canonical_vertices(np.concatenate(vertices))
        return ObjectMesh(
            vertices=all_vertices,
            faces=np.concatenate(faces).astype(np.int64),
            face_group=np.concatenate(groups),
            groups=tuple(names),
            colors=np.array([self._colors[n] for n in names], dtype=np.float64),
        )
