"""Scratch entries left by a killed writer are swept; nothing else is."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from psdr_room_core.engine import debris

WRITER = """
import os, signal, sys
from pathlib import Path
from psdr_room_core.engine import debris
folder = debris.scratch_dir(Path(sys.argv[1]), "publishing")
(folder / "half.png").write_bytes(b"half")
fd, path = debris.scratch_file(Path(sys.argv[1]), "download", ".part")
os.write(fd, b"half")
os.kill(os.getpid(), signal.SIGKILL)
"""


def killed_writer(folder: Path) -> None:
    """A real process that makes a scratch folder and a scratch file in ``folder``, then is killed."""
    result = subprocess.run([sys.executable, "-c", WRITER, str(folder)], capture_output=True)
    assert result.returncode == -signal.SIGKILL


def test_a_killed_writers_entries_are_swept_by_kind(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    killed_writer(tmp_path)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert [n.split("-")[0] for n in left] == [".download", ".publishing"]
    with caplog.at_level(logging.WARNING, logger="psdr_room"):
        removed = debris.sweep(tmp_path, "publishing")
    assert [p.name for p in removed] == [left[1]]
    assert sorted(p.name for p in tmp_path.iterdir()) == [left[0]]  # another kind waits for its own sweep
    assert len(caplog.records) == 1 and str(tmp_path) in caplog.records[0].getMessage()
    assert [p.name for p in debris.sweep(tmp_path, "download")] == [left[0]]
    assert not list(tmp_path.iterdir())


def test_live_foreign_and_remote_entries_stay(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        host = debris.scratch_dir(tmp_path, "publishing").name.split("@")[1].rsplit("-", 1)[0]
        stays = [
            tmp_path / f".publishing-{live.pid}@{host}-abc",  # a writer still running
            tmp_path / f".publishing-{live.pid}@{host}x-abc",  # another host's writer (a shared cache)
            tmp_path / ".publishing-notes",  # the user's own folder
            tmp_path / "publishing-1@host-abc",  # not a scratch name
        ]
        for path in stays:
            path.mkdir()
        own = debris.scratch_dir(tmp_path, "publishing")  # this process's own, in use
        with caplog.at_level(logging.WARNING, logger="psdr_room"):
            assert debris.sweep(tmp_path, "publishing") == []
        assert all(p.is_dir() for p in [*stays, own]) and not caplog.records
    finally:
        live.kill()
        live.wait()
    assert debris.sweep(tmp_path, "publishing") == [stays[0]]  # its writer has ended now


def test_scratch_names_carry_kind_pid_and_host(tmp_path: Path) -> None:
    fd, path = debris.scratch_file(tmp_path / "new", "download", ".part")
    os.close(fd)
    assert path.parent == tmp_path / "new" and path.suffix == ".part"
    assert path.name.startswith(f".download-{os.getpid()}@")
    assert not debris.abandoned(path, "download")  # its writer (this process) runs
