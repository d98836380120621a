"""``segmentation=layout_eyes`` and ``depth=layout_eyes``: the offline box layout, helped by the eyes network.

``segmentation=layout`` fits its box room to the photo's lines and a floor prior alone. Where a room has few
lines (a plain wall meeting a plain ceiling) or many that are not the room's (rows of desks, shelves), the box
can put the ceiling on a wall or the floor on furniture; every stage after it stands objects on that floor and
scales them by it. The eyes network, trained on psdr-room's renders, labels wall, floor and ceiling pixels
directly. ``segmentation=layout_eyes`` fits the box to its labels too, as ``depth=layout`` fits the
segmentation's (``label_weight``: agreement with them, against the lines'); its walls, windows and doors may
lie on any wall of the box. The objects are layout's own: the detector's prompts cut out by GrabCut, so the
user's boxes still apply. Where one of the network's furniture instances fills a prompt's box (box IoU
``segmentation.layout.discovery.seen_iou``), it is the one object there: its mask where GrabCut finds nothing
(rows of alike chairs, whose colours fill the box's margin too), and the box is no box round a group.

``depth=layout`` stands each object where its mask meets the floor. An object whose contact is hidden (a desk
behind another, feet below the frame) has none, and is put against the room surface behind it.
``depth=layout_eyes`` gives such an object the eyes network's relative depth instead, scaled to the layout's
on the pixels the layout places (room surfaces and the objects it stood on the floor), never beyond the room.

The layout knows the room's shape in camera heights; ``depth=layout`` assumes the camera's height
(``camera_height_m``). Furniture has real sizes, and the segmentation's 3D boxes (``segmentation=eyes`` or
``layout_eyes``) say how far each object is: ``depth=layout_eyes`` takes the camera height at which the layout's
object depths match the boxes' (their median ratio over the objects), within ``camera_heights``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import asdict, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from psdr_room_core.method.artifacts import Camera, DepthMap, Detections, Image, Panoptic
from psdr_room_core.method.objects import OBJECT_CATEGORIES
from psdr_room_core.method.seen_boxes import depth_ratio

from ..layout.depth import LayoutDepth
from ..layout.segmentation import LayoutSegmentation
from ..layout.settings import LayoutDepthSettings, LayoutSegmentationSettings
from .perception import Eyes, EyesDepth
from .plugin import EyesSettings

log = logging.getLogger("psdr_room")


class _LayoutHelpedByEyes:
    """What the eyes network needs, for a layout implementation helped by it: its file, and why it cannot run."""

    eyes: Eyes

    def external_files(self, photo: Path) -> list[Path]:
        return self.eyes.external_files(photo)

    def unavailable(self, photo: Path) -> str | None:
        return self.eyes.unavailable(photo)


class LayoutWithEyesSurfaces(_LayoutHelpedByEyes):
    """``segmentation=layout`` whose box also agrees with the eyes network's room surfaces. Set a member's
    settings on its own node (``segmentation.layout.X``, ``segmentation.eyes.X``)."""

    def __init__(self, layout: LayoutSegmentationSettings | None = None, eyes: EyesSettings | None = None) -> None:
        # vars, not asdict: the layout's nested settings stay typed
        self.layout = LayoutSegmentation(**vars(layout)) if layout else LayoutSegmentation()
        self.eyes = Eyes(**asdict(eyes)) if eyes else Eyes()

    def segment(self, image: Image, camera: Camera, detections: Detections, photo: Path) -> Panoptic:
        seen = self.eyes.panoptic(image, camera)
        log.info(
            "layout_eyes: the box also fits %s's %s; its %d furniture instance(s) help discovery",
            self.eyes.describe(),
            ", ".join(sorted({s.category for s in seen.segments if s.category not in OBJECT_CATEGORIES}))
            or "no room surfaces",
            sum(s.category in OBJECT_CATEGORIES for s in seen.segments),
        )
        return self.layout.segment(image, camera, detections, photo, seen=seen)


class LayoutDepthWithEyes(_LayoutHelpedByEyes):
    """``depth=layout`` whose objects with no floor contact take the eyes network's depth, scaled to the layout's,
    whose objects on the floor take its shape behind their contact plane (:func:`~..layout.depth.shaped_by`), and
    whose scale is set by the segmentation's 3D boxes (:func:`camera_height`) within ``camera_heights``. Set a
    member's settings on its own node (``depth.layout.X``, ``depth.eyes.X``)."""

    eyes: EyesDepth

    def __init__(
        self,
        layout: LayoutDepthSettings | None = None,
        eyes: EyesSettings | None = None,
        *,
        camera_heights: Sequence[float],
    ) -> None:
        self.layout = LayoutDepth(**vars(layout)) if layout else LayoutDepth()
        self.eyes = EyesDepth(**asdict(eyes)) if eyes else EyesDepth()
        low, high = sorted(float(h) for h in camera_heights)
        self.camera_heights = (low, high)

    def estimate(self, image: Image, camera: Camera, panoptic: Panoptic, photo: Path) -> DepthMap:
        relative = self.eyes.estimate(image, camera, panoptic, photo)
        depth = self.layout.estimate(image, camera, panoptic, photo, relative=relative.depth)
        assumed = self.layout.settings.camera_height_m
        height = camera_height(depth.depth, panoptic, assumed, self.camera_heights)
        source = f"{depth.source}; objects with no floor contact: {relative.source}, scaled to it"
        if height != assumed:
            log.info(
                "layout_eyes: the 3D boxes put the camera %.2f m above the floor (%.2f m assumed)", height, assumed
            )
            source += f"; camera {height:.2f} m above the floor by the segmentation's 3D boxes"
        return replace(depth, depth=(depth.depth * (height / assumed)).astype(np.float32), source=source)


def camera_height(depth: np.ndarray, panoptic: Panoptic, assumed: float, heights: tuple[float, float]) -> float:
    """The camera height (metres) at which ``depth`` (the layout's, for a camera ``assumed`` metres high) agrees
    with the segments' 3D boxes: ``assumed`` over the median, over the segments with a box and depth, of their
    median depth over the box's near-face depth (:func:`~psdr_room_core.method.seen_boxes.depth_ratio`), within
    ``heights``; ``assumed`` where no segment has both."""
    boxes = {s.id: s.seen for s in panoptic.segments if s.seen is not None}
    depths = {}
    for segment_id in boxes:
        seen = depth[(panoptic.ids == segment_id) & (depth > 0)]
        if seen.size:
            depths[segment_id] = float(np.median(seen))
    ratio = depth_ratio(depths, boxes)
    return assumed if ratio is None else float(np.clip(assumed / ratio, *heights))


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import DepthEstimator, Segmenter

    _LayoutWithEyesSurfaces_is_a_segmentation: type[Segmenter] = LayoutWithEyesSurfaces
    _LayoutDepthWithEyes_is_a_depth: type[DepthEstimator] = LayoutDepthWithEyes
