"""Object masks from box prompts: GrabCut (Rother et al. 2004, OpenCV) initialised with each box."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from psdr_room_core.artifacts import Detection


@dataclass(frozen=True)
class GrabCutParams:
    """Knobs of the box-prompted GrabCut."""

    iterations: int = 5
    margin: float = 0.15
    """Context around the box (fraction of its size) given to GrabCut as known background."""
    min_fill: float = 0.08
    """Masks covering less than this fraction of their box are dropped (GrabCut found no object)."""


def grabcut_mask(rgb8: np.ndarray, box: tuple[float, float, float, float], params: GrabCutParams) -> np.ndarray | None:
    """The object's boolean mask (H, W) inside ``box`` (x0, y0, x1, y1 pixels), its largest connected
    component, or None when GrabCut leaves too little of the box."""
    height, width = rgb8.shape[:2]
    x0, y0, x1, y1 = box
    bw, bh = x1 - x0, y1 - y0
    cx0, cy0 = max(0, int(x0 - params.margin * bw)), max(0, int(y0 - params.margin * bh))
    cx1, cy1 = min(width, int(np.ceil(x1 + params.margin * bw))), min(height, int(np.ceil(y1 + params.margin * bh)))
    crop = np.ascontiguousarray(rgb8[cy0:cy1, cx0:cx1, ::-1])
    rect = (int(x0) - cx0, int(y0) - cy0, max(2, int(round(bw))), max(2, int(round(bh))))
    rect = (rect[0], rect[1], min(rect[2], crop.shape[1] - rect[0]), min(rect[3], crop.shape[0] - rect[1]))
    if min(crop.shape[:2]) < 4 or rect[2] < 2 or rect[3] < 2:
        return None
    mask = np.zeros(crop.shape[:2], np.uint8)
    background, foreground = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)
    cv2.grabCut(crop, mask, rect, background, foreground, params.iterations, cv2.GC_INIT_WITH_RECT)
    object_mask = ((mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)).astype(np.uint8)
    n, components, stats, _ = cv2.connectedComponentsWithStats(object_mask, connectivity=4)
    if n <= 1:
        return None
    largest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    if stats[largest, cv2.CC_STAT_AREA] < params.min_fill * bw * bh:
        return None
    full = np.zeros((height, width), dtype=bool)
    full[cy0:cy1, cx0:cx1] = components == largest
    return full


def object_masks(rgb8: np.ndarray, detections: list[Detection], params: GrabCutParams) -> list[tuple[Detection, np.ndarray]]:
    """A mask per box prompt that GrabCut could segment, largest box first (so smaller, usually nearer
    objects are painted over larger ones by the caller)."""
    ordered = sorted(detections, key=lambda d: -(d.box[2] - d.box[0]) * (d.box[3] - d.box[1]))
    found = []
    for detection in ordered:
        mask = grabcut_mask(rgb8, detection.box, params)
        if mask is not None:
            found.append((detection, mask))
    return found
