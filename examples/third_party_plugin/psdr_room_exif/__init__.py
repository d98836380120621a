"""psdr-room plugin: the vertical field of view from the photo's EXIF 35 mm-equivalent focal length."""

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import PIL.Image

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.settings import setting
from psdr_room_core.method.artifacts import Camera, Image

FOCAL_35MM = 0xA405  # EXIF FocalLengthIn35mmFilm, in the Exif sub-IFD
FULL_FRAME_DIAGONAL_MM = math.hypot(36.0, 24.0)


@dataclass
class ExifSettings:
    """Checked against ``fov.exif`` before any stage runs."""

    fallback_vfov_deg: float = setting(
        gt=0, lt=180, doc="Vertical field of view (degrees) of a photo without the EXIF tag."
    )


class ExifFov:
    """Focal length from EXIF FocalLengthIn35mmFilm; ``fallback_vfov_deg`` when the tag is missing."""

    def __init__(self, fallback_vfov_deg: float) -> None:
        self.fallback_vfov_deg = fallback_vfov_deg

    def external_files(self, photo: Path) -> list[Path]:
        return [photo]  # the EXIF tags are read from the photo itself

    def estimate(self, image: Image, photo: Path) -> Camera:
        with PIL.Image.open(photo) as pil:
            focal_35mm = pil.getexif().get_ifd(0x8769).get(FOCAL_35MM)
        if not focal_35mm:
            return Camera.from_vfov(
                image.width, image.height, self.fallback_vfov_deg, method="exif/fallback", confidence=0.0
            )
        focal_px = float(focal_35mm) / FULL_FRAME_DIAGONAL_MM * math.hypot(image.width, image.height)
        vfov = math.degrees(2 * math.atan(0.5 * image.height / focal_px))
        return Camera.from_vfov(image.width, image.height, vfov, method="exif")


@hookimpl
def register_implementations(registry):
    registry.add_implementation("fov", "exif", ExifFov, params=ExifSettings, reads_files=True)


@hookimpl
def conf_searchpath():
    return "pkg://psdr_room_exif"  # holds fov/exif.yaml


if TYPE_CHECKING:  # mypy checks ExifFov against the fov capability's protocol
    from psdr_room_core.method.capabilities import FovEstimator

    _ExifFov_is_a_fov: type[FovEstimator] = ExifFov
