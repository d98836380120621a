"""Pipeline benchmark: per-stage time, the cached-rerun ratio, and FoV accuracy on real photos.

Runs the CLI twice on the bundled example with a fresh cache (the second run must be served from the
cache), then the vanishing-point FoV estimator on every shared photo with known intrinsics. Prints tables.

    python benchmarks/pipeline.py [--image PHOTO] [--photos DIR] [--skip-fov]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def timed_run(image: Path, cache: Path, run_dir: Path) -> tuple[float, dict]:
    """Run ``psdr-room`` once; return its wall time and metrics."""
    env = {**os.environ, "PSDR_ROOM_CACHE_DIR": str(cache)}
    start = time.perf_counter()
    subprocess.run([shutil.which("psdr-room") or "psdr-room", f"image={image}", f"hydra.run.dir={run_dir}"],
                   env=env, check=True, capture_output=True)
    return time.perf_counter() - start, json.loads((run_dir / "metrics.json").read_text())


def stage_table(image: Path) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp_path = Path(tmp)
        first_wall, first = timed_run(image, tmp_path / "cache", tmp_path / "run1")
        second_wall, second = timed_run(image, tmp_path / "cache", tmp_path / "run2")
    print(f"pipeline on {image.relative_to(REPO) if image.is_relative_to(REPO) else image}")
    print(f"{'stage':<16}{'first run (s)':>15}{'rerun (s)':>12}  rerun")
    for name, s in first["stages"].items():
        again = second["stages"][name]
        print(f"{name:<16}{s['seconds']:>15.3f}{again['seconds']:>12.3f}  {'cached' if again['cached'] else 'COMPUTED'}")
    stages_first, stages_second = first["total_seconds"], second["total_seconds"]
    print(f"{'stages total':<16}{stages_first:>15.3f}{stages_second:>12.3f}")
    print(f"{'whole command':<16}{first_wall:>15.3f}{second_wall:>12.3f}  (process start, imports, Hydra included)")
    print(f"cached-rerun ratio: stages {stages_second / stages_first:.3f}, whole command {second_wall / first_wall:.3f}")
    print(f"estimated vertical FoV {first['vfov_deg']:.2f}° (error {first['camera'].get('vfov_error_deg', float('nan')):+.2f}°)\n")


def fov_table(photos: Path) -> None:
    from fov_accuracy import evaluate, format_table, summarize

    rows = evaluate(photos)
    print(format_table(rows))
    summary = summarize(rows)
    print(" ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in summary.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--image", type=Path, default=REPO / "examples" / "nyu_basement" / "photo.jpg")
    parser.add_argument("--photos", type=Path, default=REPO.parent / "shared" / "data" / "photos")
    parser.add_argument("--skip-fov", action="store_true", help="only the pipeline timing table")
    args = parser.parse_args()
    stage_table(args.image.resolve())
    if not args.skip_fov:
        fov_table(args.photos)


if __name__ == "__main__":
    main()
