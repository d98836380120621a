"""Speed benchmark: where the pipeline's time goes, side by side with the previous defaults, and how it grows.

Every run is the command line from an empty cache (its own, deleted first), as a user's first run of a photo:

1. **defaults vs previous defaults** on the bundled example and two synthetic rooms: seconds and peak memory
   (RSS) of every stage, the process's wall time (start-up included), the ratio, and the quality figures
   beside them (render vs photo RMSE / SSIM / ꟻLIP at init and after the fit, objects placed; on synthetic
   rooms also the room box IoU and the albedo error against the truth). ``--old`` replaces the previous
   defaults' overrides (:data:`PREVIOUS`); then the preview (``+preset=preview``) on the example, its time and
   how its picks compare with the full run's;
2. **time vs objects**: synthetic rooms with 2, 4, 8 and 16 pieces of furniture (as many as fit);
3. **time vs working resolution**: the example at 160, 320 and 640 px (every stage's ``render_width``), with
   the fits cut to a few iterations (their seconds per iteration are what grows).

Both scaling tables give the stages' seconds; the fits' per-iteration seconds are in their logs.

    python benchmarks/speed.py [--seeds 0,1] [--old KEY=VALUE ...] [--no-scaling] [--objects 2,4,8,16]
                               [--widths 160,320,640]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import time
from pathlib import Path

from pipeline import EXAMPLE, ground_truth_errors, pipeline, synth_photo
from room import iou

from psdr_room_core.method.artifacts import RoomBox

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "outputs" / "benchmarks" / "speed"
PREVIOUS = [
    "retrieval.silhouette.shortlist=0",  # every model of the category refined (1 / 0.2 of them now)
    "fit_objects.convergence.window=0",  # all 300 iterations (plateau stop now)
    "fit_appearance.map_size=128",  # procedural maps at 128² while fitting (64² now)
    "fit_appearance._uses_.texture.size=256",  # render crops described at 256 px, as photo crops (128 now)
    "renderer.mitsuba.freeze=false",  # path-traced renders traced in Python every iteration (replayed now)
]
"""Overrides that bring back the settings the defaults replaced (issue 20)."""
WIDTH_KEYS = (
    "room_fit.render_width",
    "retrieval.silhouette.render_width",
    "place_objects.render_width",
    "fit_objects.render_width",
    "fit_appearance.render_width",
)
SHORT_FITS = [
    "room_fit.iterations=20",
    "fit_objects.iterations=20",
    "fit_objects.convergence.window=0",
    "fit_appearance.iterations=10",
]


def timed_run(photo: Path, label: str, overrides: list[str]) -> dict:
    """One run from an empty cache: its metrics.json, plus ``wall`` (the process, start-up included)."""
    run_dir, cache = OUT / "runs" / label, OUT / "cache" / label
    shutil.rmtree(cache, ignore_errors=True)
    start = time.perf_counter()
    metrics = pipeline(photo, run_dir, overrides, {**os.environ, "PSDR_ROOM_CACHE_DIR": str(cache)})
    wall = time.perf_counter() - start
    shutil.rmtree(cache, ignore_errors=True)
    return {**metrics, "wall": wall, "run_dir": run_dir, "photo": photo}


def peak(m: dict) -> float:
    """A run's highest stage peak memory (MiB)."""
    return max(s.get("peak_rss_mb", 0.0) for s in m["stages"].values())


def quality(m: dict) -> dict[str, str]:
    """The figures that must not get worse, as printed."""
    fit = m.get("fit_appearance_log", {})
    artifacts = m["run_dir"] / "artifacts"
    placed = next(
        (
            artifacts / name / "placements.json"
            for name in ("placements_fit", "placements")
            if (artifacts / name).is_dir()
        ),
        None,
    )
    out = {"objects placed": str(len(json.loads(placed.read_text())["objects"])) if placed else "–"}
    for key, name in (("rmse", "RMSE"), ("ssim", "SSIM"), ("flip", "ꟻLIP")):
        if key in fit:
            out[f"{name} init→fit"] = f"{fit[key + '_init']:.4f}→{fit[key]:.4f}"
    truth_path = m["photo"].parent / "ground_truth.json"
    truth = json.loads(truth_path.read_text()) if truth_path.is_file() else {}
    if "room" in truth and "albedo" in truth:  # a synthetic room's (the example's holds its sensor's intrinsics)
        out["room IoU"] = f"{iou(truth, RoomBox.load(m['run_dir'] / 'artifacts' / 'room_box_fit')):.3f}"
        errors = ground_truth_errors(m["run_dir"], truth, fit.get("fitted_parts", []))
        if "albedo_err" in errors:
            out["albedo error"] = f"{errors['albedo_err']:.3f}"
    return out


def picks(m: dict) -> dict[int, list[str]]:
    """Each object segment's ranked candidate model ids in a run."""
    objects = json.loads((m["run_dir"] / "artifacts" / "object_candidates" / "candidates.json").read_text())["objects"]
    return {o["segment_id"]: [c["model_id"] for c in o["candidates"]] for o in objects}


def agreement(preview: dict, full: dict) -> str:
    """How the preview's picks compare with the full run's on the same photo."""
    ours, theirs = picks(preview), picks(full)
    both = [s for s in theirs if s in ours and theirs[s]]
    first = sum(bool(ours[s]) and ours[s][0] == theirs[s][0] for s in both)
    listed = sum(theirs[s][0] in ours[s] for s in both)
    return (
        f"first pick as the full run's for {first}/{len(both)} objects, the full run's first pick in the "
        f"preview's candidates for {listed}/{len(both)}"
    )


def side_by_side(name: str, old: dict, new: dict) -> None:
    print(f"\n### {name}\n")
    print("| stage | previous s | now s | now peak RSS MiB |")
    print("|---|---|---|---|")
    for stage, s in new["stages"].items():
        before = old["stages"].get(stage, {}).get("compute_seconds", float("nan"))
        print(f"| {stage} | {before:.1f} | {s['compute_seconds']:.1f} | {s.get('peak_rss_mb', 0):.0f} |")
    old_total, new_total = old["total_seconds"], new["total_seconds"]
    print(
        f"| **stages** | **{old_total:.1f}** | **{new_total:.1f}** ({old_total / new_total:.2f}×) | {peak(new):.0f} |"
    )
    print(
        f"| process wall (start-up included) | {old['wall']:.1f} | {new['wall']:.1f} "
        f"({old['wall'] / new['wall']:.2f}×) | |"
    )
    for (key, before), after in zip(quality(old).items(), quality(new).values()):
        print(f"| {key} | {before} | {after} | |")


def synth_scene(seed: int, objects: int | None = None) -> Path:
    """A synthetic room's photo (rendered once, kept under the benchmark's folder)."""
    return synth_photo(OUT / "scenes", seed, dict(os.environ), objects)


def scaling_table(title: str, column: str, runs: dict[str, dict]) -> None:
    print(f"\n### {title}\n")
    stages = list(next(iter(runs.values()))["stages"])
    print(f"| {column} | " + " | ".join(stages) + " | stages | peak RSS MiB |")
    print("|---|" + "---|" * (len(stages) + 2))
    for label, m in runs.items():
        cells = [f"{m['stages'][s]['compute_seconds']:.1f}" for s in stages]
        print(f"| {label} | " + " | ".join(cells) + f" | {m['total_seconds']:.1f} | {peak(m):.0f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1", help="the synthetic rooms of the side-by-side table ('': none)")
    parser.add_argument(
        "--old",
        action="append",
        metavar="KEY=VALUE",
        help="the previous defaults as overrides (default: the settings issue 20 replaced)",
    )
    parser.add_argument("--no-scaling", action="store_true", help="only the side-by-side table and the preview")
    parser.add_argument("--objects", default="2,4,8,16")
    parser.add_argument("--widths", default="160,320,640")
    args = parser.parse_args()
    old_overrides = args.old or PREVIOUS
    OUT.mkdir(parents=True, exist_ok=True)
    print(f"previous defaults: {' '.join(old_overrides)}")
    scenes = [("example (NYU basement)", EXAMPLE)] + [
        (f"synthetic room {s}", synth_scene(int(s))) for s in args.seeds.split(",") if s
    ]
    runs = {}
    for name, photo in scenes:
        label = photo.parent.name
        runs[photo] = new = timed_run(photo, f"{label}_now", [])
        old = timed_run(photo, f"{label}_previous", old_overrides)
        side_by_side(name, old, new)
    preview = timed_run(EXAMPLE, "preview", ["+preset=preview"])
    print(
        f"\npreview (+preset=preview, until place_objects) on the example: stages {preview['total_seconds']:.1f} s, "
        f"process wall {preview['wall']:.1f} s, {quality(preview)['objects placed']} objects, "
        f"peak RSS {peak(preview):.0f} MiB; {agreement(preview, runs[EXAMPLE])}"
    )
    if args.no_scaling:
        return
    by_objects = {}
    for count in (int(n) for n in args.objects.split(",")):
        photo = synth_scene(0, count)
        m = timed_run(photo, f"objects_{count}", SHORT_FITS)
        placed = quality(m)["objects placed"]
        by_objects[f"{count} asked, {placed} placed"] = m
    scaling_table(
        "time vs objects (synthetic room 0; fits cut to " + ", ".join(SHORT_FITS) + ")", "objects", by_objects
    )
    by_width = {}
    for width in (int(w) for w in args.widths.split(",")):
        by_width[f"{width} px"] = timed_run(
            EXAMPLE, f"width_{width}", [f"{k}={width}" for k in WIDTH_KEYS] + SHORT_FITS
        )
    scaling_table("time vs working resolution (the example; fits cut as above)", "render_width", by_width)


if __name__ == "__main__":
    main()
