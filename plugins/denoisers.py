"""``denoiser=oidn`` (Intel Open Image Denoise, the default) and ``denoiser=none`` (renders as they are).

A denoiser cleans finished renders only: the final and initial renders of ``fit_appearance`` (its pictures
and metrics), the report's and ``psdr-room-edit``'s images. Gradients never flow through it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import NoSettings, setting

log = logging.getLogger(__name__)

QUALITIES = ("high", "balanced", "fast")


class OidnDenoiser:
    """OIDN's ``RT`` filter on an HDR linear render, with the render's albedo and normal as guides (OIDN
    prefilters them, so a few samples per pixel of guides do). ``pyoidn`` runs on the CPU with its weights
    inside the wheel; when it cannot load, one logged line and the noisy image."""

    def __init__(self, quality: str = "high") -> None:
        self.quality = quality
        self._module: Any = None
        self._failure: str | None = None

    def _load(self) -> Any:
        if self._module is None and self._failure is None:
            try:
                import pyoidn
            except Exception as exc:  # ImportError, or OSError from its shared library
                self._failure = f"pyoidn could not load ({type(exc).__name__}: {exc})"
                log.warning("denoiser=oidn: %s; renders stay noisy (scripts/setup.sh installs it)", self._failure)
            else:
                self._module = pyoidn
        return self._module

    def describe(self) -> str:
        module = self._load()
        if module is None:
            return f"none: {self._failure}"
        return f"oidn {_distribution_version('pyoidn')} ({self.quality})"

    def denoise(
        self, rgb: np.ndarray, albedo: np.ndarray | None = None, normal: np.ndarray | None = None
    ) -> np.ndarray:
        """``rgb`` without its noise (float32 [H,W,3], linear, any non-negative range)."""
        module = self._load()
        colour = np.ascontiguousarray(np.maximum(rgb, 0.0), dtype=np.float32)
        if module is None:
            return colour
        guides = {}
        if albedo is not None:
            guides["albedo"] = np.ascontiguousarray(np.clip(albedo, 0.0, 1.0), dtype=np.float32)
            if normal is not None:  # OIDN takes a normal only beside an albedo
                guides["normal"] = np.ascontiguousarray(np.clip(normal, -1.0, 1.0), dtype=np.float32)
        return np.asarray(module.denoise(colour, hdr=True, quality=self.quality, **guides), dtype=np.float32)


@dataclass
class OidnSettings:
    """``denoiser=oidn``: Open Image Denoise's filter."""

    quality: str = setting(choices=QUALITIES, doc="The filter's quality: high (slowest, best), balanced or fast.")


class NoDenoiser:
    """Renders as they come out of the path tracer (for ablations and noise measurements)."""

    def describe(self) -> str:
        return "none"

    def denoise(
        self, rgb: np.ndarray, albedo: np.ndarray | None = None, normal: np.ndarray | None = None
    ) -> np.ndarray:
        return np.asarray(rgb, dtype=np.float32)


def _distribution_version(name: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return "?"


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("denoiser", "oidn", OidnDenoiser, params=OidnSettings, reads_files=False)
    registry.add_implementation("denoiser", "none", NoDenoiser, params=NoSettings, reads_files=False)


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Denoiser

    _NoDenoiser_is_a_denoiser: type[Denoiser] = NoDenoiser
    _OidnDenoiser_is_a_denoiser: type[Denoiser] = OidnDenoiser
