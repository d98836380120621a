"""``depth=file``: depth read from a file beside the photo (a sensor's depth, or any estimate a user saved).

Conventions: 16-bit PNG in units of 1/scale metres (NYU and SUN RGB-D ``scale=1000``, TUM ``5000``), the
SUN RGB-D bit-rotated PNG (``encoding=sun``), float EXR or NPY. Encoding and scale come from the config,
else from ``<photo stem>.depth.json`` (``{"encoding": "png16", "scale": 1000}``), else the defaults.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting
from psdr_room_core.libraries.sidecar_depth import (
    DEPTH_ENCODINGS,
    DEPTH_SUFFIXES,
    SidecarError,
    find_depth_sidecar,
    read_depth,
    read_depth_options,
)
from psdr_room_core.method.artifacts import Camera, DepthMap, Image, Panoptic


class FileDepth:
    """Depth from ``<photo stem>.depth.png|.exr|.npy`` (or ``path``), resized to the working image."""

    def __init__(self, path: str | None = None, encoding: str = "auto", scale: float | None = None) -> None:
        self.path = Path(path).expanduser() if path else None
        self.encoding = encoding
        self.scale = scale

    def _locate(self, photo: Path) -> Path:
        found = self.path or find_depth_sidecar(photo)
        if found is None:
            names = " or ".join(photo.stem + s for s in DEPTH_SUFFIXES)
            raise PsdrRoomError(
                f"{photo}: no depth file beside it ({names}); add one, set depth.file.path=FILE, "
                "or choose another depth implementation (psdr-room-plugins lists them)"
            )
        return found

    def external_files(self, photo: Path) -> list[Path]:
        depth = self.path or find_depth_sidecar(photo)
        return [] if depth is None else [depth, depth.with_suffix(".json")]

    def unavailable(self, photo: Path) -> str | None:
        if self.path is not None:
            return None if self.path.is_file() else f"{self.path} does not exist"
        found = find_depth_sidecar(photo)
        return (
            None if found is not None else f"no {' / '.join(photo.stem + s for s in DEPTH_SUFFIXES)} beside the photo"
        )

    def estimate(self, image: Image, camera: Camera, panoptic: Panoptic, photo: Path) -> DepthMap:
        path = self._locate(photo)
        try:
            options = read_depth_options(path)
            if self.encoding != "auto":
                options["encoding"] = self.encoding
            if self.scale is not None:
                options["scale"] = float(self.scale)
            depth, valid = read_depth(path, **options)
        except SidecarError as exc:
            raise PsdrRoomError(str(exc)) from None
        if abs(depth.shape[1] / depth.shape[0] - image.width / image.height) > 0.01:
            raise PsdrRoomError(
                f"{path}: depth is {depth.shape[1]}x{depth.shape[0]} but the photo is {image.original_size[0]}x"
                f"{image.original_size[1]}; the depth map must be aligned with the photo (same aspect ratio)"
            )
        size = (image.width, image.height)
        depth = cv2.resize(depth, size, interpolation=cv2.INTER_NEAREST)
        valid = cv2.resize(valid.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
        return DepthMap(depth=depth, valid=valid, metric=path.suffix.lower() == ".png", source=str(path))


@dataclass
class FileDepthSettings:
    """``depth=file``: where the depth file is and how its values are encoded."""

    path: str | None = setting(doc="The depth file; null: <photo stem>.depth.png|.exr|.npy beside the photo.")
    encoding: str = setting(
        choices=("auto", *DEPTH_ENCODINGS),
        doc='png16 | sun | exr | npy; auto: by the file\'s suffix, or "encoding" in <stem>.depth.json.',
    )
    scale: float | None = setting(
        gt=0, doc="png16: units per metre (NYU/SUN 1000, TUM 5000); null: <stem>.depth.json's, else 1000."
    )


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("depth", "file", FileDepth, params=FileDepthSettings, reads_files=True)


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import DepthEstimator

    _FileDepth_is_a_depth: type[DepthEstimator] = FileDepth
