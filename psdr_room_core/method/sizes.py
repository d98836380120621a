"""Real furniture sizes (§4.3, "a fitted scale is a likelihood"): what each database category measures, and the
size prior on a posed model.

The database's models are real size (metres), so a pose that needs a bed twice its size is a wrong pose, a
wrong model or a wrong object, not a big bed. Each category has a range of **height** (floor to top),
**length** (the longer horizontal side) and **width** (the shorter one), :data:`CATEGORY_SIZES`. They are the
ranges furniture is made in, taken generously so that every style counts:

* beds from a single (0.9 × 1.9 m mattress) to a super king with its frame (2.3 m wide, 2.5 m long) and from
  a low platform to a tall headboard or a bunk (EN 1725 and the US/UK/EU mattress sizes);
* sofas from a bench or a loveseat to a corner sofa of 3 m a side, seats 0.4–0.5 m, backs to 1.25 m;
* chairs 0.45–1.4 m tall (stools to wing chairs), tables 0.3 m (coffee) to 1.15 m (bar), desks 0.6–1.25 m
  (sitting to standing: BIFMA G1), kitchen units 0.9 m and wardrobes to 2.7 m, refrigerators 0.8–2.1 m
  (Neufert, Architects' Data, furniture and kitchen chapters);
* every model of the built-in database at its own size lies inside its category's range (tested).

A posed model of extent ``e`` (canonical x, y, z) at scale ``s`` measures ``s·e``; it is inside its category's
range for scales in ``[s_lo, s_hi]`` (:func:`scale_range`). :class:`SizePrior` turns that into a penalty on
``ln s``: ``scale_weight·|ln s|`` (the model is most likely its own size) plus ``range_weight`` × how far (in
log units) the size is outside the range, which the view search and eq. 3 add to their errors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

Interval = tuple[float, float]


@dataclass(frozen=True)
class SizeRange:
    """A category's real sizes, metres."""

    height: Interval
    length: Interval
    """The longer horizontal side."""
    width: Interval
    """The shorter horizontal side."""

    def describe(self) -> str:
        return "; ".join(
            f"{name} {lo:g}-{hi:g} m"
            for name, (lo, hi) in (("height", self.height), ("length", self.length), ("width", self.width))
        )


CATEGORY_SIZES: dict[str, SizeRange] = {
    "bed": SizeRange(height=(0.25, 1.9), length=(1.85, 2.5), width=(0.85, 2.3)),
    "sofa": SizeRange(height=(0.4, 1.25), length=(0.75, 3.6), width=(0.35, 3.0)),
    "chair": SizeRange(height=(0.45, 1.4), length=(0.25, 1.5), width=(0.25, 1.1)),
    "ottoman": SizeRange(height=(0.25, 0.6), length=(0.3, 1.4), width=(0.3, 1.0)),
    "table": SizeRange(height=(0.3, 1.15), length=(0.35, 3.2), width=(0.3, 1.6)),
    "desk": SizeRange(height=(0.6, 1.25), length=(0.8, 2.4), width=(0.45, 2.0)),
    "cabinet": SizeRange(height=(0.3, 2.7), length=(0.3, 3.0), width=(0.25, 1.0)),
    "shelf": SizeRange(height=(0.3, 2.6), length=(0.3, 3.0), width=(0.15, 0.7)),
    "refrigerator": SizeRange(height=(0.8, 2.1), length=(0.5, 1.0), width=(0.5, 0.85)),
    "appliance": SizeRange(height=(0.2, 1.2), length=(0.3, 1.0), width=(0.25, 0.8)),
    "lamp": SizeRange(height=(0.15, 2.1), length=(0.1, 1.7), width=(0.1, 0.8)),
    "tv": SizeRange(height=(0.2, 1.5), length=(0.3, 2.3), width=(0.02, 0.5)),
    "frame": SizeRange(height=(0.1, 1.8), length=(0.1, 2.5), width=(0.0, 0.15)),
    "box": SizeRange(height=(0.05, 0.9), length=(0.1, 1.0), width=(0.08, 0.8)),
    "pillow": SizeRange(height=(0.08, 0.7), length=(0.25, 1.0), width=(0.05, 0.45)),
    "plant": SizeRange(height=(0.1, 2.5), length=(0.1, 1.5), width=(0.1, 1.5)),
    "rug": SizeRange(height=(0.0, 0.05), length=(0.5, 4.5), width=(0.4, 3.5)),
    "other": SizeRange(height=(0.02, 3.0), length=(0.02, 4.0), width=(0.0, 3.0)),
}
"""Database category → its real sizes (see the module docstring for the sources); ``other`` takes what a
foreign database has that maps onto no category."""


def size_range(category: str) -> SizeRange:
    """The category's sizes (``other``'s for a category without its own)."""
    return CATEGORY_SIZES.get(category, CATEGORY_SIZES["other"])


def dimensions(extent: Sequence[float], scale: float = 1.0) -> np.ndarray:
    """(height, length, width) of a canonical extent (x, y, z) at ``scale``."""
    x, y, z = (float(v) * scale for v in extent)
    return np.array([y, max(x, z), min(x, z)])


def scale_range(category: str, extent: Sequence[float]) -> Interval:
    """The scales ``[s_lo, s_hi]`` at which a model of ``extent`` is inside its category's range; where no
    scale is (its proportions are not the category's), the single scale closest to it in log terms."""
    limits = size_range(category)
    lows, highs = [0.0], [math.inf]
    for size, (lo, hi) in zip(dimensions(extent), (limits.height, limits.length, limits.width)):
        if size > 1e-3:
            lows.append(lo / size)
            highs.append(hi / size)
    low, high = max(lows), min(highs)
    if low <= high:
        return low, high
    middle = math.sqrt(low * high)
    return middle, middle


def size_excess(category: str, extent: Sequence[float], scale: float) -> float:
    """How far (log scale) a model of ``extent`` at ``scale`` lies outside its category's real sizes; 0 inside."""
    low, high = scale_range(category, extent)
    return max(0.0, math.log(low / scale) if low > 0 else 0.0, math.log(scale / high))


@dataclass(frozen=True)
class SizePrior:
    """The size prior on a posed model's scale: ``scale_weight·|ln s| + range_weight·outside(s)`` with
    ``outside(s) = max(0, ln(s_lo/s), ln(s/s_hi))`` (:func:`scale_range`)."""

    low: float
    high: float
    scale_weight: float = 0.0
    range_weight: float = 0.0

    @classmethod
    def of(cls, category: str, extent: Sequence[float], scale_weight: float, range_weight: float) -> SizePrior:
        low, high = scale_range(category, extent)
        return cls(low, high, float(scale_weight), float(range_weight))

    def outside(self, scale: float) -> float:
        """How far ``scale`` is outside ``[low, high]``, in log units (0 inside)."""
        return max(0.0, math.log(self.low / scale) if self.low > 0 else 0.0, math.log(scale / self.high))

    def penalty(self, scale: float) -> float:
        return self.scale_weight * abs(math.log(scale)) + self.range_weight * self.outside(scale)

    def clamp(self, scale: float) -> float:
        """``scale`` moved into ``[low, high]``."""
        return min(max(scale, self.low), self.high)
