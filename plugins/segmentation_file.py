"""``segmentation=file``: a panoptic segmentation drawn or corrected by a user, read from beside the photo.

Formats: LabelMe polygons (``<photo stem>.labelme.json``: draw or fix masks in the LabelMe tool) or
COCO panoptic (``<photo stem>.panoptic.png`` + ``.panoptic.json``, what the ``segment`` stage saves).
psdr-room-studio's own copy (``<photo stem>.studio.panoptic.png`` + ``.json``: the user's file, or the automatic
segmentation, with the boxes and marks drawn in the studio) comes before both; deleting it (the studio's *Reset
segmentation*) returns to them. Class names are mapped to the room categories (wall, floor, ceiling, window, door,
lamp, object).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting
from psdr_room_core.libraries.sidecar_depth import SidecarError
from psdr_room_core.libraries.sidecar_segmentation import (
    find_segmentation_sidecar,
    panoptic_json_for,
    read_coco_panoptic,
    read_labelme,
)
from psdr_room_core.method.artifacts import Camera, Detections, Image, Panoptic


class FileSegmentation:
    """Segments from a LabelMe JSON or a COCO-panoptic PNG+JSON (``path``, or found beside the photo)."""

    def __init__(self, path: str | None = None) -> None:
        self.path = Path(path).expanduser() if path else None

    def _locate(self, photo: Path) -> tuple[str, Path]:
        if self.path is not None:
            return ("labelme" if self.path.suffix.lower() == ".json" else "coco_panoptic", self.path)
        found = find_segmentation_sidecar(photo)
        if found is None:
            raise PsdrRoomError(
                f"{photo}: no segmentation beside it ({photo.stem}.labelme.json or {photo.stem}.panoptic.png); "
                "draw one with LabelMe, set segmentation.file.path=FILE, or choose another segmentation implementation"
            )
        return found

    def external_files(self, photo: Path) -> list[Path]:
        if self.path is None and find_segmentation_sidecar(photo) is None:
            return []
        kind, path = self._locate(photo)
        return [path] if kind == "labelme" else [path, panoptic_json_for(path)]

    def unavailable(self, photo: Path) -> str | None:
        if self.path is not None:
            return None if self.path.is_file() else f"{self.path} does not exist"
        found = find_segmentation_sidecar(photo)
        return (
            None if found is not None else f"no {photo.stem}.labelme.json or {photo.stem}.panoptic.png beside the photo"
        )

    def segment(self, image: Image, camera: Camera, detections: Detections, photo: Path) -> Panoptic:
        return read_segmentation(*self._locate(photo), image)


def read_segmentation(kind: str, path: Path, image: Image) -> Panoptic:
    """The segmentation in ``path`` (``kind``: ``labelme`` or ``coco_panoptic``) on ``image``'s pixels: a map of
    the photo's aspect is resized (prompt boxes with it); a wrong file is a one-line :class:`PsdrRoomError`."""
    try:
        if kind == "labelme":
            ids, segments = read_labelme(path, (image.height, image.width))
        else:
            ids, segments = read_coco_panoptic(path, panoptic_json_for(path))
    except SidecarError as exc:
        raise PsdrRoomError(str(exc)) from None
    if ids.shape != (image.height, image.width):
        if abs(ids.shape[1] / ids.shape[0] - image.width / image.height) > 0.01:
            raise PsdrRoomError(f"{path}: segmentation is {ids.shape[1]}x{ids.shape[0]}, not aligned with the photo")
        sx, sy = image.width / ids.shape[1], image.height / ids.shape[0]
        ids = cv2.resize(ids, (image.width, image.height), interpolation=cv2.INTER_NEAREST)
        segments = [
            s if s.box is None else replace(s, box=(s.box[0] * sx, s.box[1] * sy, s.box[2] * sx, s.box[3] * sy))
            for s in segments
        ]
    present = set(np.unique(ids).tolist())
    return Panoptic(ids=ids.astype(np.int32), segments=[s for s in segments if s.id in present])


@dataclass
class FileSegmentationSettings:
    """``segmentation=file``: where the segmentation file is."""

    path: str | None = setting(
        doc="The segmentation file; null: <photo stem>.labelme.json, else <photo stem>.panoptic.png (+ .panoptic.json)."
    )


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation(
        "segmentation", "file", FileSegmentation, params=FileSegmentationSettings, reads_files=True
    )


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Segmenter

    _FileSegmentation_is_a_segmentation: type[Segmenter] = FileSegmentation
