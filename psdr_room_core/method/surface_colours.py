"""How well the fitted room explains each pixel: colour models of its surfaces (after Hedau et al. 2009's
clutter, without their learned classifier).

Each visible surface of the fitted box (floor, ceiling, each wall) gets a colour histogram of its pixels that
no trusted object prompt covers. A pixel is *explained* by the room when its colour is among the most common
colours of the surface it lies on: those that hold ``coverage`` of the surface's own pixels (a plain wall has
one such colour, a patterned carpet several; the furniture in front of them is rarer). A weak
prompt whose mask the room explains is the floor or a wall, not an object; the pixels it does not explain are
clutter, the seeds of class-agnostic proposals (:mod:`psdr_room_plugins.layout.proposals`).

The material stage asks the same question of every scene part (:func:`clean_pixels`): its crops and median
colour come from the pixels its own colour model explains and no strong edge crosses, so a wall's material is
fitted to the wall and not to the shelf in front of it; :func:`texture_energy` then tells a plain surface
from a textured one.
"""

from __future__ import annotations

from collections.abc import Iterable

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter

BINS = (8, 12, 12)
"""Histogram bins along L*, a*, b*."""


def colour_bins(rgb8: np.ndarray) -> np.ndarray:
    """The flat index of each pixel's L*a*b* histogram bin (:data:`BINS`), same shape as the image's pixels."""
    lab = cv2.cvtColor(np.ascontiguousarray(rgb8), cv2.COLOR_RGB2LAB)
    bins = np.minimum((lab * (np.array(BINS) / 256.0)).astype(np.int64), np.array(BINS) - 1)
    return (bins[..., 0] * BINS[1] + bins[..., 1]) * BINS[2] + bins[..., 2]


class SurfaceColours:
    """Colour histograms of the fitted room's surfaces: ``labels`` (H, W) surface index per pixel (box.trace),
    ``background`` (H, W) the pixels that may train them (no object prompt on them)."""

    def __init__(
        self,
        rgb8: np.ndarray,
        labels: np.ndarray,
        background: np.ndarray,
        coverage: float = 0.75,
        min_pixels: int = 200,
    ) -> None:
        self.index = colour_bins(rgb8)
        self.labels = labels
        self.likelihood = np.zeros(labels.shape, np.float32)
        self.explained = np.zeros(labels.shape, bool)
        self.commonness = np.zeros(labels.shape, np.float32)
        """Per pixel, the share of its surface's own pixels whose colour is rarer on it (0: as rare as any)."""
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
            ranked = np.sort(hist[self.index[train]])
            self.commonness[on] = np.searchsorted(ranked, p) / len(ranked)

    def share_explained(self, mask: np.ndarray) -> float:
        """Share of ``mask``'s pixels the room explains."""
        return float(self.explained[mask].mean()) if mask.any() else 1.0


def unprompted(shape: tuple[int, int], boxes: Iterable[tuple[float, float, float, float]]) -> np.ndarray:
    """(H, W) True outside every box."""
    free = np.ones(shape, bool)
    for x0, y0, x1, y1 in boxes:
        free[max(0, int(y0)) : int(np.ceil(y1)), max(0, int(x0)) : int(np.ceil(x1))] = False
    return free


def dominant_colour(rgb8: np.ndarray, mask: np.ndarray) -> tuple[float, float, float]:
    """The sRGB colour (0..1) most of ``mask``'s pixels share: the median of the pixels in its commonest
    L*a*b* histogram bin (:data:`BINS`). Unlike a per-channel median it never mixes a white wall, a cork board
    and a dark desk front into a colour none of them has."""
    index = colour_bins(rgb8)[mask]
    modal = index == np.bincount(index).argmax()
    return tuple(float(c) / 255.0 for c in np.median(rgb8[mask][modal], axis=0))  # type: ignore[return-value]


def edge_outliers(rgb8: np.ndarray, labels: np.ndarray, ratio: float, floor: float, window: int = 9) -> np.ndarray:
    """(H, W) True where the local edge energy (mean gradient magnitude of L* in 0..255 over a ``window``
    square) exceeds ``ratio`` times the median of its own surface's pixels and ``floor``: the outline of
    something in front of a plain wall stands out, the grain of a textured floor, present everywhere on it,
    does not."""
    lightness = cv2.cvtColor(np.ascontiguousarray(rgb8), cv2.COLOR_RGB2LAB)[..., 0].astype(np.float32)
    gy, gx = np.gradient(cv2.GaussianBlur(lightness, (0, 0), 1.0))
    energy = cv2.blur(np.hypot(gx, gy), (window, window))
    out = np.zeros(labels.shape, bool)
    for surface in np.unique(labels[labels >= 0]):
        on = labels == surface
        out[on] = energy[on] > max(floor, ratio * float(np.median(energy[on])))
    return out


def clean_pixels(
    rgb8: np.ndarray, labels: np.ndarray, coverage: float, edge_ratio: float, edge_floor: float, open_px: int
) -> np.ndarray:
    """(H, W) True on the pixels that show their surface itself: ``labels`` (H, W) gives each pixel's surface
    (−1: none); a pixel is clean when its surface's colour model explains it (:class:`SurfaceColours` at
    ``coverage``) and no :func:`edge_outliers` (``edge_ratio``, ``edge_floor``) lies within ``open_px`` // 2
    pixels. What the colour model rejects is first opened by an ``open_px`` square, so the rare colours of a
    texture's own grain stay clean while a compact object of another colour does not."""
    colours = SurfaceColours(rgb8, labels, labels >= 0, coverage=coverage, min_pixels=1)
    square = np.ones((open_px, open_px), np.uint8)
    foreign = cv2.morphologyEx((~colours.explained & (labels >= 0)).astype(np.uint8), cv2.MORPH_OPEN, square)
    edges = edge_outliers(rgb8, labels, edge_ratio, edge_floor)
    dirty = cv2.dilate(((foreign > 0) | edges).astype(np.uint8), square) > 0
    return (labels >= 0) & ~dirty


def texture_energy(rgb: np.ndarray, side: int = 64, sigma: float = 4.0) -> float:
    """How textured an (H, W, 3) sRGB crop in 0..1 is: at ``side`` pixels on its shorter side, the standard
    deviation of its luma minus a Gaussian blur of it (``sigma`` pixels: shading gradients go, grain stays),
    over the mean luma (+0.05, so dark crops do not blow up). Plain paint measures under ~0.05, wood, tiles,
    fabric and stone well above (calibration: ``benchmarks/materials.py``)."""
    full = np.asarray(rgb, np.float32) @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    scale = side / min(full.shape)
    size = (max(8, round(full.shape[1] * scale)), max(8, round(full.shape[0] * scale)))
    luma = cv2.resize(full, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    residual = luma - cv2.GaussianBlur(luma, (0, 0), sigma)
    return float(residual.std() / (luma.mean() + 0.05))
