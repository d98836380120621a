"""Synthetic rooms with exact ground truth, the benchmark every stage is measured on (``psdr-room-synth``).

Each scene directory holds what the ``file`` implementations read beside a photo, plus the answers:

    photo.png                      path-traced with Mitsuba 3 (global illumination, area lights)
    photo.depth.png/.depth.json    z-depth, uint16 millimetres (scale 1000): exact, or estimator-like (--depth-noise)
    photo.panoptic.png/.json       COCO panoptic: floor, ceiling, one segment per wall, objects, lights
    ground_truth.json              intrinsics, vfov, camera pose, room box, objects (boxes), lights, seed, case,
                                   albedo (linear), exposure (photo = sRGB(exposure × radiance))
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.method import artifacts

from .raycast import raycast
from .render import render_photo
from .room import SyntheticRoom
from .scene import HARD_CASES, generate


def estimated_depth(depth: np.ndarray, noise: float, seed: int) -> np.ndarray:
    """Depth as an estimator gives it: smoothed across edges and with a smooth multiplicative error of
    relative standard deviation ``noise`` (mean 1, so the scale stays right); ``noise=0`` is the exact depth."""
    if noise <= 0:
        return depth
    rng = np.random.default_rng(seed)
    height, width = depth.shape
    field = cv2.resize(rng.normal(size=(4, 5)).astype(np.float32), (width, height), interpolation=cv2.INTER_CUBIC)
    field = (field - field.mean()) / max(float(field.std()), 1e-6)
    blurred = cv2.GaussianBlur(depth, (0, 0), sigmaX=width / 160)
    return (blurred * (1.0 + noise * field)).astype(np.float32)


def write_scene(room: SyntheticRoom, directory: Path, spp: int = 64, depth_noise: float = 0.0) -> Path:
    """Render ``room`` and write its photo, sidecars and ground truth into ``directory``; return the photo.

    ``depth_noise`` > 0 writes an estimator-like depth sidecar (:func:`estimated_depth`) instead of the exact one.
    """
    directory.mkdir(parents=True, exist_ok=True)
    depth, ids, segments = raycast(room)
    depth = estimated_depth(depth, depth_noise, room.seed)
    photo = directory / "photo.png"
    image, scale = render_photo(room, spp=spp)
    cv2.imwrite(str(photo), image[..., ::-1])
    cv2.imwrite(str(directory / "photo.depth.png"), np.clip(np.rint(depth * 1000.0), 0, 65535).astype(np.uint16))
    (directory / "photo.depth.json").write_text(json.dumps({"encoding": "png16", "scale": 1000.0}) + "\n")
    artifacts.write_coco_panoptic(directory / "photo.panoptic.png", directory / "photo.panoptic.json", ids, segments)
    (directory / "ground_truth.json").write_text(json.dumps({**room.to_json(), "exposure": scale}, indent=2) + "\n")
    return photo


def parse_seeds(text: str) -> list[int]:
    """``"0-9"`` → 0..9; ``"1,5,7"`` → those."""
    if "-" in text:
        start, end = text.split("-", 1)
        return list(range(int(start), int(end) + 1))
    return [int(s) for s in text.split(",")]


def main() -> None:
    """Entry point of ``psdr-room-synth``."""
    parser = argparse.ArgumentParser(description="Render synthetic rooms with exact ground truth.")
    parser.add_argument("--out", type=Path, required=True, help="directory for scene_<case>_<seed>/ folders")
    parser.add_argument("--seeds", default="0-9", help="e.g. 0-9 or 1,5,7")
    parser.add_argument("--case", default="random", choices=("random", *HARD_CASES))
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument(
        "--depth-noise",
        type=float,
        default=0.0,
        help="relative error of an estimator-like depth sidecar (0: exact depth)",
    )
    parser.add_argument("--objects", type=int, help="pieces of furniture (as many as fit; default: 3-5 at random)")
    args = parser.parse_args()
    for seed in parse_seeds(args.seeds):
        room = generate(seed, args.case, args.width, args.height, args.objects)
        name = f"scene_{args.case}_{seed:04d}" + (f"_{args.objects}objects" if args.objects is not None else "")
        photo = write_scene(room, args.out / name, args.spp, args.depth_noise)
        print(f"{photo}  vfov {room.vfov_deg:.1f}°  {len(room.furniture)} objects")
