"""Synthetic rooms with exact ground truth, the benchmark every stage is measured on.

A library: ``psdr-room-synth`` (:mod:`psdr_room_core.applications.synth`) writes them from the command line.

Each scene directory holds what the ``file`` implementations read beside a photo, plus the answers:

    photo.png                      path-traced with Mitsuba 3 (global illumination, area lights)
    photo.depth.png/.depth.json    z-depth, uint16 millimetres (scale 1000): exact, or estimator-like (--depth-noise)
    photo.panoptic.png/.json       COCO panoptic: floor, ceiling, one segment per wall, objects, lights
    ground_truth.json              intrinsics, vfov, camera pose, room box, objects (boxes), lights, seed, case,
                                   albedo (linear), exposure (photo = sRGB(exposure × radiance))
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.method import artifacts

from .raycast import raycast
from .render import render_photo
from .room import SyntheticRoom


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
