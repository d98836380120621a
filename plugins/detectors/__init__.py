"""``detector`` implementations: object boxes that prompt box-driven segmentation.

- ``nanodet_onnx`` (:mod:`.nanodet`): the bundled NanoDet COCO detector, offline, onnxruntime only;
- ``boxes_file`` (:mod:`.boxes_file`): boxes a user wrote in ``<photo stem>.boxes.yaml``;
- ``none``: no boxes (segmenters that find objects themselves).

Their parameters are in ``conf/detector/*.yaml``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import NoSettings, setting
from psdr_room_core.method.artifacts import Detections, Image

from .boxes_file import BoxesFile
from .nanodet import NanodetOnnx


@dataclass
class NanodetSettings:
    """``detector=nanodet_onnx``: COCO boxes, prompts for the segmentation (their label is a weak prior: pictures
    are often "tv")."""

    path: str | None = setting(
        doc="null: the bundled nanodet.onnx; or another NanoDet export (fixed HxW input, strides 8/16/32)."
    )
    score_threshold: float = setting(
        ge=0, le=1, doc="(Cell, class) scores at least this are kept (low: segmentation=layout judges the boxes)."
    )
    nms_iou: float = setting(
        ge=0, le=1, doc="Per class, boxes overlapping a better one by more than this IoU are suppressed."
    )
    max_detections: int = setting(ge=1, doc="At most this many boxes, best first.")
    classes: list[str] | None = setting(
        doc="COCO classes kept (null: all 80); COCO has no lamp, window, door, cabinet or shelf."
    )
    flip: bool = setting(doc="Also run the mirrored photo (test-time augmentation).")
    intra_op_threads: int = setting(ge=0, doc="onnxruntime threads (0: the run's run.threads).")
    providers: list[str] = setting(
        doc="onnxruntime execution providers tried in order where available (e.g. CUDAExecutionProvider first)."
    )


@dataclass
class BoxesFileSettings:
    """``detector=boxes_file``: the file the user's boxes are read from."""

    path: str | None = setting(doc="The boxes file; null: <photo stem>.boxes.yaml beside the photo.")


class NoDetector:
    """No object boxes."""

    def detect(self, image: Image, photo: Path) -> Detections:
        return Detections(items=[], source="none")


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation(
        "detector",
        "nanodet_onnx",
        NanodetOnnx,
        version="2",
        params=NanodetSettings,
        reads_files=True,
        description="COCO object boxes from the bundled NanoDet-g 416 (onnxruntime, offline)",
    )
    registry.add_implementation(
        "detector",
        "boxes_file",
        BoxesFile,
        version="1",
        params=BoxesFileSettings,
        reads_files=True,
        description="object boxes from <photo stem>.boxes.yaml beside the photo",
    )
    registry.add_implementation(
        "detector", "none", NoDetector, version="1", description="no object boxes", params=NoSettings, reads_files=False
    )


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Detector

    _NoDetector_is_a_detector: type[Detector] = NoDetector
