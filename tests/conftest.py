"""Shared fixtures: paths to the bundled example and the shared real data, isolated caches."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
EXAMPLE = REPO / "examples" / "nyu_basement" / "photo.jpg"


SESSION_DIRS = ("PSDR_ROOM_MODELS_DIR", "PSDR_ROOM_CACHE_DIR")


def pytest_configure(config: pytest.Config) -> None:
    """An empty models directory and cache for the whole session (subprocesses too): ``auto`` selections never
    depend on weights the developer has installed, and what a test caches (stage results, network and code
    digests) never lands in the developer's cache. The ``cache_dir`` fixture gives a test its own cache."""
    for name in SESSION_DIRS:
        os.environ[name] = tempfile.mkdtemp(prefix=f"{name.lower()}-")


def pytest_unconfigure(config: pytest.Config) -> None:
    """Remove the session's models directory and cache."""
    for name in SESSION_DIRS:
        shutil.rmtree(os.environ.pop(name, ""), ignore_errors=True)


@pytest.fixture
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh cache directory, also exported for subprocesses (PSDR_ROOM_CACHE_DIR)."""
    path = tmp_path / "cache"
    monkeypatch.setenv("PSDR_ROOM_CACHE_DIR", str(path))
    return path


@pytest.fixture
def cli_env(cache_dir: Path) -> dict[str, str]:
    """Environment for running the CLI in a subprocess with the isolated cache."""
    env = dict(os.environ)
    env["PSDR_ROOM_CACHE_DIR"] = str(cache_dir)
    return env
