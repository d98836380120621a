"""run.threads: the job's CPU allotment, from the setting, the launcher's resources or the environment."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from psdr_room_core.engine import threads
from psdr_room_core.engine.errors import PsdrRoomError


def test_an_explicit_count_wins_over_everything() -> None:
    assert threads.allotment(3, {"cpus_per_task": 8}, {"OMP_NUM_THREADS": "1"}) == (3, "run.threads")


@pytest.mark.parametrize(
    ("launcher", "expected"),
    [
        ({"cpus_per_task": 4, "n_jobs": None}, (4, "hydra.launcher.cpus_per_task")),  # submitit (local and SLURM)
        ({"ray": {"init": {}, "remote": {"num_cpus": 2}}}, (2, "hydra.launcher.ray.remote.num_cpus")),
        ({"n_jobs": 10_000, "backend": "loky"}, (1, "cores / hydra.launcher.n_jobs")),  # joblib: never below one
    ],
)
def test_auto_takes_the_launchers_resources(launcher: dict, expected: tuple[int, str]) -> None:
    assert threads.allotment("auto", launcher, {"OMP_NUM_THREADS": "7"}) == expected


def test_auto_without_launcher_resources_reads_the_scheduler_then_the_cores() -> None:
    ray_without_cpus = {"ray": {"init": {"address": None}, "remote": {}}}
    assert threads.allotment("auto", ray_without_cpus, {"SLURM_CPUS_PER_TASK": "6", "OMP_NUM_THREADS": "2"}) == (
        6,
        "SLURM_CPUS_PER_TASK",
    )
    assert threads.allotment("auto", ray_without_cpus, {"OMP_NUM_THREADS": "1"}) == (1, "OMP_NUM_THREADS")
    assert threads.allotment("auto", None, {"OMP_NUM_THREADS": "0"}) == (threads.cores(), "cores")


@pytest.mark.parametrize("bad", [0, -2, "four", True, 1.5])
def test_a_bad_count_is_one_line(bad: object) -> None:
    with pytest.raises(PsdrRoomError, match=r"run.threads=.* is not a thread count; use auto or an integer >= 1"):
        threads.allotment(bad)


def test_apply_limits_every_library_in_a_fresh_process() -> None:
    """After apply(1), torch (loaded later), Dr.Jit, OpenCV and new onnxruntime sessions use one thread."""
    code = (
        "from psdr_room_core.engine import threads; import drjit, cv2\n"
        "threads.apply(1)\n"
        "import torch\n"
        "print(torch.get_num_threads(), drjit.thread_count(), cv2.getNumThreads(), threads.count(), "
        "threads.allotment('auto')[1])\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "SLURM_CPUS_PER_TASK")}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    # the allotment still reads the environment the process started with, not the OMP_NUM_THREADS apply() set
    assert result.stdout.split() == ["1", "1", "1", "1", "cores"]
