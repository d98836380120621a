"""Kept for plugins written before the engine/method split: ``psdr_room_core.errors`` is now
:mod:`psdr_room_core.engine.errors` (import it from there in new code)."""

from psdr_room_core.engine.errors import *  # noqa: F403
