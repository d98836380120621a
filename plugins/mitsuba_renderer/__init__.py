"""``renderer=mitsuba``: Mitsuba 3 + Dr.Jit differentiable rendering of masks, depth and RGB (paper §3.1).

Importing this package is cheap: Mitsuba and Dr.Jit are imported when a renderer is first used. It does
point ``DRJIT_LIBLLVM_PATH`` at a libLLVM >= 16 right away (when one exists and the variable is unset), so
that any later ``import drjit`` in the process, by this plugin or another, gets a working LLVM backend.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.plugins import Registry
from psdr_room_core.engine.settings import setting

from .llvm import VARIANTS, ensure_llvm
from .session import GUIDING, MitsubaGeometryRenderer, MitsubaRenderer

__all__ = ["MitsubaRenderer", "MitsubaGeometryRenderer"]

with contextlib.suppress(PsdrRoomError):  # reported when the renderer is used, not when plugins load
    ensure_llvm()


@dataclass
class MitsubaSettings:
    variant: str = setting(choices=VARIANTS)
    spp: int = setting(ge=1)
    spp_boundary: int = setting(ge=0)
    rgb_spp: int = setting(ge=1)
    max_depth: int = setting(ge=1)
    rgb_sppi: int = setting(ge=0)
    rgb_guiding: str = setting(choices=GUIDING)
    rgb_geometry_gradients: bool = setting()
    seed: int = setting()
    threads: int = setting(ge=0)
    freeze: bool = setting()
    reproducible: bool = setting()


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("renderer", "mitsuba", MitsubaRenderer, params=MitsubaSettings)
