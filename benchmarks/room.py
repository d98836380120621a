"""Room-stage benchmark on synthetic rooms with exact answers (issue: renderer + room stage).

For each scene (default: 10 ``random`` seeds, plus one of each hard case), runs the pipeline up to
``room_fit`` with the default implementations (the FoV is estimated, not given; the depth sidecar has a
smooth 5% error and blurred edges, as an estimator's would, unless ``--depth-noise 0``) and prints the FoV error,
the room box 3D IoU after ``room_init`` and after ``room_fit``, the per-iteration time of ``room_fit``
(first iteration, with JIT compilation, apart from the steady state), the total stage time, and where the
floor came from (``floor`` points, or what ``room_init`` guessed it from when none were in view). ``--bare``
copies each photo alone into a folder, so the offline segmentation and depth see what a new user's photo gives;
``--until export_scene`` runs every stage (a photo that shows little of a room must still give a scene), with the
same IoU columns.

    python benchmarks/room.py [--scenes 10] [--data DIR] [--no-hard | --cases CASE...] [--bare] [--until STAGE]
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import statistics
import tempfile
from pathlib import Path

import numpy as np

from psdr_room_core.engine.cli import compose_config
from psdr_room_core.engine.run import execute
from psdr_room_core.libraries.synth import write_scene
from psdr_room_core.libraries.synth.scene import HARD_CASES, generate
from psdr_room_core.method.artifacts import RoomBox
from psdr_room_core.method.stages.room import room_iou


def iou(truth: dict, box: RoomBox) -> float:
    """3D IoU with the true box, compared in the true camera's frame (see ``room_iou``)."""
    gt = truth["room"]
    reference = RoomBox(
        camera_to_world=np.asarray(truth["camera_to_world"]),
        center=np.array(gt["center"]),
        half_size=np.array(gt["half_size"]),
        yaw=gt["yaw"],
    )
    return room_iou(reference, box)


def evaluate(
    scene: Path,
    run_dir: Path,
    overrides: list[str],
    true_fov: bool = False,
    bare: bool = False,
    until: str = "room_fit",
) -> dict:
    """Run one scene up to ``until`` (at least room_fit; ``bare``: its photo alone, without the depth and
    segmentation beside it); return its row of the table."""
    truth = json.loads((scene / "ground_truth.json").read_text())
    if true_fov:  # isolate the room stage from the FoV estimate
        overrides = ["fov=fixed", f"fov.fixed.vfov_deg={truth['vfov_deg']}", *overrides]
    photo = scene / "photo.png"
    if bare:
        photo = run_dir.parent / "bare" / scene.name / "photo.png"
        photo.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(scene / "photo.png", photo)
    record = execute(compose_config([f"image={photo}", f"run.until={until}", *overrides]), run_dir)
    camera = record.artifacts["camera"]
    timings = next(r.timings for r in record.stages if r.name == "room_fit")
    return {
        "scene": scene.name,
        "fov_error": camera.vfov_deg - truth["vfov_deg"],
        "fov_error_fit": record.artifacts["camera_fit"].vfov_deg - truth["vfov_deg"],
        "iou_init": iou(truth, record.artifacts["room_box"]),
        "iou_fit": iou(truth, record.artifacts["room_box_fit"]),
        "first_it": timings["first_iteration_seconds"],
        "it": timings["steady_iteration_seconds"],
        "stages": sum(r.seconds for r in record.stages),
        "floor": record.artifacts["room_box"].extra.get("floor_source", "floor"),
    }


def print_table(rows: list[dict], title: str) -> None:
    print(f"\n{title}")
    print(
        f"{'scene':<28}{'FoV err':>9}{'fitted':>8}{'IoU init':>10}{'IoU fit':>9}{'1st it (s)':>12}{'it (s)':>8}"
        f"{'stages (s)':>12}  floor from"
    )
    for r in rows:
        print(
            f"{r['scene']:<28}{r['fov_error']:>+9.2f}{r['fov_error_fit']:>+8.2f}{r['iou_init']:>10.3f}{r['iou_fit']:>9.3f}"
            f"{r['first_it']:>12.2f}{r['it']:>8.3f}{r['stages']:>12.1f}  {r['floor']}"
        )
    if len(rows) > 1:
        mean = {k: statistics.fmean(r[k] for r in rows) for k in ("iou_init", "iou_fit", "it", "stages")}
        fov = statistics.median(abs(r["fov_error"]) for r in rows)
        fov_fit = statistics.median(abs(r["fov_error_fit"]) for r in rows)
        print(
            f"{'mean (FoV: median |err|)':<28}{fov:>9.2f}{fov_fit:>8.2f}{mean['iou_init']:>10.3f}{mean['iou_fit']:>9.3f}"
            f"{'':>12}{mean['it']:>8.3f}{mean['stages']:>12.1f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenes", type=int, default=10, help="random scenes, seeds 0..N-1")
    parser.add_argument("--data", type=Path, help="keep the rendered scenes here (reused when present)")
    parser.add_argument("--no-hard", action="store_true", help="skip the hard cases")
    parser.add_argument(
        "--cases",
        nargs="+",
        choices=HARD_CASES,
        default=list(HARD_CASES),
        metavar="CASE",
        help=f"the hard cases to run (default: all of {', '.join(HARD_CASES)})",
    )
    parser.add_argument(
        "--width", type=int, default=640, help="photo width (height = 3/4); real photos are at least 640"
    )
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument(
        "--depth-noise",
        type=float,
        default=0.05,
        help="relative error of the depth given to the pipeline, as from a depth estimator (0: exact)",
    )
    parser.add_argument("--true-fov", action="store_true", help="give the pipeline the true FoV (fov=fixed)")
    parser.add_argument("--bare", action="store_true", help="each photo alone: offline segmentation and depth")
    parser.add_argument("--until", default="room_fit", help="the last stage of each run (export_scene: all of them)")
    parser.add_argument("overrides", nargs="*", help="config overrides for every run, e.g. room_fit.iterations=50")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = args.data or Path(tmp) / "scenes"
        cases = [("random", s) for s in range(args.scenes)] + ([] if args.no_hard else [(c, 0) for c in args.cases])
        rows: dict[str, list[dict]] = {"random": [], "hard": []}
        for case, seed in cases:
            scene = data / f"scene_{case}_{seed:04d}_noise{args.depth_noise:g}"
            if not (scene / "ground_truth.json").is_file():
                width = args.width
                write_scene(generate(seed, case, width, round(width * 3 / 4)), scene, args.spp, args.depth_noise)
            row = evaluate(
                scene,
                Path(tmp) / "runs" / scene.name,
                [f"cache_dir={Path(tmp) / 'cache'}", *args.overrides],
                args.true_fov,
                args.bare,
                args.until,
            )
            rows["random" if case == "random" else "hard"].append(row)
            print(f"  {scene.name}: IoU {row['iou_init']:.3f} -> {row['iou_fit']:.3f}", flush=True)
    print_table(
        rows["random"], f"{args.scenes} random synthetic rooms ({args.width}x{round(args.width * 3 / 4)} photos)"
    )
    if rows["hard"]:
        print_table(rows["hard"], "hard cases")
    if rows["random"] and not math.isnan(rows["random"][0]["iou_fit"]):
        better = sum(r["iou_fit"] > r["iou_init"] for r in rows["random"])
        print(f"\nroom_fit improved the IoU on {better}/{len(rows['random'])} random scenes")


if __name__ == "__main__":
    main()
