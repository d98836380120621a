"""Registers the eyes implementations (entry point ``eyes``)."""

from __future__ import annotations

from dataclasses import dataclass

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting

from ..detectors import NanodetSettings
from ..layout.settings import LayoutDepthSettings, LayoutSegmentationSettings
from ..retrieval_silhouette import SilhouetteSettings


@dataclass
class EyesSettings:
    """Which network file, onnxruntime's threads, and how instances are read from its outputs."""

    path: str | None = setting(doc="null: the shipped eyes.onnx; or a network of your own from psdr-room-train.")
    intra_op_threads: int = setting(ge=0, doc="onnxruntime threads (0: the run's run.threads).")
    center_threshold: float = setting(gt=0, lt=1, doc="An object centre is a heatmap peak at least this high.")
    min_instance_fraction: float = setting(
        ge=0, lt=1, doc="Objects and window/door regions smaller than this fraction of the photo are dropped."
    )


@dataclass
class NanodetAndEyesSettings:
    """``detector=nanodet_eyes``: each member's own settings (the config takes them from its node), and the box
    IoU from which an eyes box and a NanoDet box are one thing."""

    nanodet: NanodetSettings = setting(
        doc="NanoDet's settings: detector.nanodet_onnx's node (set detector.nanodet_onnx.X, not this)."
    )
    eyes: EyesSettings = setting(doc="The eyes network's settings: detector.eyes's node (set detector.eyes.X).")
    same_iou: float = setting(
        ge=0,
        le=1,
        doc="An eyes box this close (IoU) to a NanoDet box is the same thing: NanoDet's label stands where its "
        "classes name it.",
    )


@dataclass
class LayoutAndEyesSettings:
    """``segmentation=layout_eyes``: each member's own settings (the config takes them from its node)."""

    layout: LayoutSegmentationSettings = setting(
        doc="The layout's settings: segmentation.layout's node (set segmentation.layout.X, not this); its "
        "label_weight weighs the network's walls, floor and ceiling."
    )
    eyes: EyesSettings = setting(doc="The network's settings: segmentation.eyes's node (set segmentation.eyes.X).")


@dataclass
class LayoutDepthAndEyesSettings:
    """``depth=layout_eyes``: each member's own settings (the config takes them from its node)."""

    layout: LayoutDepthSettings = setting(
        doc="The layout's settings: depth.layout's node (set depth.layout.X, not this); its relative_extent and "
        "relative_min_width say where the network's relative depth shapes an object."
    )
    eyes: EyesSettings = setting(doc="The network's settings: depth.eyes's node (set depth.eyes.X).")
    camera_heights: list[float] = setting(
        length=2,
        gt=0,
        doc="[lowest, highest] camera height (metres) the segmentation's 3D boxes may set: the layout's depth is "
        "scaled so that the objects' depths match the boxes' (their median ratio), within these; a photo with no "
        "boxes keeps depth.layout.camera_height_m. Equal values: that height, whatever the boxes.",
    )


@dataclass
class EyesRetrievalSettings:
    """``retrieval=eyes``: the network, the silhouette search that breaks ties (its node), and how the scores
    combine."""

    network: EyesSettings = setting(doc="The eyes network: a network of your own needs its eyes_models.npz beside it.")
    silhouette: SilhouetteSettings = setting(
        doc="The view search that poses the shortlist: retrieval.silhouette's node (set retrieval.silhouette.X)."
    )
    shortlist: int = setting(ge=1, doc="The models the appearance score ranks best that the view search poses.")
    category_weight: float = setting(
        ge=0, doc="Weight of the network's probability of a model's category beside the embedding's cosine."
    )
    silhouette_weight: float = setting(
        ge=0, doc="Weight of the posed silhouette's score (0..1) added to the appearance score."
    )


DESCRIPTIONS = {
    "segmentation": "walls, floor, ceiling, windows, doors and furniture instances from psdr-room's own network "
    "(trained on its renders)",
    "depth": "relative depth from psdr-room's own network (trained on its renders)",
    "detector": "furniture boxes from psdr-room's own network (trained on its renders)",
}


@hookimpl
def register_implementations(registry: Registry) -> None:
    """By reference: the eyes modules load when one is constructed (the settings need the detectors plugin,
    loaded beside this one anyway)."""
    for capability, kind in (
        ("segmentation", "EyesSegmentation"),
        ("depth", "EyesDepth"),
        ("detector", "EyesDetector"),
    ):
        registry.add_implementation(
            capability,
            "eyes",
            f"psdr_room_plugins.eyes.perception:{kind}",
            params=EyesSettings,
            reads_files=True,
            description=DESCRIPTIONS[capability],
        )
    registry.add_implementation(
        "retrieval",
        "eyes",
        "psdr_room_plugins.eyes.retrieval:EyesRetrieval",
        params=EyesRetrievalSettings,
        reads_files=True,
        description="catalogue models ranked by psdr-room's own network's embedding and category vote, posed "
        "silhouettes breaking ties",
    )
    registry.add_implementation(
        "detector",
        "nanodet_eyes",
        "psdr_room_plugins.eyes.with_nanodet:NanodetAndEyes",
        params=NanodetAndEyesSettings,
        reads_files=True,
        description="the bundled NanoDet's COCO boxes and psdr-room's own network's furniture boxes together",
    )
    registry.add_implementation(
        "segmentation",
        "layout_eyes",
        "psdr_room_plugins.eyes.with_layout:LayoutWithEyesSurfaces",
        params=LayoutAndEyesSettings,
        reads_files=True,
        description="segmentation=layout with its box room fitted to psdr-room's own network's walls, floor and "
        "ceiling too",
    )
    registry.add_implementation(
        "depth",
        "layout_eyes",
        "psdr_room_plugins.eyes.with_layout:LayoutDepthWithEyes",
        params=LayoutDepthAndEyesSettings,
        reads_files=True,
        description="depth=layout whose objects with no floor contact take psdr-room's own network's depth, scaled "
        "to the layout's",
    )
