"""Start-up benchmark: what ``psdr-room --help`` and a fully cached run cost, and which heavy libraries they load.

Both are the command line in a fresh process, timed ``--repeat`` times (median and fastest wall seconds). The
cached run is the bundled example with short fits, first run once into ``--cache`` (a temporary folder unless
given) so that every stage then comes from the cache. The ``heavy`` column lists the libraries the process
imported (``PYTHONPROFILEIMPORTTIME``) among torch, Mitsuba, Dr.Jit, SciPy, onnxruntime and Open3D.

To compare code versions side by side, run it once per version with the same ``--cache`` folder naming a
version each, on a quiet machine (start-up time is mostly imports: a busy CPU doubles it).

    python benchmarks/startup.py [--repeat 5] [--cache DIR] [--photo PHOTO]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pipeline import EXAMPLE

HEAVY = ("torch", "mitsuba", "drjit", "scipy", "onnxruntime", "open3d")
SHORT = [
    "room_fit.iterations=8",
    "fit_objects.iterations=4",
    "fit_appearance.iterations=3",
    "fit_appearance.final_spp=16",
    "fit_appearance.map_size=32",
    "assign_materials.map_size=128",
    "export_scene.texture_size=64",
]
"""Short fits for the run that fills the cache: start-up does not depend on how long the stages took."""


def timed(command: list[str], env: dict[str, str]) -> tuple[float, set[str]]:
    """Wall seconds of ``command`` and the heavy libraries it imported; a failure ends the benchmark."""
    start = time.perf_counter()
    result = subprocess.run(command, env={**env, "PYTHONPROFILEIMPORTTIME": "1"}, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        lines = [line for line in result.stderr.splitlines() if line.strip() and not line.startswith("import time:")]
        sys.exit(f"startup: {' '.join(command[:2])} failed: {lines[-1] if lines else result.returncode}")
    names = {line.rsplit("|", 1)[1].strip() for line in result.stderr.splitlines() if line.startswith("import time:")}
    return seconds, {name for name in HEAVY if name in names}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--cache", type=Path, help="cache folder (filled by a first run when empty)")
    parser.add_argument("--photo", type=Path, default=EXAMPLE)
    args = parser.parse_args()
    exe = shutil.which("psdr-room") or sys.exit("startup: psdr-room is not on PATH; source scripts/env.sh first")
    with tempfile.TemporaryDirectory() as scratch:
        cache = (args.cache or Path(scratch) / "cache").resolve()
        env = {**os.environ, "PSDR_ROOM_CACHE_DIR": str(cache)}
        run = [exe, f"image={args.photo.resolve()}", f"cache_dir={cache}", *SHORT]
        fill, _ = timed([*run, f"hydra.run.dir={scratch}/fill"], env)
        commands = {
            "psdr-room --help": lambda i: [exe, "--help"],
            "fully cached run": lambda i: [*run, f"hydra.run.dir={scratch}/cached{i}"],
        }
        print(f"(cache filled in {fill:.1f} s: {cache})")
        print(f"{'command':<20} {'median s':>9} {'fastest s':>9}  heavy libraries imported")
        for name, command in commands.items():
            results = [timed(command(i), env) for i in range(args.repeat)]
            seconds = [s for s, _ in results]
            heavy = sorted(set().union(*(h for _, h in results)))
            print(f"{name:<20} {statistics.median(seconds):9.2f} {min(seconds):9.2f}  {', '.join(heavy) or '-'}")


if __name__ == "__main__":
    main()
