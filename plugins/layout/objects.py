"""Object masks from box prompts: GrabCut (Rother et al. 2004, OpenCV) initialised with each box."""

from __future__ import annotations

import cv2
import numpy as np

from .settings import GrabCutParams


def grabcut_mask(
    rgb8: np.ndarray, box: tuple[float, float, float, float], params: GrabCutParams, taken: np.ndarray | None = None
) -> np.ndarray | None:
    """The object's boolean mask (H, W) inside ``box`` (x0, y0, x1, y1 pixels): its largest connected piece
    and those ``min_part`` of it, or None when GrabCut leaves too little of the box. Pixels ``taken`` (H, W) by other objects
    start as probable background: the box's own object must win them by colour."""
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
    mask = np.full(crop.shape[:2], cv2.GC_BGD, np.uint8)
    mask[rect[1] : rect[1] + rect[3], rect[0] : rect[0] + rect[2]] = cv2.GC_PR_FGD
    if taken is not None:
        mask[(mask == cv2.GC_PR_FGD) & taken[cy0:cy1, cx0:cx1]] = cv2.GC_PR_BGD
    if not (mask == cv2.GC_PR_FGD).any():
        return None
    background, foreground = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)
    cv2.grabCut(crop, mask, None, background, foreground, params.iterations, cv2.GC_INIT_WITH_MASK)  # type: ignore[call-overload]  # the stub lacks rect=None
    object_mask = ((mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)).astype(np.uint8)
    n, components, stats, _ = cv2.connectedComponentsWithStats(object_mask, connectivity=4)
    if n <= 1:
        return None
    areas = stats[1:, cv2.CC_STAT_AREA]
    parts = 1 + np.flatnonzero(areas >= params.min_part * areas.max())  # a chair's back and seat, apart
    if areas[parts - 1].sum() < params.min_fill * bw * bh:
        return None
    full = np.zeros((height, width), dtype=bool)
    full[cy0:cy1, cx0:cx1] = np.isin(components, parts)
    return full
