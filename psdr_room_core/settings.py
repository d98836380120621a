"""Kept for plugins written before the engine/method split: ``psdr_room_core.settings`` is now
:mod:`psdr_room_core.engine.settings` (import it from there in new code)."""

from psdr_room_core.engine.settings import *  # noqa: F403
