"""``detector=nanodet_eyes``: the bundled NanoDet's COCO boxes and the eyes network's furniture boxes, together.

Each finds what the other misses on real photos. NanoDet, trained on real photos, names chairs, sofas, beds,
tables, TVs, plants, refrigerators and appliances well; it can only call a desk, a cabinet or a shelf by its
nearest COCO class (a desk is a "bed" or a "chair"). The eyes network, trained on psdr-room's renders, names
those. So an eyes box is added where it names what NanoDet's classes cannot, or where no NanoDet box of any
class overlaps it by box IoU ``same_iou``; where NanoDet boxed the same thing and its classes name the eyes
box's category, NanoDet's label stands (:func:`added_boxes`).

The boxes are prompts for ``segmentation=layout``. Where an added eyes box and a NanoDet box overlap by more
than its ``discovery.nms_iou``, both take the label their scores sum to most
(:func:`~psdr_room_plugins.layout.discovery.vote_labels`) and discovery keeps one object of them. The two
scores are on different scales: an eyes score is its centre heatmap's peak (at least ``center_threshold``,
0.3), so eyes boxes pass layout's score thresholds and are considered early.
"""

from __future__ import annotations

import logging
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdr_room_core.method.artifacts import Detection, Detections, Image
from psdr_room_core.method.image_boxes import box_iou
from psdr_room_core.method.labels import primary_category

from ..detectors import NanodetSettings
from ..detectors.coco import COCO_80
from ..detectors.nanodet import NanodetOnnx
from .perception import EyesDetector
from .plugin import EyesSettings

log = logging.getLogger("psdr_room")

COCO_NAMED = ("chair", "sofa", "bed", "table", "tv", "plant", "refrigerator", "appliance")
"""Database categories COCO classes name well (chair, couch, bed, dining table, tv, potted plant, refrigerator,
oven and microwave). COCO's sink, clock or book name a cabinet, a frame or a shelf only loosely: NanoDet calls
dressers "tv", so those stay the eyes network's to name."""


def added_boxes(
    coco: Detections, eyes: Detections, named: frozenset[str], same_iou: float
) -> tuple[list[Detection], list[Detection]]:
    """(added, left): the eyes boxes to add to NanoDet's, and those left to NanoDet. An eyes box is left where a
    NanoDet box overlaps it by box IoU ``same_iou`` or more and its category is ``named`` (the categories
    NanoDet's classes name) or unknown (the eyes network's "other")."""
    boxes = np.array([d.box for d in coco.items], np.float64).reshape(-1, 4)
    added: list[Detection] = []
    left: list[Detection] = []
    for d in eyes.items:
        nameable = primary_category(d.label, d.category) in (*named, "object")
        same = len(boxes) > 0 and box_iou(np.asarray(d.box, np.float64), boxes).max() >= same_iou
        (left if nameable and same else added).append(d)
    return added, left


class NanodetAndEyes:
    """NanoDet's boxes and the eyes boxes that add to them, best score first; ``source`` names both. Set a
    member's settings on its own node (``detector.nanodet_onnx.X``, ``detector.eyes.X``)."""

    def __init__(
        self, nanodet: NanodetSettings | None = None, eyes: EyesSettings | None = None, same_iou: float = 0.5
    ) -> None:
        self.nanodet = NanodetOnnx(**asdict(nanodet)) if nanodet else NanodetOnnx()
        self.eyes = EyesDetector(**asdict(eyes)) if eyes else EyesDetector()
        self.same_iou = float(same_iou)
        self.named = frozenset(COCO_NAMED) & {primary_category(COCO_80[i]) for i in self.nanodet.class_ids}

    def external_files(self, photo: Path) -> list[Path]:
        return [*self.nanodet.external_files(photo), *self.eyes.external_files(photo)]

    def unavailable(self, photo: Path) -> str | None:
        return self.nanodet.unavailable(photo) or self.eyes.unavailable(photo)

    def detect(self, image: Image, photo: Path) -> Detections:
        coco, eyes = self.nanodet.detect(image, photo), self.eyes.detect(image, photo)
        added, left = added_boxes(coco, eyes, self.named, self.same_iou)
        if left:
            log.info(
                "detector nanodet_eyes: NanoDet's boxes stand over %d eyes box(es) of what its classes name: %s",
                len(left),
                ", ".join(d.label for d in left),
            )
        items = sorted([*coco.items, *added], key=lambda d: -d.score)
        return Detections(items, source=f"{coco.source} + {eyes.source}")


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Detector

    _NanodetAndEyes_is_a_detector: type[Detector] = NanodetAndEyes
