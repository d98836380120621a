"""``segmentation=layout``: walls, floor and ceiling from a fitted box layout, objects from box prompts."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from psdr_room_core.method.artifacts import Camera, Detections, Image, Panoptic, Segment
from psdr_room_core.method.surface_colours import SurfaceColours, unprompted

from . import box
from .discovery import discover
from .fit import fit_layout
from .objects import SeenObjects
from .settings import LayoutSegmentationSettings

log = logging.getLogger("psdr_room")

SURFACE_CATEGORY = {
    box.WALL_X0: "wall",
    box.WALL_X1: "wall",
    box.WALL_Z0: "wall",
    box.WALL_Z1: "wall",
    box.FLOOR: "floor",
    box.CEILING: "ceiling",
}


class LayoutSegmentation:
    """Box-layout room surfaces (one segment per visible wall) with the discovered objects on top
    (:mod:`.discovery`: the prompts GrabCut cuts out and the fitted room finds plausible, far to near)."""

    def __init__(self, **settings: Any) -> None:
        """``settings``: the fields of :class:`~.settings.LayoutSegmentationSettings`."""
        self.settings = LayoutSegmentationSettings(**settings)

    def segment(
        self, image: Image, camera: Camera, detections: Detections, photo: Path, seen: Panoptic | None = None
    ) -> Panoptic:
        """The panoptic segmentation; ``seen``: another segmenter's (a network's), whose wall, floor and
        ceiling labels the box must also agree with (``label_weight``), as ``depth=layout``'s does, and whose
        objects give a prompt its mask where GrabCut finds none and a second opinion on its label
        (:class:`~.objects.SeenObjects`)."""
        fitted = fit_layout(image, camera, self.settings, detections=detections, panoptic=seen)
        labels, _ = fitted.trace(camera, image.width, image.height)
        ids = np.zeros(labels.shape, dtype=np.int32)
        segments: list[Segment] = []
        for surface in range(6):
            mask = labels == surface
            if mask.mean() >= self.settings.min_surface_fraction:
                segments.append(Segment(len(segments) + 1, SURFACE_CATEGORY[surface], box.SURFACES[surface]))
                ids[mask] = segments[-1].id
        rays = fitted.frame.rays(camera, image.width, image.height)
        rgb8 = image.to_uint8()
        trusted = [d.box for d in detections.items if d.score >= self.settings.discovery.trusted_score]
        colours = SurfaceColours(rgb8, labels, unprompted(labels.shape, trusted))
        seen_objects = SeenObjects.of(seen) if seen is not None else None
        found = discover(
            rgb8,
            rays,
            colours,
            detections.items,
            self.settings.discovery,
            self.settings.proposals,
            self.settings.grabcut,
            seen_objects,
        )
        same_iou = self.settings.discovery.seen_iou
        for item in found:
            d = item.detection
            opinion = seen_objects.label(d.box, same_iou) if seen_objects is not None else None
            box_3d = seen_objects.box_3d(d.box, same_iou) if seen_objects is not None else None
            segments.append(Segment(len(segments) + 1, d.category, d.label, d.score, d.box, opinion, box_3d))
            ids[item.mask] = segments[-1].id
        present = set(np.unique(ids).tolist())
        kept = [s for s in segments if s.id in present]
        log.info(
            "layout: box %s (score %.3f), %d objects from %d prompts (%d the network also names)",
            np.round(fitted.box, 2).tolist(),
            fitted.score,
            len(found),
            len(detections.items),
            sum(s.second_opinion is not None for s in kept),
        )
        return Panoptic(ids=ids, segments=kept)


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Segmenter

    _LayoutSegmentation_is_a_segmentation: type[Segmenter] = LayoutSegmentation
