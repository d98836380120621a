"""The repository's contracts in ``pyproject.toml``, checked by the test command through ``.pre-commit-config.yaml``:

* [tool.importlinter]: five rooms (applications, plugins, libraries, method, engine: each on those below, never the
  other way),
  an engine free of the rendering/vision/learning stack, and no package whose modules import each other in a circle
  (type-only imports included);
* [tool.ruff]: ``ruff check`` (pyflakes, syntax errors, import order, bugbear, pyupgrade, simplify) and ``ruff format``
  everywhere;
* [tool.mypy] (``scripts/mypy.sh``): every package type-checks, the engine under ``--strict``, the rest at mypy's
  default strictness.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def test_the_pre_commit_hooks_pass() -> None:
    """Every hook of ``.pre-commit-config.yaml`` (ruff check, ruff format, import contracts, mypy) over every file."""
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}
    result = subprocess.run(
        [str(BIN / "pre-commit"), "run", "--all-files", "--color=never"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout[-6000:] + result.stderr[-2000:]
    assert all(hook in result.stdout for hook in ("ruff check", "ruff format", "import contracts", "mypy")), (
        result.stdout
    )


def test_the_wheel_lists_every_package() -> None:
    """``pyproject.toml`` names its packages one by one, so a package folder left off the list is missing from a wheel
    (an editable install still finds it): every folder with an ``__init__.py`` must be listed."""
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    found = {
        ".".join([name, *init.parent.relative_to(ROOT / folder).parts])
        for name, folder in setuptools["package-dir"].items()
        for init in (ROOT / folder).rglob("__init__.py")
    }
    assert found - set(setuptools["packages"]) == set()
