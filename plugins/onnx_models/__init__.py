"""Neural implementations run with onnxruntime: ``depth=onnx`` and ``segmentation=onnx`` (§4.1) and
``retrieval=clip_onnx`` (§4.3).

The weights are files a user downloads once (``psdr-room-models download NAME``; the registry is
``psdr_room_core/method/models.json``); which file, the models directory and onnxruntime's thread count come
from ``conf/depth/onnx.yaml`` and ``conf/segmentation/onnx.yaml``. Sessions are created on first use, and
the model file is part of the stage's cache key. Pre- and post-processing per model family are in
:mod:`.depth` and :mod:`.segmentation`; what they share (file lookup, session, input layout) in
:mod:`.network`.

There is no ``fov=onnx``: the paper's PerspectiveFields has no published ONNX export and its camera
parameters come from per-pixel fields through the project's own optimisation code, so there is no single
graph with a fixed signature to support; ``fov=vanishing_points`` stays the estimator.
"""

from __future__ import annotations

from dataclasses import dataclass

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting

from .clip import ClipRetrieval
from .depth import OnnxDepth
from .segmentation import OnnxSegmentation


@dataclass
class OnnxModelSettings:
    """Which network file and how onnxruntime runs it (shared by the three implementations)."""

    model: str = setting()
    path: str | None = setting()
    family: str | None = setting()
    models_dir: str = setting()
    intra_op_threads: int = setting(ge=0)
    providers: list[str] = setting()


@dataclass
class OnnxDepthSettings(OnnxModelSettings):
    input_size: int | None = setting(ge=32)
    disparity_eps: float = setting(ge=0, lt=1)


@dataclass
class OnnxSegmentationSettings(OnnxModelSettings):
    input_size: int | None = setting(ge=32)
    min_segment_fraction: float = setting(ge=0, lt=1)


@dataclass
class ClipSettings(OnnxModelSettings):
    database: str = setting()
    fraction: float = setting(gt=0, le=1)
    seed: int = setting()
    category_filter: bool = setting()
    batch: int = setting(ge=1)
    cache_dir: str = setting()


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("depth", "onnx", OnnxDepth, params=OnnxDepthSettings, reads_files=True)
    registry.add_implementation(
        "segmentation", "onnx", OnnxSegmentation, params=OnnxSegmentationSettings, reads_files=True
    )
    registry.add_implementation(
        "retrieval", "clip_onnx", ClipRetrieval, version="2", params=ClipSettings, reads_files=True
    )
