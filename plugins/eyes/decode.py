"""What the eyes network's outputs mean, in numpy (no torch: the run-time plugins use onnxruntime only):
surface labels, furniture instances with their categories, relative depth."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .labels import OBJECT


@dataclass(frozen=True)
class Instance:
    """One piece of furniture found: its mask (output resolution), category index, centre score."""

    mask: np.ndarray
    category: int
    score: float


def softmax(logits: np.ndarray, axis: int = 0) -> np.ndarray:
    shifted = np.exp(logits - logits.max(axis=axis, keepdims=True))
    return shifted / shifted.sum(axis=axis, keepdims=True)


def instances(
    surface: np.ndarray,
    category: np.ndarray,
    center: np.ndarray,
    offset: np.ndarray,
    threshold: float = 0.3,
    min_pixels: int = 6,
    reach: float = 6.0,
) -> list[Instance]:
    """Furniture instances of one image's outputs ([C, h, w] each, no batch): centres are the heatmap's local
    maxima above ``threshold``; each object pixel joins the centre nearest to where its offset points, if that
    is within ``reach`` output pixels (else it joins none); an instance's category is the one its pixels give
    the most probability, its score its centre's value."""
    heat = center[0]
    peaks = (heat >= cv2.dilate(heat, np.ones((3, 3), np.uint8))) & (heat > threshold)
    cy, cx = np.nonzero(peaks)
    objects = surface.argmax(axis=0) == OBJECT
    if len(cy) == 0 or not objects.any():
        return []
    ys, xs = np.nonzero(objects)
    ty, tx = ys + offset[1, ys, xs], xs + offset[0, ys, xs]
    distance = (ty[:, None] - cy[None, :]) ** 2 + (tx[:, None] - cx[None, :]) ** 2
    owner = np.where(distance.min(axis=1) <= reach**2, distance.argmin(axis=1), -1)
    probabilities = softmax(category)
    found = []
    for k in range(len(cy)):
        mine = owner == k
        if mine.sum() < min_pixels:
            continue
        mask = np.zeros(heat.shape, bool)
        mask[ys[mine], xs[mine]] = True
        votes = probabilities[:, ys[mine], xs[mine]].sum(axis=1)
        found.append(Instance(mask, int(votes.argmax()), float(heat[cy[k], cx[k]])))
    return sorted(found, key=lambda i: -i.score)


def median_scaled(predicted_log_depth: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """exp(log depth) scaled so that its median over ``reference``'s valid (> 0) pixels matches it."""
    depth = np.exp(predicted_log_depth)
    valid = reference > 0
    if not valid.any():
        return depth
    return depth * float(np.median(reference[valid]) / max(float(np.median(depth[valid])), 1e-9))
