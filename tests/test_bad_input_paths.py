"""The bad-input corpus for the places Hydra writes: run, sweep and job folders, ``hydra.output_subdir`` and
log files named by interpolation (``${oc.env:...}``, ``${hydra:...}``, ``${now:...}``) or escaping the run
folder, and photo paths holding ``${``. Each refusal is one line and leaves every file of the user's as it was."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from bad_input import Case, example, run_case, snapshot
from conftest import EXAMPLE
from psdr_room_core.engine.cache import Store, damage
from psdr_room_core.engine.ownership import MARKER

QUICK = ("fov=fixed", "detector=none", "run.until=load_image")
"""Overrides that end a run that missed the fault after its first stage."""
FOLDER_VARIABLE = "PSDR_ROOM_TEST_FOLDER"
"""The environment variable the interpolated run-folder cases point at a folder of the user's."""
UNSET_VARIABLE = "PSDR_ROOM_TEST_UNSET"
"""An environment variable no case sets."""


def another_apps_folder(folder: Path) -> Path:
    """A run folder of another Hydra app: its saved config and its results, no psdr-room marker."""
    (folder / ".hydra").mkdir(parents=True)
    (folder / ".hydra" / "config.yaml").write_text("their_app: 1\n")
    (folder / "their_results.csv").write_text("a,b\n")
    return folder


def users_folder(folder: Path) -> Path:
    """A folder of the user's holding a ``config.yaml`` (the name Hydra saves a job's config under)."""
    folder.mkdir()
    (folder / "config.yaml").write_text("mine: 1\n")
    return folder


def sweep_into_another_apps_folder(folder: Path) -> list[str]:
    sweep = another_apps_folder(folder / "other")
    (sweep / "multirun.yaml").write_text("their_sweep: 1\n")
    return ["--multirun", f"image={example(folder)}", *QUICK, f"hydra.sweep.dir={sweep}"]


def sweep_job_outside_sweep(folder: Path) -> list[str]:
    users_folder(folder / "mine")
    sweep = folder / "sweep"
    return ["--multirun", f"image={example(folder)}", *QUICK, f"hydra.sweep.dir={sweep}", "hydra.sweep.subdir=../mine"]


def output_subdir_escaping_into_users_folder(folder: Path) -> list[str]:
    users_folder(folder / "mine")  # beside the run folder
    return [f"image={example(folder)}", *QUICK, "hydra.output_subdir=../mine"]


CASES: dict[str, Case] = {
    "output_subdir_absolute": Case(
        lambda f: [f"image={example(f)}", *QUICK, f"hydra.output_subdir={users_folder(f / 'mine')}"],
        "hydra.output_subdir=",
    ),
    "output_subdir_escapes": Case(output_subdir_escaping_into_users_folder, "hydra.output_subdir=../mine: "),
    "log_file_outside_run_dir": Case(
        lambda f: [
            f"image={example(f)}",
            *QUICK,
            f"hydra.job_logging.handlers.file.filename={f / 'sentinel/keep.txt'}",
        ],
        "hydra.job_logging.handlers.file.filename=",
    ),
    "sweep_dir_of_another_app": Case(sweep_into_another_apps_folder, "psdr-room did not write"),
    "sweep_subdir_escapes": Case(sweep_job_outside_sweep, "hydra.sweep.subdir=../mine: "),
    "sweep_dir_unset_variable": Case(
        lambda f: ["--multirun", f"image={example(f)}", *QUICK, f"hydra.sweep.dir=${{oc.env:{UNSET_VARIABLE}}}"],
        f"hydra.sweep.dir=${{oc.env:{UNSET_VARIABLE}}}: cannot be resolved",
    ),
    "photo_interpolated_missing": Case(
        lambda f: [f"image={f / 'room ${oc.env:HOME}.jpg'}", "fov=fixed"], "room ${oc.env:HOME}.jpg: no such file"
    ),
}
"""Cases that :func:`bad_input.run_case` runs (it names the run folder ``hydra.run.dir=`` itself)."""


def run_dir_from_variable(folder: Path) -> list[str]:
    another_apps_folder(folder / "other")
    return [f"image={example(folder)}", *QUICK, f"hydra.run.dir=${{oc.env:{FOLDER_VARIABLE}}}"]


def run_dir_from_hydra_resolver(folder: Path) -> list[str]:
    another_apps_folder(folder / "psdr-room")  # the job's name
    return [f"image={example(folder)}", *QUICK, f"hydra.run.dir={folder}/${{hydra:job.name}}"]


def run_dir_unset_variable(folder: Path) -> list[str]:
    return [f"image={example(folder)}", *QUICK, f"hydra.run.dir=${{oc.env:{UNSET_VARIABLE}}}/run"]


NAMED_RUN_DIR_CASES: dict[str, Case] = {
    "run_dir_from_variable": Case(run_dir_from_variable, "psdr-room did not write"),
    "run_dir_from_hydra_resolver": Case(run_dir_from_hydra_resolver, "psdr-room did not write"),
    "run_dir_unset_variable": Case(
        run_dir_unset_variable, f"hydra.run.dir=${{oc.env:{UNSET_VARIABLE}}}/run: cannot be resolved"
    ),
}
"""Cases naming their run folder by interpolation; ``${oc.env:PSDR_ROOM_TEST_FOLDER}`` is the user's ``other``."""


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_path_gets_one_line(name: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    run_case(CASES[name], tmp_path, cli_env, cache_dir)


@pytest.mark.parametrize("name", sorted(NAMED_RUN_DIR_CASES))
def test_interpolated_run_dir_gets_one_line(
    name: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path
) -> None:
    """:func:`bad_input.run_case`'s promise for a case that names the run folder itself: one error line, and
    every file under the case's folder (the folder the interpolation names among them) as it was."""
    files = tmp_path / "user"
    files.mkdir()
    env = {key: value for key, value in cli_env.items() if key != UNSET_VARIABLE}
    env[FOLDER_VARIABLE] = str(files / "other")
    case = NAMED_RUN_DIR_CASES[name]
    args = case.setup(files)
    before = snapshot(files, ())
    result = subprocess.run([shutil.which("psdr-room") or "psdr-room", *args], env=env, capture_output=True, text=True)
    lines = [line for line in result.stderr.splitlines() if any(w in line.lower() for w in ("error", "warn", "trace"))]
    assert result.returncode != 0 and len(lines) == 1, result.stdout + result.stderr
    assert lines[0].startswith("psdr-room: error: ") and case.expected in lines[0], lines[0]
    assert snapshot(files, ()) == before
    assert not cache_dir.is_dir() or not [e for e in Store(cache_dir).entries() if damage(e)]


def psdr_room(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([shutil.which("psdr-room") or "psdr-room", *args], env=env, capture_output=True, text=True)


def test_photo_named_with_interpolation_runs(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """A photo whose file name holds ``${...}`` is read under that very name."""
    photo = tmp_path / "room ${oc.env:HOME}.jpg"
    shutil.copyfile(EXAMPLE, photo)
    run_dir = tmp_path / "run"
    result = psdr_room(f"image={photo}", *QUICK, f"hydra.run.dir={run_dir}", env=cli_env)
    assert result.returncode == 0, result.stderr[-3000:]
    assert json.loads((run_dir / "run.json").read_text())["config"]["image"] == str(photo)


def test_run_dir_named_by_time_runs(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """``hydra.run.dir=.../${now:...}`` is a new folder: checked as Hydra resolves it, and run."""
    result = psdr_room(
        f"image={EXAMPLE}", *QUICK, f"hydra.run.dir={tmp_path}/runs/${{now:%Y-%m-%d_%H-%M-%S}}", env=cli_env
    )
    assert result.returncode == 0, result.stderr[-3000:]
    (run_dir,) = (tmp_path / "runs").iterdir()
    assert (run_dir / MARKER).is_file() and (run_dir / ".hydra" / "config.yaml").is_file()


def test_sweep_reruns_into_its_own_folder(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """A sweep folder psdr-room wrote is its own: the same sweep runs into it again."""
    sweep = tmp_path / "sweep"
    for _ in range(2):
        result = psdr_room("--multirun", f"image={EXAMPLE}", *QUICK, f"hydra.sweep.dir={sweep}", env=cli_env)
        assert result.returncode == 0, result.stderr[-3000:]
    assert (sweep / MARKER).is_file() and (sweep / "0" / MARKER).is_file()
