"""What the bad-input corpus cannot show with one failing command: paths as people name them run, permission
problems (simulated where the tests run as root, who may read and write anything) are one-line bad input,
a read-only cache still gives a result, and the same inputs give the same digests (a cache key follows the
code that computes it: tests/test_fingerprint.py)."""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import EXAMPLE
from psdr_room_core.engine.cache import Store
from psdr_room_core.engine.cli import compose_config, preflight
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.engine.run import execute


@pytest.mark.parametrize("name", ["café.jpg", "my,room.jpg", "room (1).jpg", "it's #2.jpg"])
def test_photo_names_as_people_write_them_run(name: str, tmp_path: Path, cli_env: dict[str, str]) -> None:
    photo = tmp_path / name
    shutil.copyfile(EXAMPLE, photo)
    result = subprocess.run(
        [
            shutil.which("psdr-room") or "psdr-room",
            f"image={photo}",
            "run.until=load_image",
            f"hydra.run.dir={tmp_path / 'run'}",
        ],
        env=cli_env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "run" / "artifacts" / "image").is_dir()


def _deny(monkeypatch: pytest.MonkeyPatch, path: Path, mode: int) -> None:
    """Make ``os.access`` answer as for a user without ``mode`` on ``path`` (root has every permission)."""
    real = os.access

    def access(target: os.PathLike[str] | str, wanted: int, **kwargs: object) -> bool:
        return False if Path(target) == path and wanted & mode else real(target, wanted)

    monkeypatch.setattr(os, "access", access)


def test_unreadable_photo_is_bad_input(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    photo = tmp_path / "photo.jpg"
    shutil.copyfile(EXAMPLE, photo)
    if os.geteuid() != 0:  # an ordinary user: the real thing
        photo.chmod(0)
    else:
        _deny(monkeypatch, photo, os.R_OK)
    with pytest.raises(PsdrRoomError, match=r"photo.jpg: cannot be read \(permission denied\)"):
        preflight([f"image={photo}", f"hydra.run.dir={tmp_path / 'run'}"], plugin_system())


def test_unwritable_run_folder_is_refused_before_hydra_writes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    parent = tmp_path / "locked"
    parent.mkdir()
    _deny(monkeypatch, parent, os.W_OK)
    with pytest.raises(PsdrRoomError, match=r"hydra.run.dir=.*locked cannot be written \(permission denied\)"):
        preflight([f"image={EXAMPLE}", f"hydra.run.dir={parent / 'run'}"], plugin_system())
    assert list(parent.iterdir()) == []


def test_a_read_only_cache_computes_without_storing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    cache = tmp_path / "cache"
    Store(cache)
    monkeypatch.setattr(Store, "writable", lambda self: False)
    with caplog.at_level(logging.WARNING, logger="psdr_room"):
        record = execute(
            compose_config([f"image={EXAMPLE}", "run.until=estimate_fov", f"cache_dir={cache}"]), tmp_path / "run"
        )
    assert [r.name for r in record.stages] == ["load_image", "estimate_fov"]
    assert [r.getMessage() for r in caplog.records if "read-only" in r.getMessage()] == [
        f"cache_dir={cache} is read-only: finished stages are read from it, new results are not stored "
        "(set cache_dir= to a writable folder to keep them)"
    ]
    assert list(Store(cache).entries()) == []
    assert (tmp_path / "run" / "metrics.json").is_file()


def test_same_inputs_same_digests(tmp_path: Path) -> None:
    """room_fit and fit_objects recomputed on the same inputs (in two processes, as two runs would) give the same
    bytes: no clock in an artifact, and the renderer's gradient sums in one order."""
    digests = []
    for run in ("a", "b"):
        script = (
            "import json, sys\n"
            "from pathlib import Path\n"
            "from psdr_room_core.engine.cli import compose_config\n"
            "from psdr_room_core.engine.run import execute\n"
            f"record = execute(compose_config(['image={EXAMPLE}', 'cache_dir={tmp_path / 'cache'}', "
            "'run.from=room_fit', 'run.until=fit_objects', 'room_fit.iterations=20', 'fit_objects.iterations=10']), "
            f"Path('{tmp_path / run}'))\n"
            "print(json.dumps(record.digests))\n"
        )
        result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
        assert result.returncode == 0, result.stderr[-2000:]
        digests.append(result.stdout.strip().splitlines()[-1])
    assert digests[0] == digests[1]
