"""Commands stopped half-way: what ``psdr-room``, ``psdr-room-edit`` and ``psdr-room-blender`` write whole is
written under a scratch name and renamed into place, a command stopped by SIGTERM removes its scratch, and the
scratch a killed one (SIGKILL) leaves is removed by the next command writing there, with one line saying so;
nothing else is touched (a live writer's scratch, another kind's, another host's, a name of the user's).

The processes are real and so are the kills. Publishing and an edit's last steps are too quick to hit by polling,
so a plugin (installed for that command only, through the ``psdr_room`` entry points) holds the command there:
in its ``run_metrics`` hook (called while a run publishes) and in its ``held`` denoiser (called by
``psdr-room-edit`` after rendering, into its scratch folder) it writes $HOLD_FILE, then waits to be stopped."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bad_input import Case, example, run_case, scene_folder
from psdr_room_core.engine.debris import scratch_dir
from psdr_room_core.method.stages.export import mesh_ply

QUICK = ["fov=fixed", "detector=none", "run.until=load_image"]
SWEPT = "removed 1 unfinished {kind} entry left in {folder} by a process that was stopped"

HOLDING_PLUGIN = '''"""Holds a command where it writes: says so in the file $HOLD_FILE, then waits to be stopped."""

import os
import time
from pathlib import Path

from psdr_room_core.engine.hookspecs import hookimpl


def hold():
    Path(os.environ["HOLD_FILE"]).write_text("holding")
    time.sleep(600)


class HeldDenoiser:
    def describe(self):
        return "held"

    def denoise(self, rgb, albedo=None, normal=None):
        hold()
        return rgb


@hookimpl
def register_implementations(registry):
    registry.add_implementation("denoiser", "held", HeldDenoiser)


@hookimpl
def run_metrics(run):
    hold()
    return {}
'''


# ------------------------------------------------------------------------------------------ helpers
def program(name: str) -> str:
    return shutil.which(name) or name


def holding(tmp_path: Path, cli_env: dict[str, str]) -> tuple[dict[str, str], tuple[Path, str]]:
    """An environment in which the commands load the holding plugin, and the file it writes when it holds (as
    the folder and name :func:`stop_when` waits for)."""
    site = tmp_path / "plugin_site"
    (site / "holding-0.dist-info").mkdir(parents=True)
    (site / "holding.py").write_text(HOLDING_PLUGIN)
    (site / "holding-0.dist-info" / "METADATA").write_text("Metadata-Version: 2.1\nName: holding\nVersion: 0\n")
    (site / "holding-0.dist-info" / "entry_points.txt").write_text("[psdr_room]\nholding = holding\n")
    path = os.pathsep.join(p for p in (str(site), cli_env.get("PYTHONPATH", "")) if p)
    return {**cli_env, "PYTHONPATH": path, "HOLD_FILE": str(tmp_path / "holding")}, (tmp_path, "holding")


def start(command: list[str], env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )


def stop_when(
    process: subprocess.Popen[str], appears: tuple[Path, str], how: signal.Signals, group: bool = False
) -> str:
    """Send ``how`` to ``process`` (its whole process group with ``group``) as soon as an entry matching
    ``appears`` (folder, glob) exists; return its stderr."""
    folder, pattern = appears
    deadline = time.monotonic() + 240
    while not list(folder.glob(pattern)):
        if process.poll() is not None:
            pytest.fail(f"{process.args!s} ended without writing {folder / pattern}: {process.communicate()}")
        if time.monotonic() > deadline:
            os.killpg(process.pid, signal.SIGKILL)
            pytest.fail(f"{process.args!s} wrote no {folder / pattern} in 240 s")
        time.sleep(0.005)
    if group:
        os.killpg(process.pid, how)
    else:
        process.send_signal(how)
    _, stderr = process.communicate(timeout=120)
    return stderr


def left_by_a_dead_process(folder: Path, kind: str) -> Path:
    """A scratch folder of ``kind`` in ``folder`` made by a process that has ended (with a file in it)."""
    made = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from pathlib import Path; from psdr_room_core.engine.debris import scratch_dir; "
            "d = scratch_dir(Path(sys.argv[1]), sys.argv[2]); (d / 'half.json').write_text('{'); print(d)",
            str(folder),
            kind,
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    return Path(made.stdout.strip())


def running_in_group(group: int) -> list[int]:
    """The processes of process group ``group`` still running (not zombies) a few seconds on."""
    deadline = time.monotonic() + 10
    while True:
        running = []
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue  # ended meanwhile
            if int(fields[2]) == group and fields[0] != "Z":
                running.append(int(stat.parent.name))
        if not running or time.monotonic() > deadline:
            return running
        time.sleep(0.2)


def problems(stderr: str) -> list[str]:
    """The lines of ``stderr`` that report something (errors, warnings, tracebacks, removals)."""
    words = ("error", "warn", "traceback", "removed")
    return [line for line in stderr.splitlines() if any(w in line.lower() for w in words)]


def renderable_scene(folder: Path) -> Path:
    """A scene folder ``psdr-room-edit`` renders: :func:`bad_input.scene_folder`'s floor and ceiling light with
    their meshes."""
    scene = scene_folder(folder)
    (scene / "meshes").mkdir()
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    floor = np.array([[-2, -2, 3], [2, -2, 3], [2, 2, 3], [-2, 2, 3]], float)
    lamp = np.array([[-0.3, -1, 1.5], [0.3, -1, 1.5], [0.3, -1, 2.1], [-0.3, -1, 2.1]], float)
    (scene / "meshes" / "floor.ply").write_bytes(mesh_ply(floor, quad))
    (scene / "meshes" / "light_ceiling_1.ply").write_bytes(mesh_ply(lamp, quad))
    return scene


def edit_command(scene: Path, out: Path, denoiser: str = "none") -> list[str]:
    return [program("psdr-room-edit"), str(scene), "light.scale=2", "--out", str(out), "--denoiser", denoiser]


def exported_scene(folder: Path, cli_env: dict[str, str]) -> Path:
    """A complete scene folder (``scene.glb`` and ``scene.xml`` too), as psdr-room-edit writes it."""
    out = folder / "exported"
    result = subprocess.run(
        [program("psdr-room-edit"), str(renderable_scene(folder)), "--out", str(out), "--spp", "1"],
        env=cli_env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    return out


def blender_command(scene: Path, *options: str) -> list[str]:
    return [program("psdr-room-blender"), str(scene), "--render", str(scene / "cycles.png"), "--spp", "2", *options]


RENDERING = ("--spp", "100000", "--width", "640")
"""A render that keeps Blender busy for seconds after it saved the .blend (Cycles' adaptive sampling ends a small
one at once)."""


needs_blender = pytest.mark.skipif(
    shutil.which(os.environ.get("PSDR_ROOM_BLENDER", "blender")) is None, reason="Blender is not installed"
)


# ------------------------------------------------------------------------------------------ psdr-room
def test_a_run_killed_while_publishing_leaves_what_the_rerun_removes(
    tmp_path: Path, cli_env: dict[str, str], cache_dir: Path
) -> None:
    run_dir = tmp_path / "run"
    command = [program("psdr-room"), f"image={example(tmp_path)}", *QUICK, f"hydra.run.dir={run_dir}"]
    held_env, held = holding(tmp_path, cli_env)
    stop_when(start(command, held_env), held, signal.SIGKILL)
    assert len(list(run_dir.glob(".publishing-*"))) == 1 and not (run_dir / "metrics.json").exists()

    rerun = subprocess.run(command, env=cli_env, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert problems(rerun.stderr) == [SWEPT.format(kind=kind, folder=run_dir) for kind in ("publishing", "run_store")]
    assert not list(run_dir.glob(".publishing-*")) and (run_dir / "metrics.json").is_file()


def test_a_run_stopped_by_sigterm_while_publishing_removes_its_scratch(
    tmp_path: Path, cli_env: dict[str, str], cache_dir: Path
) -> None:
    run_dir = tmp_path / "run"
    command = [program("psdr-room"), f"image={example(tmp_path)}", *QUICK, f"hydra.run.dir={run_dir}"]
    held_env, held = holding(tmp_path, cli_env)
    process = start(command, held_env)
    stderr = stop_when(process, held, signal.SIGTERM)
    assert process.returncode == 130, stderr
    assert problems(stderr) == [
        "psdr-room: error: interrupted; finished stages are cached, rerun the same command to resume"
    ]
    assert not list(run_dir.glob(".publishing-*")) and not (run_dir / "metrics.json").exists()


def test_a_rerun_removes_only_the_scratch_of_dead_writers(
    tmp_path: Path, cli_env: dict[str, str], cache_dir: Path
) -> None:
    """A dead writer's publishing scratch goes; a live writer's, another kind's, another host's and the user's own
    ``.publishing-notes`` stay."""
    run_dir = tmp_path / "run"
    command = [program("psdr-room"), f"image={example(tmp_path)}", *QUICK, f"hydra.run.dir={run_dir}"]
    first = subprocess.run(command, env=cli_env, capture_output=True, text=True, timeout=300)
    assert first.returncode == 0, first.stderr
    dead = left_by_a_dead_process(run_dir, "publishing")
    other_host = run_dir / f"{dead.name.split('@')[0]}@another.host-x1y2z3"  # a dead pid there says nothing here
    other_host.mkdir()
    (run_dir / ".publishing-notes").write_text("the user's")
    kept = [
        scratch_dir(run_dir, "publishing"),  # this test's own process: alive
        left_by_a_dead_process(run_dir, "edit"),
        other_host,
        run_dir / ".publishing-notes",
    ]

    rerun = subprocess.run(command, env=cli_env, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert problems(rerun.stderr) == [SWEPT.format(kind="publishing", folder=run_dir)]
    assert not dead.exists() and all(path.exists() for path in kept)
    assert (run_dir / ".publishing-notes").read_text() == "the user's"


def test_a_rerun_removes_a_report_half_written_by_a_killed_run(
    tmp_path: Path, cli_env: dict[str, str], cache_dir: Path
) -> None:
    """The report (and every file written whole) goes through a scratch file of kind ``writing``."""
    run_dir = tmp_path / "run"
    command = [program("psdr-room"), f"image={example(tmp_path)}", *QUICK, f"hydra.run.dir={run_dir}"]
    first = subprocess.run(command, env=cli_env, capture_output=True, text=True, timeout=300)
    assert first.returncode == 0, first.stderr
    dead = left_by_a_dead_process(run_dir, "writing")

    rerun = subprocess.run(command, env=cli_env, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert problems(rerun.stderr) == [SWEPT.format(kind="writing", folder=run_dir)]
    assert not dead.exists() and (run_dir / "report.html").is_file()


# ------------------------------------------------------------------------------------------ psdr-room-edit
def test_an_edit_killed_while_writing_leaves_what_the_next_edit_removes(
    tmp_path: Path, cli_env: dict[str, str]
) -> None:
    scene, out = renderable_scene(tmp_path), tmp_path / "edited"
    held_env, held = holding(tmp_path, cli_env)
    stop_when(start(edit_command(scene, out, "held"), held_env), held, signal.SIGKILL)
    assert len(list(tmp_path.glob(".edit-*"))) == 1 and not out.exists()
    kept = [scratch_dir(tmp_path, "edit"), tmp_path / ".edit-notes"]  # a live writer's; the user's
    kept[1].write_text("the user's")

    again = subprocess.run(edit_command(scene, out), env=cli_env, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert problems(again.stderr) == [SWEPT.format(kind="edit", folder=tmp_path)]
    assert sorted(tmp_path.glob(".edit-*")) == sorted(kept) and (out / "render.png").is_file()


def test_an_edit_stopped_by_sigterm_removes_its_scratch(tmp_path: Path, cli_env: dict[str, str]) -> None:
    scene, out = renderable_scene(tmp_path), tmp_path / "edited"
    held_env, held = holding(tmp_path, cli_env)
    process = start(edit_command(scene, out, "held"), held_env)
    stderr = stop_when(process, held, signal.SIGTERM)
    assert process.returncode == 130, stderr
    assert problems(stderr) == ["psdr-room-edit: error: interrupted; rerun the same command"]
    assert not list(tmp_path.glob(".edit-*")) and not out.exists()


def test_an_edit_replacing_its_earlier_one_leaves_no_scratch_and_plain_permissions(
    tmp_path: Path, cli_env: dict[str, str]
) -> None:
    """The earlier edit is moved aside, the new one renamed in its place, then the earlier one removed."""
    scene, out = renderable_scene(tmp_path), tmp_path / "edited"
    for _ in range(2):
        result = subprocess.run(edit_command(scene, out), env=cli_env, capture_output=True, text=True, timeout=300)
        assert result.returncode == 0, result.stderr
    assert not list(tmp_path.glob(".edit-*")) and (out / "render.png").is_file()
    assert (out.stat().st_mode & 0o777) == (scene.stat().st_mode & 0o777)  # as a plain mkdir makes it


# ------------------------------------------------------------------------------------------ psdr-room-blender
@needs_blender
def test_blender_killed_while_rendering_leaves_what_the_next_run_removes(
    tmp_path: Path, cli_env: dict[str, str]
) -> None:
    scene = exported_scene(tmp_path, cli_env)
    process = start(blender_command(scene, *RENDERING), cli_env)
    stop_when(process, (scene, ".blender-*/scene.blend"), signal.SIGKILL, group=True)  # the command and its Blender
    assert len(list(scene.glob(".blender-*"))) == 1 and not (scene / "scene.blend").exists()

    again = subprocess.run(blender_command(scene), env=cli_env, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert problems(again.stderr) == [SWEPT.format(kind="blender", folder=scene)]
    assert not list(scene.glob(".blender-*")) and (scene / "scene.blend").is_file()
    assert (scene / "cycles.png").stat().st_mode & 0o777 == (scene / "scene.xml").stat().st_mode & 0o777


@needs_blender
def test_blender_stopped_by_sigterm_stops_blender_and_removes_its_scratch(
    tmp_path: Path, cli_env: dict[str, str]
) -> None:
    scene = exported_scene(tmp_path, cli_env)
    process = start(blender_command(scene, *RENDERING), cli_env)
    stderr = stop_when(process, (scene, ".blender-*/scene.blend"), signal.SIGTERM)  # the command alone: `kill PID`
    assert process.returncode == 130, stderr
    assert not running_in_group(process.pid)  # its Blender is stopped too
    assert problems(stderr) == ["psdr-room-blender: error: interrupted; rerun the same command"]
    assert not list(scene.glob(".blender-*")) and not (scene / "scene.blend").exists()


# ------------------------------------------------------------------------------------------ one-line errors
def blender_into(folder: Path, *output: str) -> list[str]:
    """A complete-looking scene folder (Blender would fail on it: the outputs are refused first)."""
    scene = scene_folder(folder)
    for name in ("scene.glb", "scene.xml"):
        (scene / name).write_bytes(b"not read")
    (folder / "a_file").write_text("the user's")
    return [str(scene), *output]


CASES: dict[str, Case] = {
    "edit_out_under_a_file": Case(
        lambda folder: [str(renderable_scene(folder)), "--out", str(folder / "sentinel" / "keep.txt" / "edited")],
        "keep.txt is a file, not a folder",
        "psdr-room-edit",
    ),
    "blender_out_is_a_folder": Case(
        lambda folder: blender_into(folder, "--out", str(folder / "sentinel")),
        "sentinel: is a folder",
        "psdr-room-blender",
    ),
    "blender_render_under_a_file": Case(
        lambda folder: blender_into(folder, "--render", str(folder / "a_file" / "cycles.png")),
        "a_file is a file, not a folder",
        "psdr-room-blender",
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_debris_bad_input_gets_one_line(name: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    run_case(CASES[name], tmp_path, cli_env, cache_dir)
