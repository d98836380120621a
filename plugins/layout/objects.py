"""Object masks from box prompts: GrabCut (Rother et al. 2004, OpenCV) initialised with each box, or what a
network sees in the box where GrabCut finds nothing (:class:`SeenObjects`)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from psdr_room_core.method.artifacts import ROOM_CATEGORIES, Panoptic, SeenBox
from psdr_room_core.method.image_boxes import box_iou, mask_box
from psdr_room_core.method.objects import OBJECT_CATEGORIES

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


@dataclass(frozen=True)
class SeenObjects:
    """The objects another segmenter (a network) sees in the photo, one mask per instance. Where one fills a
    prompt's box, it is the one object there: its mask where GrabCut cannot cut one (rows of alike chairs,
    whose colours fill the box's margin too), no box round a group, and its label a second opinion on the
    prompt's (:meth:`label`)."""

    instances: list[np.ndarray]
    """(H, W) boolean mask of each object instance."""
    boxes: np.ndarray
    """(N, 4) each instance's box (x0, y0, x1, y1 pixels)."""
    labels: list[str]
    """Each instance's label."""
    boxes_3d: list[SeenBox | None]
    """Each instance's 3D box, where the network gives one."""
    surfaces: np.ndarray | None = None
    """(H, W) boolean: the pixels the network sees as a room surface (wall, floor or ceiling)."""

    @classmethod
    def of(cls, panoptic: Panoptic) -> SeenObjects:
        """The object and lamp segments of ``panoptic``, and its room surfaces."""
        shown = [(panoptic.ids == s.id, s) for s in panoptic.segments if s.category in OBJECT_CATEGORIES]
        shown = [(mask, segment) for mask, segment in shown if mask.any()]
        boxes = [mask_box(mask) for mask, _ in shown]
        surfaces = np.isin(panoptic.ids, [s.id for s in panoptic.segments if s.category in ROOM_CATEGORIES])
        return cls(
            [m for m, _ in shown],
            np.array(boxes, np.float64).reshape(-1, 4),
            [segment.label for _, segment in shown],
            [segment.seen for _, segment in shown],
            surfaces,
        )

    def _filling(self, box: tuple[float, float, float, float], same_iou: float) -> int | None:
        """The index of the instance whose box overlaps ``box`` (x0, y0, x1, y1 pixels) most, by box IoU
        ``same_iou`` or more: the one object the network sees there."""
        if not self.instances:
            return None
        ious = box_iou(np.asarray(box, np.float64), self.boxes)
        best = int(np.argmax(ious))
        return best if ious[best] >= same_iou else None

    def instance(self, box: tuple[float, float, float, float], same_iou: float) -> np.ndarray | None:
        """The mask of the instance filling ``box`` (see :meth:`_filling`), if any."""
        index = self._filling(box, same_iou)
        return None if index is None else self.instances[index]

    def label(self, box: tuple[float, float, float, float], same_iou: float) -> str | None:
        """The label of the instance filling ``box`` (see :meth:`_filling`), if any."""
        index = self._filling(box, same_iou)
        return None if index is None else self.labels[index]

    def box_3d(self, box: tuple[float, float, float, float], same_iou: float) -> SeenBox | None:
        """The 3D box of the instance filling ``box`` (see :meth:`_filling`), if any and the network gives one."""
        index = self._filling(box, same_iou)
        return None if index is None else self.boxes_3d[index]

    def apart(
        self, piece: tuple[float, float, float, float], whole: tuple[float, float, float, float], same_iou: float
    ) -> bool:
        """Whether an instance fills box ``piece`` (see :meth:`_filling`) that does not also fill box ``whole``:
        the network sees the piece as an object of its own, not a part of what ``whole`` boxes."""
        index = self._filling(piece, same_iou)
        return index is not None and index != self._filling(whole, same_iou)

    def surface_share(self, mask: np.ndarray) -> float:
        """Share of ``mask``'s pixels the network sees as a room surface (0 when it labels none)."""
        if self.surfaces is None or not mask.any():
            return 0.0
        return float(self.surfaces[mask].mean())

    def mask(
        self, box: tuple[float, float, float, float], taken: np.ndarray, min_fill: float, same_iou: float
    ) -> np.ndarray | None:
        """Its :meth:`instance` in ``box``, less the pixels ``taken``; None when there is none or it fills less
        than ``min_fill`` of the box."""
        one = self.instance(box, same_iou)
        if one is None:
            return None
        x0, y0, x1, y1 = (int(round(v)) for v in box)
        mask = np.zeros(one.shape, bool)
        mask[max(0, y0) : max(0, y1), max(0, x0) : max(0, x1)] = True
        mask &= one & ~taken
        return mask if mask.sum() >= min_fill * max(1, (x1 - x0) * (y1 - y0)) else None
