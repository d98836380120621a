"""Orientation map from line segments (after Lee, Hebert and Kanade 2009, "Geometric reasoning for single
image structure recovery").

A segment pointing at vanishing point i lies on a plane containing direction i. Sweeping it towards (and
away from) vanishing point j covers pixels that may lie on the plane spanned by i and j; a pixel covered
both by i-segments swept towards j and by j-segments swept towards i is labelled with that plane, whose
normal is the third axis k. A sweep stops at the first segment of axis k it meets (that segment lies on
another plane) and, unlike Lee et al., also after a fixed distance, which keeps spurious sweeps local.
"""

from __future__ import annotations

import cv2
import numpy as np


def segment_families(segments: np.ndarray, vanishing_points: np.ndarray, tolerance_deg: float) -> np.ndarray:
    """(N,) index of the vanishing point each segment points at (within ``tolerance_deg``), or -1.

    ``segments`` are (N, 4) ``x1, y1, x2, y2``; ``vanishing_points`` (3, 3) homogeneous, same pixels.
    """
    if len(segments) == 0:
        return np.zeros(0, dtype=np.int64)
    mid = (segments[:, :2] + segments[:, 2:]) / 2.0
    direction = segments[:, 2:] - segments[:, :2]
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-12)
    cosines = np.empty((len(segments), len(vanishing_points)))
    for k, vp in enumerate(vanishing_points):
        towards = vp[:2][None, :] - vp[2] * mid  # parallel to (vp - mid) up to sign, also for vp at infinity
        towards /= np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-12)
        cosines[:, k] = np.abs(np.sum(direction * towards, axis=1))
    best = np.argmax(cosines, axis=1)
    ok = cosines[np.arange(len(segments)), best] >= np.cos(np.radians(tolerance_deg))
    return np.where(ok, best, -1)


def _crosses(a: np.ndarray, b: np.ndarray, blockers: np.ndarray) -> np.ndarray:
    """(S, B) whether segment a[s]-b[s] properly crosses each blocker (B, 4)."""
    c, d = blockers[None, :, :2], blockers[None, :, 2:]
    a, b = a[:, None], b[:, None]

    def orient(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])

    return (orient(a, b, c) * orient(a, b, d) < 0) & (orient(c, d, a) * orient(c, d, b) < 0)


def _sweep_polygon(
    segment: np.ndarray, vp: np.ndarray, reach: float, blockers: np.ndarray, steps: int = 12
) -> np.ndarray:
    """Quadrilateral swept by ``segment`` moving towards and away from ``vp``: up to ``reach`` pixels, never
    past a finite vanishing point, and only until it meets one of ``blockers`` (segments of the third axis,
    which lie on another plane: Lee et al.'s occlusion rule)."""
    ends = segment.reshape(2, 2)
    towards = vp[None, :2] - vp[2] * ends
    towards /= np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-12)
    corners = []
    for sign in (1.0, -1.0):
        step = np.full(2, reach)
        if abs(vp[2]) > 1e-9:  # a finite vanishing point: never sweep past it
            finite = vp[:2] / vp[2]
            to_vp = finite[None] - ends
            heading = np.sign(np.sum(towards * to_vp, axis=1)) == sign
            step = np.where(heading, np.minimum(step, 0.95 * np.linalg.norm(to_vp, axis=1)), step)
        direction = sign * towards * step[:, None]
        if len(blockers):
            fractions = np.linspace(0.0, 1.0, steps + 1)[1:]
            moved = ends[None] + fractions[:, None, None] * direction[None]
            hit = _crosses(moved[:, 0], moved[:, 1], blockers).any(axis=1)
            if hit.any():
                direction = direction * (fractions[int(np.argmax(hit))] - 1.0 / steps)
        moved = ends + direction
        corners.extend(moved if sign > 0 else moved[::-1])
    return np.round(np.array(corners)).astype(np.int32)


def orientation_map(
    segments: np.ndarray, families: np.ndarray, vanishing_points: np.ndarray, shape: tuple[int, int], reach: float
) -> np.ndarray:
    """(3, H, W) float32: 1 where the pixel's plane is confidently normal to axis k (and to no other)."""
    height, width = shape
    swept = np.zeros((3, 3, height, width), dtype=np.uint8)  # [i, j]: i-segments swept towards vp j
    for segment, i in zip(segments, families):
        if i < 0:
            continue
        for j in range(3):
            if j != i:
                blockers = segments[families == 3 - i - j]
                cv2.fillPoly(swept[i, j], [_sweep_polygon(segment, vanishing_points[j], reach, blockers)], 1)
    planes = np.zeros((3, height, width), dtype=bool)
    for k in range(3):
        i, j = [a for a in range(3) if a != k]
        planes[k] = (swept[i, j] > 0) & (swept[j, i] > 0)
    exclusive = planes & (planes.sum(axis=0) == 1)[None]
    return exclusive.astype(np.float32)
