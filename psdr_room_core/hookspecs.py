"""Kept for plugins written before the engine/method split: ``psdr_room_core.hookspecs`` is now
:mod:`psdr_room_core.engine.hookspecs` (import it from there in new code)."""

from psdr_room_core.engine.hookspecs import *  # noqa: F403
