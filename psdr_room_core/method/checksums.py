"""Networks checked against the sha256 recorded for them before they run.

Where a checksum is recorded:

- a file of the models directory named by a registry entry: the entry's ``sha256`` (or published prefix) and
  ``size`` (:func:`check_installed`, through :func:`.models.check_file`);
- any other network: the ``sha256`` of the JSON note beside it, named as the network with ``.json``
  (:func:`check_beside`): ``eyes.json`` beside the shipped ``eyes.onnx`` and beside every network psdr-room-train
  exports, ``nanodet.json`` beside the bundled ``nanodet.onnx``. A network with no note is used as it is.

Digests are remembered by (size, mtime_ns) (:func:`.models.cached_sha256`: in the models directory for its files,
else in psdr-room's cache directory, and in the process), so a check costs a ``stat`` once a file was hashed.

A network that differs from its record is a :class:`Mismatch`: one line naming the file, the record and the fix.
What follows is the same for every capability that reads a network (segmentation, depth, detector, retrieval):

- ``<capability>=auto`` asks each choice's ``unavailable(photo)``; there a damaged network is unusable, as a
  missing one is, so auto takes the next choice of its ``order``, and :func:`passed_over` logs a warning line
  naming the file and why;
- an implementation chosen by name (``detector=eyes``) stops the run with the one line before the network runs.

Either way the run never gives a silently different result.
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Callable
from pathlib import Path

from psdr_room_core.engine.bounded import excerpt
from psdr_room_core.engine.errors import PsdrRoomError

from . import models

log = logging.getLogger("psdr_room")

_HEX64 = re.compile(r"^[0-9a-f]{64}$")
_WARNED: set[str] = set()
"""Reasons already logged by :func:`passed_over` in this process (every stage asks ``auto`` again)."""


class Mismatch(PsdrRoomError):
    """A network that is not the file recorded for it, or whose record cannot be read."""


def note_sha256(network: Path) -> tuple[Path, str] | None:
    """(note, sha256) recorded in the JSON note beside ``network`` (``<stem>.json``), or None where there is no
    note or it records no ``sha256``."""
    note = network.with_suffix(".json")
    if not note.is_file():
        return None
    try:
        data = json.loads(note.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise Mismatch(
            f"{note}: cannot read the note recording the sha256 of {network.name} "
            f"({excerpt(str(exc))}); restore it, or remove it to use {network.name} unchecked"
        ) from None
    sha256 = data.get("sha256") if isinstance(data, dict) else None
    if sha256 is None:
        return None
    if not isinstance(sha256, str) or not _HEX64.match(sha256):
        raise Mismatch(
            f"{note}: sha256 must be 64 lower-case hex digits, got {excerpt(repr(sha256))}; restore the note, "
            f"or remove it to use {network.name} unchecked"
        )
    return note, sha256


def check_beside(network: Path, fix: str) -> str:
    """The sha256 of ``network``; a :class:`Mismatch` naming it, its note and ``fix`` where the note records
    another."""
    recorded = note_sha256(network)
    digest = models.cached_sha256(network)
    if recorded is not None and digest != recorded[1]:
        note, sha256 = recorded
        raise Mismatch(
            f"{network}: sha256 {digest[:12]}… does not match the {sha256[:12]}… recorded in {note.name}; {fix}"
        )
    return digest


def check_installed(entry: models.ModelEntry, models_dir: Path) -> None:
    """A :class:`Mismatch` where the installed file of ``entry`` differs from its registry entry's size or
    checksum (a missing file is left to :func:`.models.require`)."""
    status = models.check_file(entry, Path(models_dir))
    if status.state == "corrupt":
        raise Mismatch(
            f"{status.path}: {status.detail} ({Path(entry.registry).name or 'the registry'}, model "
            f"'{entry.name}'); run `psdr-room-models download {entry.name} --force`"
        )


def passed_over(mismatch: Mismatch) -> str:
    """The reason ``auto`` passes over a damaged network, logged as a warning line once per process."""
    reason = str(mismatch)
    if reason not in _WARNED:
        _WARNED.add(reason)
        log.warning("psdr-room: warning: %s (auto takes its next choice)", reason)
    return reason


def damage(check: Callable[[], object]) -> str | None:
    """Why ``auto`` passes over a network: the :class:`Mismatch` that ``check()`` raises (logged by
    :func:`passed_over`), or None when it raises none."""
    try:
        check()
    except Mismatch as mismatch:
        return passed_over(mismatch)
    return None
