"""How many CPU threads a run may use (``run.threads``), set once for every library that starts threads.

``run.threads=auto`` takes the job's CPU allotment, so that N sweep workers on N cores do not oversubscribe:
the launcher's resources (``hydra.launcher.cpus_per_task`` for submitit, ``hydra.launcher.ray.remote.num_cpus``
for Ray, cores / ``hydra.launcher.n_jobs`` for joblib), else what the scheduler or worker says in the
environment (``SLURM_CPUS_PER_TASK``, ``OMP_NUM_THREADS``: Ray and loky set it for their workers), else every
core this process may run on. :func:`apply` hands the count to OpenMP/BLAS (environment, read by torch and
open3d when they load), and to torch, Dr.Jit and OpenCV when they are loaded; onnxruntime sessions and the
renderer ask :func:`count`.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from typing import Any

from .errors import PsdrRoomError

_ENV_LIMITS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
_ALLOTMENT_VARIABLES = ("SLURM_CPUS_PER_TASK", "OMP_NUM_THREADS")
_INHERITED = {variable: os.environ[variable] for variable in _ALLOTMENT_VARIABLES if variable in os.environ}
"""The allotment variables as this process found them (before :func:`apply` set ``OMP_NUM_THREADS`` itself)."""
_applied: int | None = None


def cores() -> int:
    """CPU cores this process may run on (its affinity mask, which containers and schedulers narrow)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def allotment(
    setting: Any, launcher: Mapping[str, Any] | None = None, environ: Mapping[str, str] = _INHERITED
) -> tuple[int, str]:
    """The thread count for ``run.threads=setting`` and where it came from (for the log)."""
    if setting not in (None, "auto"):
        if isinstance(setting, bool) or not str(setting).isdigit() or int(setting) < 1:
            raise PsdrRoomError(f"run.threads={setting} is not a thread count; use auto or an integer >= 1")
        return int(setting), "run.threads"
    launcher = launcher or {}
    if count := _positive(launcher.get("cpus_per_task")):
        return count, "hydra.launcher.cpus_per_task"
    if count := _positive(((launcher.get("ray") or {}).get("remote") or {}).get("num_cpus")):
        return count, "hydra.launcher.ray.remote.num_cpus"
    if jobs := _positive(launcher.get("n_jobs")):
        return max(1, cores() // jobs), "cores / hydra.launcher.n_jobs"
    for variable in _ALLOTMENT_VARIABLES:
        if count := _positive(environ.get(variable)):
            return count, variable
    return cores(), "cores"


def _positive(value: Any) -> int | None:
    """``value`` as a positive integer, or None."""
    if value is None or isinstance(value, bool) or not str(value).isdigit() or int(value) < 1:
        return None
    return int(value)


def apply(threads: int) -> None:
    """Limit this process to ``threads`` threads in every library that starts its own."""
    global _applied
    _applied = threads
    for variable in _ENV_LIMITS:
        os.environ[variable] = str(threads)
    # Libraries loaded already read the environment above too early; the engine imports none of them itself.
    for module, setter in (("torch", "set_num_threads"), ("drjit", "set_thread_count"), ("cv2", "setNumThreads")):
        if module in sys.modules:
            getattr(sys.modules[module], setter)(threads)


def count() -> int:
    """The thread count :func:`apply` set, or every core when no run has set one (tests, library use)."""
    return _applied if _applied is not None else cores()
