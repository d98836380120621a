"""Tests of the vanishing-point FoV estimator on synthetic box-room renders."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from boxroom import checker_floor, render_box_room
from psdr_room_core.engine import shipped
from psdr_room_core.libraries.vanishing_points import VanishingPointParams, estimate_camera
from psdr_room_core.method.artifacts import Camera

PARAMS = shipped.settings(VanishingPointParams, "fov.vanishing_points")

# (vertical FoV, yaw, pitch, roll) in degrees
VIEWS = [(45.0, 20.0, -5.0, 2.0), (60.0, -25.0, 5.0, -3.0), (75.0, 40.0, -10.0, 1.0)]


@cache
def _render(vfov: float, yaw: float, pitch: float, roll: float) -> np.ndarray:
    return render_box_room(vfov, width=320, height=240, yaw_deg=yaw, pitch_deg=pitch, roll_deg=roll)


@pytest.mark.parametrize("vfov, yaw, pitch, roll", VIEWS)
def test_recovers_vertical_fov(vfov: float, yaw: float, pitch: float, roll: float) -> None:
    result = estimate_camera(_render(vfov, yaw, pitch, roll), PARAMS)
    assert result.method != "fallback"
    assert abs(result.vfov_deg - vfov) < 2.0
    assert result.focal_px == pytest.approx(240 / (2 * math.tan(math.radians(result.vfov_deg) / 2)))
    assert (result.cx, result.cy) == (159.5, 119.5)
    assert 0.0 < result.confidence <= 1.0
    assert len(result.vanishing_points) == 3


@pytest.mark.parametrize("tile, pitch", [(1.0, 45.0), (0.7, 55.0), (0.8, 50.0)])
def test_a_floor_of_big_tiles_seen_from_above_gives_the_fov(tile: float, pitch: float) -> None:
    """Six to thirteen long tile edges and no vertical line (the synthetic floor-only case, a phone photo of a
    tiled floor): enough for the two floor vanishing points and the focal, not a fallback. Judged over eight
    draws of the sensor noise, since which few edges the detector keeps turns on single pixels."""
    results = [estimate_camera(checker_floor(40.0, pitch, tile, noise_seed=seed), PARAMS) for seed in range(8)]
    assert all(r.n_segments < 15 for r in results)
    assert sum(r.method != "fallback" for r in results) >= 7
    assert np.median([abs(r.vfov_deg - 40.0) for r in results]) < 3.0


def test_ignores_uniform_white_border() -> None:
    vfov, yaw, pitch, roll = VIEWS[1]
    framed = np.ones((240 + 16, 320 + 16, 3), dtype=np.float32)
    framed[8:-8, 8:-8] = _render(vfov, yaw, pitch, roll)
    result = estimate_camera(framed, PARAMS)
    # same scene, but the focal now refers to a 256 px tall image
    expected = math.degrees(2 * math.atan(256 / 240 * math.tan(math.radians(vfov) / 2)))
    assert abs(result.vfov_deg - expected) < 2.0


def test_featureless_image_falls_back() -> None:
    params = replace(PARAMS, fallback_vfov_deg=52.0)
    rng = np.random.default_rng(1)
    flat = np.clip(0.5 + rng.normal(0.0, 0.01, (240, 320, 3)), 0.0, 1.0).astype(np.float32)
    result = estimate_camera(flat, params)
    assert result.method == "fallback"
    assert result.vfov_deg == 52.0
    assert result.confidence == 0.0
    assert result.vanishing_points == []


def test_deterministic_for_a_seed() -> None:
    image = _render(*VIEWS[0])
    params = replace(PARAMS, seed=3)
    assert estimate_camera(image, params) == estimate_camera(image, params)


def test_vanishing_points_are_a_field_of_the_camera(tmp_path: Path) -> None:
    """``fov=vanishing_points`` hands the layout its vanishing points as a typed field that survives the cache,
    and a camera.json written when they travelled in ``extra`` loads into that field."""
    vps = [(0.6, 0.0, 0.8), (0.0, 1.0, 0.0)]
    camera = Camera.from_vfov(320, 240, 55.0, vanishing_points=vps, extra={"segments": 12})
    camera.save(tmp_path)
    assert Camera.load(tmp_path) == camera
    data = json.loads((tmp_path / "camera.json").read_text())
    data["extra"]["vanishing_points"] = [list(v) for v in data.pop("vanishing_points")]
    (tmp_path / "camera.json").write_text(json.dumps(data))
    assert Camera.load(tmp_path) == camera
