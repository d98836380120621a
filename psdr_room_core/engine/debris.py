"""Scratch files and folders that a killed process leaves behind, and their sweeping.

Whatever psdr-room writes whole (a run's published artifacts, an edited scene, a downloaded network) is first
written under a scratch name beside its target and renamed into place. A scratch name carries its kind, the
writer's process id and host: ``.<kind>-<pid>@<host>-<random><suffix>``. A process killed before the rename
leaves that entry behind; the next command that writes there calls :func:`sweep`, which removes the entries of
that kind whose writer is dead: written on this host by a process id that no longer runs. Nothing else is
touched: another name, a live writer, or a writer on another host (a cache shared over the network) stays.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import shutil
import socket
import tempfile
from pathlib import Path

_LOG = logging.getLogger("psdr_room")
_HOST = re.sub(r"[^A-Za-z0-9_.]", "_", socket.gethostname()) or "host"
_NAME = re.compile(r"\.(?P<kind>[a-z_]+)-(?P<pid>\d+)@(?P<host>[A-Za-z0-9_.]+)-")


def _prefix(kind: str) -> str:
    return f".{kind}-{os.getpid()}@{_HOST}-"


def scratch_dir(parent: Path, kind: str) -> Path:
    """A new empty scratch folder of ``kind`` in ``parent`` (created), to be renamed into place when complete."""
    parent.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=_prefix(kind), dir=parent))


def scratch_file(parent: Path, kind: str, suffix: str = "") -> tuple[int, Path]:
    """A new scratch file of ``kind`` in ``parent``: its open descriptor and its path."""
    parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=_prefix(kind), suffix=suffix, dir=parent)
    return fd, Path(name)


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this host (another user's included)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's live process
    return True


def abandoned(path: Path, kind: str) -> bool:
    """Whether ``path`` is a scratch entry of ``kind`` whose writer, on this host, no longer runs."""
    match = _NAME.match(path.name)
    return bool(
        match
        and match["kind"] == kind
        and match["host"] == _HOST
        and int(match["pid"]) != os.getpid()
        and not pid_alive(int(match["pid"]))
    )


def sweep(parent: Path, kind: str) -> list[Path]:
    """Remove the abandoned scratch entries of ``kind`` in ``parent`` (see the module docstring); say so in one
    log line naming the folder. Returns what was removed (an entry that cannot be removed stays, unsaid)."""
    if not parent.is_dir():
        return []
    removed = []
    for path in sorted(parent.glob(f".{kind}-*")):
        if not abandoned(path, kind):
            continue
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                path.unlink(missing_ok=True)
        if not path.exists() and not path.is_symlink():
            removed.append(path)  # a read-only folder keeps what it cannot give up
    if removed:
        _LOG.warning(
            "removed %d unfinished %s %s left in %s by a process that was stopped",
            len(removed),
            kind,
            "entry" if len(removed) == 1 else "entries",
            parent,
        )
    return removed
