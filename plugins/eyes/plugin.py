"""Registers the eyes implementations (entry point ``eyes``)."""

from __future__ import annotations

from dataclasses import dataclass

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting


@dataclass
class EyesSettings:
    """Which network file, onnxruntime's threads, and how instances are read from its outputs."""

    path: str | None = setting()
    intra_op_threads: int = setting(ge=0)
    center_threshold: float = setting(gt=0, lt=1)
    min_instance_fraction: float = setting(ge=0, lt=1)


DESCRIPTIONS = {
    "segmentation": "walls, floor, ceiling, windows, doors and furniture instances from psdr-room's own network "
    "(trained on its renders)",
    "depth": "relative depth from psdr-room's own network (trained on its renders)",
    "detector": "furniture boxes from psdr-room's own network (trained on its renders)",
}


@hookimpl
def register_implementations(registry: Registry) -> None:
    """By reference: onnxruntime and cv2 load when one is constructed."""
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
