"""``segmentation=onnx``: an ADE20K-150 network turned into a panoptic segmentation (§4.1).

Families:

- ``segformer_ade20k``: per-pixel classification, output ``logits [N,150,H/4,W/4]``;
- ``mask2former_ade20k``: mask classification (Mask2Former, MaskFormer), outputs
  ``class_queries_logits [N,Q,151]`` (the last class is "no object") and ``masks_queries_logits [N,Q,h,w]``;
  per-class scores are ``softmax(class)[:, :150]ᵀ · sigmoid(masks)`` (the semantic inference of both papers).

The class scores are resized bilinearly to the working image and the best class taken per pixel; only the
classes that win somewhere at the network's resolution are resized, which gives the same map at a
fraction of the memory. Each class present becomes segments labelled with its ADE20K name (``chair``,
``windowpane``) and mapped to a category by :mod:`.ade20k`: region classes (wall, floor, ceiling, sky, ...)
one segment per class, other classes one segment per connected component. Segments smaller than
``min_segment_fraction`` of the image are left unlabelled (id 0).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from psdr_room_core.method.artifacts import Camera, Detections, Image, Panoptic, Segment

from . import ade20k
from .network import (
    INPUTS,
    OnnxNetwork,
    Port,
    network_size,
    resize_channels,
    resolve_model,
    to_network,
    unusable_reason,
)

FAMILIES = ("segformer_ade20k", "mask2former_ade20k")
N_CLASSES = len(ade20k.ADE20K_150)


def class_map(scores: np.ndarray, hw: tuple[int, int]) -> np.ndarray:
    """Per-pixel argmax at ``hw`` of CxhxW class scores resized bilinearly (only classes that win at h x w)."""
    winners = np.unique(scores.argmax(axis=0))
    if len(winners) == 1:
        return np.full(hw, winners[0], np.int32)
    resized = resize_channels(scores[winners], hw, cv2.INTER_LINEAR)
    return winners[resized.argmax(axis=0)].astype(np.int32)


def panoptic_from_classes(classes: np.ndarray, min_fraction: float = 0.0) -> Panoptic:
    """Segments from an ADE20K class map (see the module docstring)."""
    height, width = classes.shape
    min_area = max(1, int(round(float(min_fraction) * height * width)))
    ids = np.zeros((height, width), np.int32)
    segments: list[Segment] = []
    for k in np.unique(classes).tolist():
        mask = (classes == k).astype(np.uint8)
        if k in ade20k.STUFF:
            parts = [mask.astype(bool)]
        else:
            count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            order = sorted(range(1, count), key=lambda c: (-stats[c, cv2.CC_STAT_AREA], c))
            parts = [labels == c for c in order]
        for part in parts:
            if int(part.sum()) < min_area:
                continue
            segment_id = len(segments) + 1
            ids[part] = segment_id
            segments.append(Segment(segment_id, ade20k.CATEGORIES[k], ade20k.LABELS[k]))
    return Panoptic(ids=ids, segments=segments)


def _softmax(x: np.ndarray, axis: int) -> np.ndarray:
    e = np.exp(x - x.max(axis=axis, keepdims=True))
    return e / e.sum(axis=axis, keepdims=True)


class OnnxSegmentation:
    """Panoptic segmentation from an ONNX ADE20K network (SegFormer, Mask2Former/MaskFormer)."""

    def __init__(
        self,
        model: str | None = "segformer_b0_ade20k",
        path: str | None = None,
        family: str | None = None,
        models_dir: str | None = None,
        input_size: int | None = None,
        intra_op_threads: int = 0,
        providers: Sequence[str] = ("CPUExecutionProvider",),
        min_segment_fraction: float = 0.0005,
    ) -> None:
        self._params = dict(model=model, path=path, family=family, models_dir=models_dir)
        self.input_size = int(input_size) if input_size else None
        self.threads = int(intra_op_threads)
        self.providers = tuple(providers or ())
        self.min_segment_fraction = float(min_segment_fraction)
        self._network: OnnxNetwork | None = None

    @property
    def network(self) -> OnnxNetwork:
        if self._network is None:
            self._network = OnnxNetwork(
                resolve_model("segmentation", FAMILIES, **self._params), self.threads, self.providers
            )
        return self._network

    def external_files(self, photo: Path) -> list[Path]:
        return [self.network.model.path]

    def unavailable(self, photo: Path) -> str | None:
        return unusable_reason(resolve_model("segmentation", FAMILIES, **self._params))

    def segment(self, image: Image, camera: Camera, detections: Detections, photo: Path) -> Panoptic:
        net = self.network
        spec = INPUTS[net.model.family]
        net.image_input()
        hw = network_size(image.height, image.width, spec, self.input_size, net.fixed_size())
        pixel_values = to_network(image.rgb, spec, hw)
        if net.model.family == "segformer_ade20k":
            scores = self._segformer_scores(net, pixel_values)
        else:
            scores = self._mask_classification_scores(net, pixel_values)
        classes = class_map(scores, (image.height, image.width))
        return panoptic_from_classes(classes, self.min_segment_fraction)

    # ----------------------------------------------------------------------------------- families
    @staticmethod
    def _segformer_scores(net: OnnxNetwork, pixel_values: np.ndarray) -> np.ndarray:
        port = _pick(net, rank=4, name="logits", detail=f"expected logits [N,{N_CLASSES},h,w]")
        if port.shape[1] not in (None, N_CLASSES):
            raise net.signature_error(f"expected {N_CLASSES} ADE20K classes in {port}")
        logits = net.run(pixel_values)[port.name]
        if logits.ndim != 4 or logits.shape[1] != N_CLASSES:
            raise net.signature_error(
                f"the logits came back with shape {list(logits.shape)}, expected [N,{N_CLASSES},h,w]"
            )
        return logits[0].astype(np.float32)

    @staticmethod
    def _mask_classification_scores(net: OnnxNetwork, pixel_values: np.ndarray) -> np.ndarray:
        detail = f"expected class_queries_logits [N,Q,{N_CLASSES + 1}] and masks_queries_logits [N,Q,h,w]"
        cls_port = _pick(net, rank=3, name="class_queries_logits", detail=detail)
        mask_port = _pick(net, rank=4, name="masks_queries_logits", detail=detail)
        if cls_port.shape[2] not in (None, N_CLASSES + 1):
            raise net.signature_error(f"expected {N_CLASSES} ADE20K classes plus 'no object' in {cls_port}")
        out = net.run(pixel_values)
        class_logits, mask_logits = out[cls_port.name], out[mask_port.name]
        if (
            class_logits.ndim != 3
            or class_logits.shape[2] != N_CLASSES + 1
            or mask_logits.ndim != 4
            or mask_logits.shape[1] != class_logits.shape[1]
        ):
            raise net.signature_error(
                f"the outputs came back with shapes {list(class_logits.shape)} and {list(mask_logits.shape)}; {detail}"
            )
        probs = _softmax(class_logits[0].astype(np.float64), axis=-1)[:, :N_CLASSES]  # Q x C
        masks = 1.0 / (1.0 + np.exp(-mask_logits[0].astype(np.float64)))  # Q x h x w
        return np.einsum("qc,qhw->chw", probs, masks).astype(np.float32)


def _pick(net: OnnxNetwork, *, rank: int, name: str, detail: str) -> Port:
    """The output called ``name``, else the only output of ``rank``."""
    named = [p for p in net.outputs if p.name == name]
    if named:
        if named[0].rank != rank:
            raise net.signature_error(detail)
        return named[0]
    candidates = [p for p in net.outputs if p.rank == rank]
    if len(candidates) != 1:
        raise net.signature_error(detail)
    return candidates[0]


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Segmenter

    _OnnxSegmentation_is_a_segmentation: type[Segmenter] = OnnxSegmentation
