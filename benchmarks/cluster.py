"""Many photos at once: photos per hour with one worker and with several on this machine, what a second sweep
over the same photos costs (the shared cache), and what the cache's file locks cost.

Renders ``--rooms`` synthetic rooms (``psdr-room-synth``'s generator) and sweeps the whole pipeline over them
with ``psdr-room --multirun photos='DIR/*/photo.png'``, each sweep from an empty cache and then again on it:

* ``basic``: Hydra's basic launcher, one job after another, each with every core (``run.threads=auto``);
* ``ray``: ``hydra/launcher=ray`` on an in-process local Ray cluster of ``--workers`` CPUs, one CPU per job
  (``run.threads=auto`` reads the ``OMP_NUM_THREADS=1`` Ray gives each task).

Per sweep: wall seconds (Ray's start included), photos per hour, stages computed and cached over all jobs, and
the median SSIM after the fit (the same work whichever launcher ran it). The lock line times
``Store.lock`` taken and released with nobody else holding it, on the filesystem of ``--out``, and its share
of a photo's wall time (one lock per stage).

    python benchmarks/cluster.py [--rooms 4] [--workers 2] [--set KEY=VALUE ...] [--out DIR]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from psdr_room_core.engine.cache import Store
from psdr_room_core.libraries.synth import write_scene
from psdr_room_core.libraries.synth.scene import generate


def sweep(name: str, launcher: list[str], rooms: Path, cache: Path, out: Path, extra: list[str]) -> dict:
    """One ``--multirun`` over the rooms; its wall time and what its jobs computed."""
    folder = out / name
    command = [
        shutil.which("psdr-room") or "psdr-room",
        "--multirun",
        *launcher,
        f"photos={rooms}/*/photo.png",
        f"hydra.sweep.dir={folder}",
        *extra,
    ]
    start = time.perf_counter()
    result = subprocess.run(
        command, capture_output=True, text=True, env={**os.environ, "PSDR_ROOM_CACHE_DIR": str(cache)}
    )
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        sys.exit(f"{name}: psdr-room failed ({result.returncode}):\n{result.stderr[-2000:]}")
    rows = list(csv.DictReader((folder / "summary.csv").open(encoding="utf-8")))
    stages = [json.loads((Path(r["run"]) / "metrics.json").read_text())["stages"] for r in rows]
    cached = sum(s["cached"] for job in stages for s in job.values())
    total = sum(len(job) for job in stages)
    ssim = [float(r["ssim"]) for r in rows if r["ssim"]]
    return {
        "sweep": name,
        "jobs": len(rows),
        "seconds": seconds,
        "per_hour": 3600 * len(rows) / seconds,
        "computed": total - cached,
        "cached": cached,
        "ssim": statistics.median(ssim) if ssim else float("nan"),
    }


def lock_cost(directory: Path, repeats: int = 2000) -> float:
    """Seconds to take and release one uncontended cache lock."""
    store = Store(directory)
    start = time.perf_counter()
    for i in range(repeats):
        with store.lock(f"{i % 16:064x}"):
            pass
    return (time.perf_counter() - start) / repeats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rooms", type=int, default=4, help="synthetic rooms (seeds 0..N-1)")
    parser.add_argument("--workers", type=int, default=2, help="Ray workers (CPUs of the local cluster)")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE", help="overrides for every job")
    parser.add_argument("--out", type=Path, default=None, help="where sweeps and caches go (default: a temp folder)")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="psdr-room-cluster-"))
    rooms = out / "rooms"
    for seed in range(args.rooms):
        write_scene(generate(seed), rooms / f"room{seed}")
    launchers = {"basic": [], "ray": ["hydra/launcher=ray", f"+hydra.launcher.ray.init.num_cpus={args.workers}"]}
    results = []
    for name, launcher in launchers.items():
        for run in ("cold", "warm"):
            results.append(sweep(f"{name}-{run}", launcher, rooms, out / f"cache-{name}", out, args.set))
            print(f"  {results[-1]['sweep']}: {results[-1]['seconds']:.0f} s", file=sys.stderr)
    workers = {"basic": "1", "ray": str(args.workers)}
    print(f"\n{args.rooms} synthetic rooms, {' '.join(args.set) or 'whole pipeline, default settings'}\n")
    print(f"{'sweep':<12} {'workers':>7} {'wall s':>8} {'photos/h':>9} {'computed':>9} {'cached':>7} {'SSIM':>6}")
    for r in results:
        print(
            f"{r['sweep']:<12} {workers[r['sweep'].split('-')[0]]:>7} {r['seconds']:>8.1f} {r['per_hour']:>9.1f} "
            f"{r['computed']:>9} {r['cached']:>7} {r['ssim']:>6.3f}"
        )
    lock = lock_cost(out / "lock-cache")
    stages = (results[0]["computed"] + results[0]["cached"]) / results[0]["jobs"]
    per_photo = results[0]["seconds"] / results[0]["jobs"]
    print(
        f"\ncache lock (uncontended, {out}): {lock * 1e6:.0f} µs each, {stages:.0f} per photo = "
        f"{100 * lock * stages / per_photo:.5f}% of a photo's {per_photo:.0f} s"
    )


if __name__ == "__main__":
    main()
