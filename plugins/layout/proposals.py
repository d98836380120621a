"""Class-agnostic object proposals: what the fitted room cannot explain.

Pixels whose colour the room's surfaces do not explain (:class:`~psdr_room_core.method.surface_colours.SurfaceColours`) and that no object
found so far holds are opened morphologically (thin edges, texture and noise go) and split into connected
regions; each region of a plausible size becomes a weak prompt (label ``object``: the model search tries every
category), judged like the detector's by :mod:`.discovery`. This finds what COCO has no class for (a
nightstand, a bookcase, a box) wherever it stands out from the room.
"""

from __future__ import annotations

import cv2
import numpy as np

from psdr_room_core.method.artifacts import Detection
from psdr_room_core.method.surface_colours import SurfaceColours

from .settings import ProposalParams


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
