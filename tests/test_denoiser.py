"""The ``denoiser`` capability (OIDN and none, the logged fallback without the package) and the ꟻLIP metric."""

from __future__ import annotations

import logging
import sys

import cv2
import numpy as np
import pytest

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.engine.settings import check_settings
from psdr_room_core.method.image_metrics import flip
from psdr_room_plugins.denoisers import NoDenoiser, OidnDenoiser, OidnSettings


def _noisy_ramp(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A smooth linear image, the same with Monte-Carlo-like noise (few samples of an exponential), its albedo."""
    y, x = np.mgrid[0:96, 0:128].astype(np.float32)
    clean = np.stack([0.2 + 0.5 * x / 128, 0.3 + 0.3 * y / 96, np.full_like(x, 0.4)], axis=-1)
    rng = np.random.default_rng(seed)
    noisy = clean * rng.exponential(1.0, size=(96, 128, 4, 1)).mean(axis=2).astype(np.float32)
    return clean, noisy, np.full_like(clean, 0.5)


def test_oidn_removes_noise_from_a_smooth_image() -> None:
    clean, noisy, albedo = _noisy_ramp()
    out = OidnDenoiser().denoise(noisy, albedo)
    assert out.shape == noisy.shape and out.dtype == np.float32
    assert np.abs(out - clean).mean() < 0.3 * np.abs(noisy - clean).mean()
    assert OidnDenoiser().describe().startswith("oidn ")


def test_oidn_without_its_package_logs_once_and_keeps_the_render(monkeypatch, caplog) -> None:
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # `import pyoidn` raises ImportError
    denoiser = OidnDenoiser()
    _, noisy, albedo = _noisy_ramp()
    with caplog.at_level(logging.WARNING):
        first, second = denoiser.denoise(noisy, albedo), denoiser.denoise(noisy)
    assert np.array_equal(first, noisy) and np.array_equal(second, noisy)
    assert len([r for r in caplog.records if "pyoidn could not load" in r.getMessage()]) == 1
    assert denoiser.describe().startswith("none: pyoidn could not load")


def test_none_and_registration() -> None:
    _, noisy, _ = _noisy_ramp()
    assert np.array_equal(NoDenoiser().denoise(noisy), noisy)
    registry = plugin_system().registry
    assert registry.implementation("denoiser", "oidn").factory is OidnDenoiser
    assert registry.implementation("denoiser", "none").factory is NoDenoiser
    with pytest.raises(PsdrRoomError, match="^denoiser.oidn.quality=best is not one of the choices"):
        check_settings(OidnSettings, {"quality": "best"}, "denoiser.oidn")


def test_flip_orders_known_pairs() -> None:
    rng = np.random.default_rng(1)
    y, x = np.mgrid[0:120, 0:160].astype(np.float32)
    image = np.stack([x / 160, y / 120, 0.5 + 0.4 * np.sin(x / 7)], axis=-1).astype(np.float32)
    slight = np.clip(image + rng.normal(0, 0.01, image.shape), 0, 1)
    strong = np.clip(image + rng.normal(0, 0.1, image.shape), 0, 1)
    blurred = cv2.GaussianBlur(image, (0, 0), 3)
    assert flip(image, image) == pytest.approx(0.0, abs=1e-6)
    assert 0 < flip(slight, image) < flip(strong, image) < flip(1 - image, image) <= 1
    assert flip(blurred, image) > flip(slight, image)
