"""Files and folders that appear whole or not at all: written under a scratch name beside their target
(:mod:`.debris`) and renamed into place."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from .debris import scratch_dir, scratch_file
from .errors import PsdrRoomError

WRITING = "writing"
"""The scratch kind of :func:`write_whole`'s files."""

_UMASK = os.umask(0)
os.umask(_UMASK)  # read once, at import (os.umask can only be read by setting it)


def write_whole(path: Path, data: str | bytes) -> None:
    """Write ``data`` (text as UTF-8) to ``path`` through a scratch file of kind :data:`WRITING` beside it, renamed
    into place: a reader sees the old file or the new one, never part of either, and a failed write leaves no
    scratch file. Creates the parent folder; the file gets the permissions a plain ``open`` would give it (the
    umask's)."""
    fd, tmp = scratch_file(path.parent, WRITING, suffix=f".{path.name}.tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            os.fchmod(handle.fileno(), 0o666 & ~_UMASK)  # mkstemp makes it owner-only
            handle.write(data.encode("utf-8") if isinstance(data, str) else data)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def move_into_place(new: Path, target: Path, kind: str) -> None:
    """Rename the file or folder ``new`` to ``target``, with the permissions a plain ``open`` or ``mkdir`` would
    give it (a scratch folder is owner-only). A folder already at ``target`` is first renamed into a scratch folder
    of ``kind`` beside it and removed once ``new`` is in place (put back if the rename fails): ``target`` is never
    a mix of both, and a process killed in between leaves only scratch, which the next sweep removes."""
    os.chmod(new, (0o777 if new.is_dir() else 0o666) & ~_UMASK)
    if not target.is_dir():
        os.replace(new, target)
        return
    aside = scratch_dir(target.parent, kind)
    try:
        os.replace(target, aside / target.name)
        try:
            os.replace(new, target)
        except BaseException:
            os.replace(aside / target.name, target)
            raise
    finally:
        shutil.rmtree(aside, ignore_errors=True)


def check_creatable(path: Path, what: str) -> None:
    """Refuse, in one line naming ``what``, a ``path`` that cannot be created because a file stands where one of
    the folders above it would be."""
    existing = next(p for p in path.absolute().parents if p.exists() or p.is_symlink())
    if not existing.is_dir():
        raise PsdrRoomError(f"{what} {path}: {existing} is a file, not a folder; choose another path")
