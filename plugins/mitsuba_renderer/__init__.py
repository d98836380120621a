"""``renderer=mitsuba``: Mitsuba 3 + Dr.Jit differentiable rendering of masks, depth and RGB (paper §3.1).

Importing this package is cheap: the renderer (:mod:`.session`) is registered by reference, and Mitsuba and
Dr.Jit are imported when a renderer is first used. It does
point ``DRJIT_LIBLLVM_PATH`` at a libLLVM >= 16 right away (when one exists and the variable is unset), so
that any later ``import drjit`` in the process, by this plugin or another, gets a working LLVM backend.
"""

from __future__ import annotations

import contextlib

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.libraries.llvm import ensure_llvm

from .settings import MitsubaSettings

with contextlib.suppress(PsdrRoomError):  # reported when the renderer is used, not when plugins load
    ensure_llvm()


@hookimpl
def register_implementations(registry: Registry) -> None:
    """By reference: the session (torch; Mitsuba when it first renders) loads when a renderer is constructed."""
    registry.add_implementation(
        "renderer",
        "mitsuba",
        "psdr_room_plugins.mitsuba_renderer.session:MitsubaRenderer",
        params=MitsubaSettings,
        reads_files=False,
    )
