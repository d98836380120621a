"""``detector`` implementations: object boxes that prompt box-driven segmentation.

- ``nanodet_onnx`` (:mod:`.nanodet`): the bundled NanoDet COCO detector, offline, onnxruntime only;
- ``boxes_file`` (:mod:`.boxes_file`): boxes a user wrote in ``<photo stem>.boxes.yaml``;
- ``none``: no boxes (segmenters that find objects themselves).

Their parameters are in ``conf/detector/*.yaml``.
"""

from __future__ import annotations

from pathlib import Path

from psdr_room_core.artifacts import Detections, Image
from psdr_room_core.hookspecs import hookimpl
from psdr_room_core.plugins import Registry

from .boxes_file import BoxesFile
from .nanodet import NanodetOnnx


class NoDetector:
    """No object boxes."""

    def detect(self, image: Image, photo: Path) -> Detections:
        return Detections(items=[], source="none")


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("detector", "nanodet_onnx", NanodetOnnx, version="2",
                                description="COCO object boxes from the bundled NanoDet-m 416 (onnxruntime, offline)")
    registry.add_implementation("detector", "boxes_file", BoxesFile, version="1",
                                description="object boxes from <photo stem>.boxes.yaml beside the photo")
    registry.add_implementation("detector", "none", NoDetector, version="1", description="no object boxes")
