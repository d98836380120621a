"""The repository's contracts in ``pyproject.toml``, checked by the test command:

* [tool.importlinter]: three rooms (plugins build on the method, the method on the engine, never the other way),
  an engine free of the rendering/vision/learning stack, and no package whose modules import each other in a circle;
* [tool.ruff]: ``ruff check`` everywhere (undefined and unused names, syntax errors), ``ruff format`` on the engine;
* [tool.mypy]: the engine type-checks under ``--strict``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def _run(*command: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(BIN / command[0]), *command[1:]], cwd=ROOT, capture_output=True, text=True)


def test_import_contracts_are_kept() -> None:
    result = _run("lint-imports", "--no-cache")
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    assert "3 kept, 0 broken" in result.stdout, result.stdout[-2000:]


def test_ruff_finds_nothing_and_the_engine_is_formatted() -> None:
    lint = _run("ruff", "check", "--no-cache", ".")
    assert lint.returncode == 0, lint.stdout[-4000:] + lint.stderr[-2000:]
    formatted = _run("ruff", "format", "--check", "--no-cache", "psdr_room_core/engine")
    assert formatted.returncode == 0, formatted.stdout[-4000:] + formatted.stderr[-2000:]


def test_the_engine_type_checks() -> None:
    result = _run("mypy", "--no-incremental")
    assert result.returncode == 0 and "Success" in result.stdout, result.stdout[-4000:] + result.stderr[-2000:]
