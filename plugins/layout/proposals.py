"""Class-agnostic object proposals: what the fitted room cannot explain.

Pixels whose colour the room's surfaces do not explain (:class:`~psdr_room_core.method.surface_colours.SurfaceColours`) and that no object
found so far holds are opened morphologically (thin edges, texture and noise go) and split into connected
regions; each region of a plausible size becomes a weak prompt (label ``object``: the model search tries every
category), judged like the detector's by :mod:`.discovery`. This finds what COCO has no class for (a
nightstand, a bookcase, a box) wherever it stands out from the room.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from psdr_room_core.method.artifacts import Detection
from psdr_room_core.method.surface_colours import SurfaceColours


@dataclass(frozen=True)
class ProposalParams:
    """Knobs of :func:`clutter_proposals` (``segmentation.layout.proposals`` in the config)."""

    score: float = 0.2
    """The score a proposal carries: weak (below ``discovery.trusted_score``), so every check applies."""
    open_px: int = 7
    """Side of the square opening that cleans the unexplained pixels."""
    min_area: float = 0.004
    """Regions covering less than this share of the photo are not proposed ..."""
    max_area: float = 0.3
    """... nor those covering more (a surface the colour model missed)."""
    min_fill: float = 0.3
    """Regions filling less than this share of their box are not compact enough to be one object."""
    max_proposals: int = 8
    """The largest this many regions are proposed."""


def clutter_proposals(surfaces: SurfaceColours, taken: np.ndarray, params: ProposalParams) -> list[Detection]:
    """Prompts (largest first) round the regions the room does not explain and no object ``taken`` holds."""
    clutter = (~surfaces.explained & ~taken).astype(np.uint8)
    clutter = cv2.morphologyEx(clutter, cv2.MORPH_OPEN, np.ones((params.open_px, params.open_px), np.uint8))
    count, _, stats, _ = cv2.connectedComponentsWithStats(clutter, connectivity=8)
    total = clutter.size
    regions = []
    for x, y, w, h, area in stats[1:count]:
        if params.min_area * total <= area <= params.max_area * total and area >= params.min_fill * w * h:
            regions.append((int(area), (float(x), float(y), float(x + w), float(y + h))))
    regions.sort(key=lambda r: -r[0])
    return [
        Detection(label="object", category="object", box=box, score=params.score)
        for _, box in regions[: params.max_proposals]
    ]
