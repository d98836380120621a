"""What psdr-room may overwrite, and which names from files may become paths.

Every folder the tools write whole (a run directory, an edited scene) carries a :data:`MARKER` file. A folder
is replaced or written into only when it is ours (it has the marker), empty, or absent: a user's folder given
by mistake as ``--out`` or ``hydra.run.dir`` is refused in one line, never emptied. Names read from files that
become file names (the parts, lights and fixtures of a scene's ``appearance.json``) must be plain names, so a
scene folder from elsewhere cannot reach outside itself.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from .bounded import excerpt
from .errors import PsdrRoomError

MARKER = ".psdr-room"
"""The file that marks a folder as written by psdr-room."""

PLAIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def claim(folder: Path) -> None:
    """Mark ``folder`` (which must exist) as written by psdr-room."""
    (folder / MARKER).write_text("written by psdr-room; it may replace this folder's contents\n")


def is_ours(folder: Path) -> bool:
    """Whether ``folder`` carries the marker."""
    return (folder / MARKER).is_file()


def check_replaceable(path: Path, what: str) -> None:
    """Refuse, in one line naming ``what``, to replace ``path`` unless it is absent, an empty folder or ours."""
    if not path.exists() and not path.is_symlink():
        return
    if not path.is_dir() or path.is_symlink():
        raise PsdrRoomError(f"{what} {path}: exists and is not a folder; choose a new folder")
    if any(path.iterdir()) and not is_ours(path):
        raise PsdrRoomError(
            f"{what} {path}: a folder psdr-room did not write (no {MARKER} file in it); "
            "choose a new or empty folder, its files are left as they are"
        )


def check_writable_into(folder: Path, entries: Iterable[str], what: str) -> None:
    """Refuse to replace any of ``entries`` inside ``folder`` unless the folder is ours (or none exists yet)."""
    present = [name for name in entries if (folder / name).exists() or (folder / name).is_symlink()]
    if present and not is_ours(folder):
        raise PsdrRoomError(
            f"{what} {folder}: holds {', '.join(present)} that psdr-room did not write (no {MARKER} "
            "file); choose a new folder, its files are left as they are"
        )


def plain_name(name: object, source: Path, field: str) -> str:
    """``name`` when it is a plain file name (letters, digits, ``_``, ``.``, ``-``; not starting with ``.``),
    else a one-line error naming ``source`` and ``field``."""
    if not isinstance(name, str) or not PLAIN_NAME.fullmatch(name):
        raise PsdrRoomError(
            f"{source}: {field} {excerpt(repr(name))} is not a plain name (letters, digits, '_', '.', '-'); re-export the scene"
        )
    return name
