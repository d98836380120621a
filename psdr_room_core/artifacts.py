"""Kept for plugins written before the engine/method split: ``psdr_room_core.artifacts`` is now
:mod:`psdr_room_core.method.artifacts` (import it from there in new code)."""

from psdr_room_core.method.artifacts import *  # noqa: F403
