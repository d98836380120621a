"""How well the fitted room explains each pixel: colour models of its surfaces (after Hedau et al. 2009's
clutter, without their learned classifier).

Each visible surface of the fitted box (floor, ceiling, each wall) gets a colour histogram of its pixels that
no trusted object prompt covers. A pixel is *explained* by the room when its colour is among the most common
colours of the surface it lies on: those that hold ``coverage`` of the surface's own pixels (a plain wall has
one such colour, a patterned carpet several; the furniture in front of them is rarer). A weak
prompt whose mask the room explains is the floor or a wall, not an object; the pixels it does not explain are
clutter, the seeds of class-agnostic proposals (:mod:`.proposals`).
"""

from __future__ import annotations

from collections.abc import Iterable

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter

BINS = (8, 12, 12)
"""Histogram bins along L*, a*, b*."""


class SurfaceColours:
    """Colour histograms of the fitted room's surfaces: ``labels`` (H, W) surface index per pixel (box.trace),
    ``background`` (H, W) the pixels that may train them (no object prompt on them)."""

    def __init__(self, rgb8: np.ndarray, labels: np.ndarray, background: np.ndarray, coverage: float = 0.75,
                 min_pixels: int = 200) -> None:
        lab = cv2.cvtColor(np.ascontiguousarray(rgb8), cv2.COLOR_RGB2LAB)
        scale = np.array(BINS) / 256.0
        self.bins = np.minimum((lab * scale).astype(np.int64), np.array(BINS) - 1)
        self.index = (self.bins[..., 0] * BINS[1] + self.bins[..., 1]) * BINS[2] + self.bins[..., 2]
        self.labels = labels
        self.likelihood = np.zeros(labels.shape, np.float32)
        self.explained = np.zeros(labels.shape, bool)
        for surface in np.unique(labels):
            on = labels == surface
            train = on & background
            if train.sum() < min_pixels:
                continue
            hist = np.bincount(self.index[train], minlength=int(np.prod(BINS))).astype(np.float64)
            hist = gaussian_filter(hist.reshape(BINS), 0.7, mode="nearest").reshape(-1)  # neighbouring bins share
            hist /= hist.sum()
            p = hist[self.index[on]]
            threshold = np.quantile(hist[self.index[train]], 1.0 - coverage)
            self.likelihood[on] = p
            self.explained[on] = p >= threshold

    def share_explained(self, mask: np.ndarray) -> float:
        """Share of ``mask``'s pixels the room explains."""
        return float(self.explained[mask].mean()) if mask.any() else 1.0


def unprompted(shape: tuple[int, int], boxes: Iterable[tuple[float, float, float, float]]) -> np.ndarray:
    """(H, W) True outside every box."""
    free = np.ones(shape, bool)
    for x0, y0, x1, y1 in boxes:
        free[max(0, int(y0)):int(np.ceil(y1)), max(0, int(x0)):int(np.ceil(x1))] = False
    return free
