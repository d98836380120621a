"""Box room hypotheses in the Manhattan frame: ray tracing to labels and depth, scoring and search.

The camera sits at the frame origin and the floor is the plane ``y = -1``: lengths are in camera heights.
A hypothesis is ``(x0, x1, ceiling, z0, z1)`` with walls at ``x = x0 < 0``, ``x = x1 > 0``, ``z = z0 < 0``
and ``z = z1 > 0`` and the ceiling at ``y = ceiling > 0``; a camera inside a box sees, along each ray, the
nearest of the six planes it hits.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .settings import SearchRange

WALL_X0, WALL_X1, FLOOR, CEILING, WALL_Z0, WALL_Z1 = range(6)
SURFACES = ("wall_x0", "wall_x1", "floor", "ceiling", "wall_z0", "wall_z1")
WALLS = (WALL_X0, WALL_X1, WALL_Z0, WALL_Z1)
NORMAL_AXIS = np.array([0, 0, 1, 1, 2, 2])
"""Frame axis each surface is normal to (the orientation map's classes)."""


def boxes_from_log(u: np.ndarray) -> np.ndarray:
    """(M, 5) hypotheses from (M, 5) log-parameters (signs of x0 and z0 restored)."""
    return np.exp(u) * np.array([-1.0, 1.0, 1.0, -1.0, 1.0])


def trace(rays: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface labels (M, N) int8 and ray parameters t (M, N) float32 of (N, 3) rays in (M, 5) boxes."""
    rays = rays.astype(np.float32)
    boxes = boxes.astype(np.float32)
    rx, ry, rz = rays[:, 0], rays[:, 1], rays[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(rx > 0, boxes[:, 1:2] / rx, boxes[:, 0:1] / rx)
        ty = np.where(ry > 0, boxes[:, 2:3] / ry, np.broadcast_to(-1.0 / ry, tx.shape))
        tz = np.where(rz > 0, boxes[:, 4:5] / rz, boxes[:, 3:4] / rz)
    t = np.stack([tx, ty, tz])
    t = np.where(np.isfinite(t) & (t > 0), t, np.inf)
    axis = np.argmin(t, axis=0)
    positive = np.stack([rx > 0, ry > 0, rz > 0])  # (3, N): which plane of the pair the ray meets
    labels = (2 * axis + np.take_along_axis(positive, axis, axis=0).astype(np.int64)).astype(np.int8)
    return labels, np.take_along_axis(t, axis[None], axis=0)[0]


def orientation_score(labels: np.ndarray, evidence: np.ndarray, total: float | None = None) -> np.ndarray:
    """(M,) evidence-weighted fraction of pixels whose surface orientation agrees with ``evidence`` (3, N), out of
    ``total`` (default: the evidence's own sum)."""
    total = max(float(evidence.sum()) if total is None else total, 1e-9)
    agree = np.take_along_axis(evidence[None], NORMAL_AXIS[labels][:, None].astype(np.int64), axis=1)[:, 0]
    return agree.sum(axis=1) / total


def label_score(labels: np.ndarray, room: np.ndarray, wall_segment: np.ndarray, n_wall_segments: int) -> np.ndarray:
    """(M,) fraction of labelled room pixels explained: floor on floor, ceiling on ceiling, each wall segment
    on a single wall (its most common one), and wall pixels of no segment on any wall.

    ``room``: (N,) 0 unlabelled, 1 wall, 2 floor, 3 ceiling; ``wall_segment``: (N,) 0..S-1 for the pixels of
    a wall segment that lies on one wall, -1 for wall pixels that may lie on any (a network's "wall" class).
    """
    n_room = max(int((room > 0).sum()), 1)
    score = ((labels == FLOOR) & (room == 2)[None]).sum(axis=1) + ((labels == CEILING) & (room == 3)[None]).sum(axis=1)
    score = score + np.isin(labels[:, (room == 1) & (wall_segment < 0)], WALLS).sum(axis=1)
    walls = (room == 1) & (wall_segment >= 0)
    if n_wall_segments and walls.any():
        m = labels.shape[0]
        index = (np.arange(m)[:, None] * n_wall_segments + wall_segment[walls][None]) * 6 + labels[:, walls]
        counts = np.bincount(index.ravel(), minlength=m * n_wall_segments * 6).reshape(m, n_wall_segments, 6)
        score = score + counts[:, :, list(WALLS)].max(axis=2).sum(axis=1)
    return score / n_room


def search(
    score: Callable[[np.ndarray], np.ndarray],
    search_range: SearchRange,
    rng: np.random.Generator,
    n_random: int,
    n_starts: int,
    batch: int = 256,
) -> tuple[np.ndarray, float]:
    """The best hypothesis (5,) and its score: random sampling in log space, then a pattern search
    (coordinate steps halving from 0.3 to 0.005 in log space) from the ``n_starts`` best samples."""
    lo, hi = search_range.bounds()
    samples = rng.uniform(lo, hi, size=(n_random, 5))
    scores = np.concatenate([score(boxes_from_log(samples[i : i + batch])) for i in range(0, n_random, batch)])
    best_u, best_s = samples[0], -np.inf
    for start in np.argsort(-scores)[:n_starts]:
        u, s = samples[start].copy(), scores[start]
        step = 0.3
        while step > 0.005:
            moves = np.concatenate([np.eye(5), -np.eye(5)]) * step
            candidates = np.clip(u[None] + moves, lo, hi)
            found = score(boxes_from_log(candidates))
            k = int(np.argmax(found))
            if found[k] > s + 1e-9:
                u, s = candidates[k], found[k]
            else:
                step /= 2.0
        if s > best_s:
            best_u, best_s = u, s
    return boxes_from_log(best_u[None])[0], float(best_s)
