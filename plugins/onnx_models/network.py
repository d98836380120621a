"""What every ONNX implementation shares: finding the model file, the onnxruntime session, input layout.

A model is named by its registry entry (``model``: see ``psdr-room-models list``) or given as a file
(``path`` + ``family``). The session is created on first use with ``intra_op_threads`` threads; a missing,
damaged or wrongly shaped file gives one line naming the file and the fix. A file with a recorded sha256 (a
registry entry's installed file, or a network with a JSON note beside it: :mod:`psdr_room_core.method.checksums`)
is checked against it before it runs: a file onnxruntime cannot load is reported as such, one that loads but
differs from its record stops the run, and ``auto`` passes over it (:func:`unusable_reason`) with a warning line.

Input layout per family (:data:`INPUTS`): the photo (sRGB in [0, 1]) is resized either keeping its aspect
ratio with the shorter side at ``size`` and both sides rounded to a multiple of ``multiple`` (the ViT
families need multiples of their patch size, 14 for DINOv2), or to a ``size``x``size`` square; a model
whose ONNX input has fixed height and width is always fed exactly that size. Then it is normalised with
the family's mean and standard deviation and laid out NCHW float32.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from psdr_room_core.engine import threads as run_threads
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method import checksums, models

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


@dataclass(frozen=True)
class InputSpec:
    """How a family's network wants its image."""

    size: int
    keep_aspect: bool
    multiple: int
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    interpolation: int


INPUTS: dict[str, InputSpec] = {
    # Depth-Anything-V2 (DPTImageProcessor: keep_aspect_ratio, ensure_multiple_of 14, 518, bicubic).
    "depth_anything_v2": InputSpec(518, True, 14, IMAGENET_MEAN, IMAGENET_STD, cv2.INTER_CUBIC),
    # DPT-Hybrid/Large (MiDaS v3): 384, multiples of 32, mean = std = 0.5.
    "dpt": InputSpec(384, True, 32, (0.5, 0.5, 0.5), (0.5, 0.5, 0.5), cv2.INTER_CUBIC),
    # MiDaS v2.1 (small: 256, large: 384, square), ImageNet statistics.
    "midas": InputSpec(256, False, 32, IMAGENET_MEAN, IMAGENET_STD, cv2.INTER_CUBIC),
    # SegFormer ADE20K (SegformerImageProcessor: 512x512, bilinear).
    "segformer_ade20k": InputSpec(512, False, 32, IMAGENET_MEAN, IMAGENET_STD, cv2.INTER_LINEAR),
    # MaskFormer / Mask2Former ADE20K: shorter side 512, multiples of 32 (fixed-size exports: their size).
    "mask2former_ade20k": InputSpec(512, True, 32, IMAGENET_MEAN, IMAGENET_STD, cv2.INTER_LINEAR),
}


def network_size(
    height: int, width: int, spec: InputSpec, size: int | None = None, fixed: tuple[int, int] | None = None
) -> tuple[int, int]:
    """(height, width) of the network input for a ``height`` x ``width`` image."""
    if fixed is not None:
        return fixed
    size = int(size or spec.size)
    m = spec.multiple
    if not spec.keep_aspect:
        side = max(m, int(round(size / m)) * m)
        return side, side
    scale = size / min(height, width)
    return (max(m, int(round(height * scale / m)) * m), max(m, int(round(width * scale / m)) * m))


def to_network(rgb: np.ndarray, spec: InputSpec, hw: tuple[int, int]) -> np.ndarray:
    """The NCHW float32 network input for an HxWx3 sRGB image in [0, 1]."""
    height, width = hw
    downscale = height <= rgb.shape[0] and width <= rgb.shape[1]
    resized = cv2.resize(
        np.ascontiguousarray(rgb, dtype=np.float32),
        (width, height),
        interpolation=cv2.INTER_AREA if downscale else spec.interpolation,
    )
    resized = np.clip(resized, 0.0, 1.0)  # bicubic overshoot
    normalised = (resized - np.asarray(spec.mean, np.float32)) / np.asarray(spec.std, np.float32)
    return np.ascontiguousarray(normalised.transpose(2, 0, 1)[None], dtype=np.float32)


def resize_channels(array: np.ndarray, hw: tuple[int, int], interpolation: int = cv2.INTER_LINEAR) -> np.ndarray:
    """Resize a CxHxW float array to Cx``hw`` (OpenCV takes a limited number of channels per call)."""
    height, width = hw
    out = np.empty((array.shape[0], height, width), np.float32)
    for start in range(0, array.shape[0], 32):
        chunk = np.ascontiguousarray(array[start : start + 32].transpose(1, 2, 0), dtype=np.float32)
        resized = cv2.resize(chunk, (width, height), interpolation=interpolation)
        out[start : start + 32] = resized.reshape(height, width, -1).transpose(2, 0, 1)
    return out


# ------------------------------------------------------------------------------------- the model file
@dataclass(frozen=True)
class ModelFile:
    """The resolved model: its file, family, and what to tell a user whose file is missing or bad."""

    path: Path
    family: str
    name: str
    fix: str
    entry: models.ModelEntry | None = None
    """The registry entry whose installed file ``path`` is, checked against its size and sha256."""
    noted: bool = False
    """Whether ``path`` is checked against the sha256 of the JSON note beside it, where there is one."""

    def check(self) -> None:
        """A :class:`~psdr_room_core.method.checksums.Mismatch` where the file differs from its record."""
        if self.entry is not None:
            checksums.check_installed(self.entry, self.path.parent)
        elif self.noted:
            checksums.check_beside(self.path, self.fix)


def resolve_model(
    capability: str,
    families: Sequence[str],
    *,
    model: str | None,
    path: str | None,
    family: str | None,
    models_dir: str | None,
) -> ModelFile:
    """Find the file and family from the implementation's parameters (see the module docstring)."""
    key = f"{capability}.onnx"
    entry = None
    if model:
        entry = models.lookup(str(model), models.load_registry(), capability)
    if path:
        file = Path(path).expanduser()
        name = entry.name if entry else file.stem
        fix = f"check {key}.path"
    elif entry is not None:
        file = entry.path(models.resolve_models_dir(models_dir))
        name = entry.name
        fix = (
            f"run `psdr-room-models download {entry.name}`"
            if entry.url
            else f"export it as `psdr-room-models info {entry.name}` explains"
        )
    else:
        raise PsdrRoomError(
            f"{key}: no model selected; set {key}.model=NAME (psdr-room-models list) "
            f"or {key}.path=FILE with {key}.family"
        )
    chosen = family or (entry.family if entry else None)
    if chosen is None:
        raise PsdrRoomError(
            f"{key}.path={file}: the model family is unknown; set {key}.family to one of {', '.join(families)}"
        )
    if chosen not in families:
        raise PsdrRoomError(
            f"{key}: family '{chosen}' is not a {capability} family this implementation "
            f"reads; use one of {', '.join(families)}"
        )
    return ModelFile(path=file, family=chosen, name=name, fix=fix, entry=None if path else entry)


def unusable_reason(model: ModelFile) -> str | None:
    """Why ``auto`` passes over ``model``: its file is absent, or differs from its record (a warning line says
    so); None when it is there and whole."""
    if not model.path.is_file():
        return f"weights not installed ({model.path}); {model.fix}"
    return checksums.damage(model.check)


# ----------------------------------------------------------------------------------------- session
@dataclass(frozen=True)
class Port:
    """One input or output of the ONNX graph: name, element type, shape (ints, or None when symbolic)."""

    name: str
    type: str
    shape: tuple[int | None, ...]

    @property
    def rank(self) -> int:
        return len(self.shape)

    def __str__(self) -> str:
        dims = ",".join("?" if d is None else str(d) for d in self.shape)
        return f"{self.name}[{dims}]"


def _port(arg: Any) -> Port:
    shape = tuple(d if isinstance(d, int) and d > 0 else None for d in (arg.shape or ()))
    return Port(arg.name, str(arg.type), shape)


class OnnxNetwork:
    """An onnxruntime session created on first use, with one-line errors naming the file."""

    def __init__(self, model: ModelFile, threads: int = 0, providers: Sequence[str] = ("CPUExecutionProvider",)):
        self.model = model
        self.threads = int(threads)
        self.providers = tuple(providers or ("CPUExecutionProvider",))

    def error(self, problem: str) -> PsdrRoomError:
        return PsdrRoomError(f"{self.model.path}: {problem}")

    def signature_error(self, detail: str) -> PsdrRoomError:
        return self.error(
            f"the ONNX signature does not fit the '{self.model.family}' family ({detail}; the model has inputs "
            f"{', '.join(map(str, self.inputs))} and outputs {', '.join(map(str, self.outputs))}); "
            f"choose the family that matches this file, or {self.model.fix}"
        )

    @functools.cached_property
    def session(self) -> Any:
        try:
            import onnxruntime as ort
        except ImportError as exc:  # pragma: no cover - a declared dependency
            raise PsdrRoomError(f"onnxruntime is not importable ({exc}); pip install onnxruntime") from None
        path = self.model.path
        if not path.is_file():
            raise self.error(
                f"model file of '{self.model.name}' not found; {self.model.fix}, "
                "or set models_dir to the directory that holds it"
            )
        options = ort.SessionOptions()
        options.intra_op_num_threads = self.threads or run_threads.count()
        options.inter_op_num_threads = 1
        options.log_severity_level = 3
        available = set(ort.get_available_providers())
        providers = [p for p in self.providers if p in available] or ["CPUExecutionProvider"]
        try:
            session = ort.InferenceSession(str(path), sess_options=options, providers=providers)
        except Exception as exc:  # onnxruntime raises its own types (InvalidProtobuf, Fail, ...)
            reason = " ".join(str(exc).split())
            reason = reason.split(" : ")[-1].replace(f"Load model from {path} failed:", "").strip()[:200]
            reason = reason or type(exc).__name__
            raise self.error(
                f"not a loadable ONNX model ({reason}); the file is damaged, incomplete or not ONNX: {self.model.fix}"
            ) from None
        self.model.check()
        return session

    @functools.cached_property
    def inputs(self) -> list[Port]:
        return [_port(a) for a in self.session.get_inputs()]

    @functools.cached_property
    def outputs(self) -> list[Port]:
        return [_port(a) for a in self.session.get_outputs()]

    def image_input(self) -> Port:
        """The single float NCHW image input (others may only be ``pixel_mask``)."""
        images = [p for p in self.inputs if p.rank == 4 and "float" in p.type]
        others = [p for p in self.inputs if p not in images and p.name != "pixel_mask"]
        if len(images) != 1 or others:
            raise self.signature_error("expected one float image input [N,3,H,W] (plus an optional pixel_mask)")
        port = images[0]
        if port.shape[1] not in (None, 3):
            raise self.signature_error(f"the image input {port} must have 3 channels")
        return port

    def fixed_size(self) -> tuple[int, int] | None:
        """(height, width) when the graph's image input has a fixed size."""
        shape = self.image_input().shape
        return (shape[2], shape[3]) if shape[2] and shape[3] else None

    def run(self, pixel_values: np.ndarray) -> dict[str, np.ndarray]:
        """Run the graph on an NCHW image; every output by name."""
        image = self.image_input()
        if image.type == "tensor(float16)":  # half-precision exports (model_fp16.onnx) take half input
            pixel_values = pixel_values.astype(np.float16)
        feeds: dict[str, np.ndarray] = {image.name: pixel_values}
        for port in self.inputs:
            if port.name == "pixel_mask":
                feeds[port.name] = np.ones((pixel_values.shape[0], *pixel_values.shape[2:]), np.int64)
        try:
            values = self.session.run(None, feeds)
        except Exception as exc:
            reason = " ".join(str(exc).split())[:300]
            raise self.error(
                f"inference failed on a {pixel_values.shape[3]}x{pixel_values.shape[2]} input "
                f"({reason}); check the family and input_size fit this model, "
                f"or {self.model.fix}"
            ) from None
        return {port.name: np.asarray(value) for port, value in zip(self.outputs, values)}
