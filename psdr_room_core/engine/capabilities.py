"""Protocols the engine itself consults on an implementation, whatever its capability.

Capabilities (the swappable parts of a method: ``fov``, ``renderer``, ...) and their protocols belong to the
method that registers them (``register_capabilities``); the engine only selects, constructs and asks these.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol, runtime_checkable


@runtime_checkable
class ExternalFiles(Protocol):
    """Optional: files an implementation reads for a given photo, hashed into the stage's cache key."""

    def external_files(self, photo: Path) -> list[Path]: ...


@runtime_checkable
class Availability(Protocol):
    """Optional: whether an implementation can run for a photo, consulted by ``<capability>=auto``.

    ``auto`` tries the implementations in its ``order`` and selects the first whose ``unavailable`` returns
    None; the reasons the others gave are logged and recorded in the run.
    """

    def unavailable(self, photo: Path) -> str | None:
        """None when usable for ``photo``, else a short reason (``weights not installed: <path>``)."""
        ...
