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

    model: str = setting(doc="A model of `psdr-room-models list` (of the implementation's kind).")
    path: str | None = setting(doc="Or an ONNX file of your own (then set family).")
    family: str | None = setting(
        doc="null: the model's; for a file of your own: depth_anything_v2 | dpt | midas (depth), segformer_ade20k | "
        "mask2former_ade20k (segmentation)."
    )
    models_dir: str = setting(doc="Where downloaded models live.")
    intra_op_threads: int = setting(ge=0, doc="onnxruntime threads (0: the run's run.threads).")
    providers: list[str] = setting(
        doc="onnxruntime execution providers tried in order where available (e.g. CUDAExecutionProvider first)."
    )


@dataclass
class OnnxDepthSettings(OnnxModelSettings):
    """``depth=onnx``: relative depth from an ONNX network, normalised to unit range (§4.1)."""

    input_size: int | None = setting(
        ge=32, doc="Network input: shorter side (square side for midas); null: the family's (518, 384, 256)."
    )
    disparity_eps: float = setting(
        ge=0,
        lt=1,
        doc="Disparity at most this × the largest is invalid (farther than 1/this × the nearest: sky, edge artefacts).",
    )


@dataclass
class OnnxSegmentationSettings(OnnxModelSettings):
    """``segmentation=onnx``: panoptic segmentation from an ONNX ADE20K network (SegFormer, Mask2Former) (§4.1)."""

    input_size: int | None = setting(
        ge=32, doc="Network input: square side (segformer) or shorter side; null: the family's (512)."
    )
    min_segment_fraction: float = setting(
        ge=0, lt=1, doc="Segments smaller than this fraction of the image are left unlabelled."
    )


@dataclass
class ClipSettings(OnnxModelSettings):
    """``retrieval=clip_onnx``: CLIP image-tower embeddings of the object crop against the database thumbnails,
    cosine kNN (§4.3)."""

    database: str = setting(doc="The object database (as retrieval=silhouette's).")
    fraction: float = setting(
        gt=0,
        le=1,
        doc="A random fraction of the database's models per category is used (the paper's Fig. 10 ablation).",
    )
    seed: int = setting(doc="Seed of that random fraction.")
    category_filter: bool = setting(
        doc="Only models of the segment label's categories (false: every model, as the paper ranks)."
    )
    batch: int = setting(ge=1, doc="Thumbnails embedded per network call.")
    cache_dir: str = setting(doc="Where the thumbnails' embeddings are cached.")


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("depth", "onnx", OnnxDepth, params=OnnxDepthSettings, reads_files=True)
    registry.add_implementation(
        "segmentation", "onnx", OnnxSegmentation, params=OnnxSegmentationSettings, reads_files=True
    )
    registry.add_implementation(
        "retrieval", "clip_onnx", ClipRetrieval, version="2", params=ClipSettings, reads_files=True
    )
