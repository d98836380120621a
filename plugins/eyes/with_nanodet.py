"""``detector=nanodet_eyes``: the bundled NanoDet's COCO boxes and the eyes network's furniture boxes, together.

Each finds what the other misses on real photos. NanoDet, trained on real photos, names chairs, sofas, beds,
tables, TVs, plants and refrigerators well; it can only call a desk, a cabinet or a shelf by its nearest COCO
class (a desk is a "bed" or a "dining table"). The eyes network, trained on psdr-room's renders, names those.
So an eyes box is kept where it names what COCO cannot, or where NanoDet boxed nothing there (box IoU under
``same_iou``); where NanoDet boxed the same thing and COCO can name it, NanoDet's label stands. The boxes are
prompts: where kept boxes of the two still overlap, ``segmentation=layout`` gives each the label their scores
sum to most (:func:`~psdr_room_plugins.layout.discovery.vote_labels`) and keeps one object of them.
"""

from __future__ import annotations

import logging
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdr_room_core.method.artifacts import Detection, Detections, Image
from psdr_room_core.method.labels import primary_category

from ..detectors import NanodetSettings
from ..detectors.nanodet import NanodetOnnx, box_iou
from .perception import EyesDetector
from .plugin import EyesSettings

log = logging.getLogger("psdr_room")

COCO_NAMED = ("chair", "sofa", "bed", "table", "tv", "plant", "refrigerator")
"""Database categories that COCO classes name (chair, couch, bed, dining table, tv, potted plant, refrigerator);
``object`` (the eyes network's "other") names nothing, so NanoDet's box stands over it too."""


class NanodetAndEyes:
    """NanoDet's boxes and the eyes boxes that add to them, best score first; ``source`` names both."""

    def __init__(self, nanodet: NanodetSettings, eyes: EyesSettings, same_iou: float = 0.5) -> None:
        self.nanodet = NanodetOnnx(**asdict(nanodet))
        self.eyes = EyesDetector(**asdict(eyes))
        self.same_iou = float(same_iou)

    def external_files(self, photo: Path) -> list[Path]:
        return [self.nanodet.path, *self.eyes.external_files(photo)]

    def unavailable(self, photo: Path) -> str | None:
        return self.nanodet.unavailable(photo) or self.eyes.unavailable(photo)

    def detect(self, image: Image, photo: Path) -> Detections:
        coco, eyes = self.nanodet.detect(image, photo), self.eyes.detect(image, photo)
        boxes = np.array([d.box for d in coco.items], np.float64).reshape(-1, 4)
        added: list[Detection] = []
        left: list[Detection] = []
        for d in eyes.items:
            named = primary_category(d.label, d.category) in (*COCO_NAMED, "object")
            same = len(boxes) > 0 and box_iou(np.asarray(d.box, np.float64), boxes).max() >= self.same_iou
            (left if named and same else added).append(d)
        if left:
            log.info(
                "detector nanodet_eyes: NanoDet's boxes stand over %d eyes box(es) of what COCO names: %s",
                len(left),
                ", ".join(d.label for d in left),
            )
        items = sorted([*coco.items, *added], key=lambda d: -d.score)
        return Detections(items, source=f"{coco.source} + {eyes.source}")


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Detector

    _NanodetAndEyes_is_a_detector: type[Detector] = NanodetAndEyes
