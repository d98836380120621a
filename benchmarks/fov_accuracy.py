"""Accuracy of the vanishing-point FoV estimator on real photos with known intrinsics.

Reads ``index.csv`` of the photo set (columns ``image``, ``height``, ``fy``; rows with a
blank ``fy`` are skipped), runs :func:`plugins.vanishing_points.estimate_camera` on each
photo and prints per-photo ground-truth and estimated vertical FoV, then the median and
worst absolute errors and how many photos got an estimate (not the fallback).

    python benchmarks/fov_accuracy.py [--photos DIR]
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
import time
from pathlib import Path

import numpy as np
from PIL import Image

from psdr_room_core.engine import shipped
from psdr_room_core.libraries.vanishing_points import VanishingPointParams, estimate_camera

REPO_ROOT = Path(__file__).resolve().parents[1]

DEFAULT_PHOTOS = REPO_ROOT.parent / "shared/data/photos"


def load_rgb(path: Path) -> np.ndarray:
    """Float32 HxWx3 sRGB image in [0, 1]."""
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"), dtype=np.float32) / 255.0


def evaluate(photos_dir: Path, params: VanishingPointParams | None = None) -> list[dict]:
    """Run the estimator on every photo of ``photos_dir/index.csv`` with a known ``fy``.

    Returns one dict per photo: ``image``, ``gt_vfov_deg``, ``est_vfov_deg``, ``error_deg``
    (estimate minus ground truth), ``method``, ``confidence``, ``n_segments``, ``time_s``.
    """
    photos_dir = Path(photos_dir)
    rows = []
    with open(photos_dir / "index.csv", newline="") as fh:
        for entry in csv.DictReader(fh):
            if not entry.get("fy", "").strip():
                continue
            rgb = load_rgb(photos_dir / entry["image"])
            fy = float(entry["fy"])
            gt = math.degrees(2.0 * math.atan(rgb.shape[0] / (2.0 * fy)))
            start = time.perf_counter()
            result = estimate_camera(rgb, params or VanishingPointParams(**shipped.node("fov.vanishing_points")))
            elapsed = time.perf_counter() - start
            rows.append(
                {
                    "image": entry["image"],
                    "gt_vfov_deg": gt,
                    "est_vfov_deg": result.vfov_deg,
                    "error_deg": result.vfov_deg - gt,
                    "method": result.method,
                    "confidence": result.confidence,
                    "n_segments": result.n_segments,
                    "time_s": elapsed,
                }
            )
    return rows


def summarize(rows: list[dict]) -> dict:
    """Median and worst absolute error (deg) and the number of non-fallback estimates."""
    errors = [abs(r["error_deg"]) for r in rows]
    return {
        "n_photos": len(rows),
        "median_abs_error_deg": statistics.median(errors) if errors else float("nan"),
        "worst_abs_error_deg": max(errors) if errors else float("nan"),
        "n_estimated": sum(r["method"] != "fallback" for r in rows),
    }


def format_table(rows: list[dict]) -> str:
    """Plain-text table of the per-photo results and the summary."""
    lines = [f"{'photo':<36} {'gt':>6} {'est':>6} {'err':>6} {'method':<19} {'conf':>5} {'segs':>5} {'time':>6}"]
    for r in rows:
        lines.append(
            f"{r['image']:<36} {r['gt_vfov_deg']:6.2f} {r['est_vfov_deg']:6.2f} {r['error_deg']:+6.2f} "
            f"{r['method']:<19} {r['confidence']:5.2f} {r['n_segments']:5d} {r['time_s']:5.2f}s"
        )
    s = summarize(rows)
    lines.append(
        f"median |err| {s['median_abs_error_deg']:.2f} deg, worst |err| {s['worst_abs_error_deg']:.2f} deg, "
        f"estimated {s['n_estimated']}/{s['n_photos']} (rest fallback)"
    )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=Path, default=DEFAULT_PHOTOS, help="folder holding index.csv")
    args = parser.parse_args()
    print(format_table(evaluate(args.photos)))


if __name__ == "__main__":
    main()
