"""The settings of ``renderer=mitsuba`` (``conf/renderer/mitsuba.yaml``), importable without Mitsuba or torch."""

from __future__ import annotations

from dataclasses import dataclass

from psdr_room_core.engine.settings import setting
from psdr_room_core.libraries.llvm import VARIANTS

GUIDING = ("none", "grid", "octree")
"""How ``rgb_sppi`` samples find indirect silhouettes."""


@dataclass
class MitsubaSettings:
    variant: str = setting(choices=VARIANTS)
    spp: int = setting(ge=1)
    spp_boundary: int = setting(ge=1)
    rgb_spp: int = setting(ge=1)
    max_depth: int = setting(ge=1)
    rgb_sppi: int = setting(ge=0)
    rgb_guiding: str = setting(choices=GUIDING)
    rgb_geometry_gradients: bool = setting()
    seed: int = setting()
    threads: int = setting(ge=0)
    freeze: bool = setting()
    reproducible: bool = setting()
