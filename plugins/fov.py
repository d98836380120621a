"""``fov`` implementations: ``vanishing_points`` (offline estimate from the photo's lines) and ``fixed``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting
from psdr_room_core.libraries.vanishing_points import VanishingPointParams
from psdr_room_core.method.artifacts import Camera, Image


class VanishingPointsFov:
    """Focal length from orthogonal vanishing points of the photo's line segments (fallback: a fixed FoV)."""

    def __init__(self, **params: Any) -> None:
        self.params = VanishingPointParams(**params)

    def estimate(self, image: Image, photo: Path) -> Camera:
        from psdr_room_core.libraries.vanishing_points import estimate_camera

        result = estimate_camera(image.rgb, self.params)
        return Camera(
            width=image.width,
            height=image.height,
            fx=result.focal_px,
            fy=result.focal_px,
            cx=result.cx,
            cy=result.cy,
            method=f"vanishing_points/{result.method}",
            confidence=result.confidence,
            vanishing_points=[(float(x), float(y), float(w)) for x, y, w in result.vanishing_points],
            extra={"segments": result.n_segments},
        )


@dataclass
class FixedFovSettings:
    """``fov=fixed``: the field of view."""

    vfov_deg: float = setting(
        gt=0,
        lt=180,
        doc="Vertical field of view, degrees; also fov=vanishing_points' fallback for photos with too few lines.",
    )


class FixedFov:
    """A fixed vertical field of view (square pixels, centred principal point)."""

    def __init__(self, vfov_deg: float) -> None:
        self.vfov_deg = float(vfov_deg)

    def estimate(self, image: Image, photo: Path) -> Camera:
        return Camera.from_vfov(image.width, image.height, self.vfov_deg, method="fixed")


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation(
        "fov", "vanishing_points", VanishingPointsFov, params=VanishingPointParams, reads_files=False
    )
    registry.add_implementation("fov", "fixed", FixedFov, params=FixedFovSettings, reads_files=False)


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import FovEstimator

    _FixedFov_is_a_fov: type[FovEstimator] = FixedFov
    _VanishingPointsFov_is_a_fov: type[FovEstimator] = VanishingPointsFov
