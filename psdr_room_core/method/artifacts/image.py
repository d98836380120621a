"""The photo and the camera: the working image and its pinhole intrinsics (§4.1)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .io import read_json, read_png, write_json, write_png


@dataclass
class Image:
    """The input photo at working resolution: float32 HxWx3 sRGB in [0, 1]."""

    kind: ClassVar[str] = "image"
    marker: ClassVar[str] = "image.json"
    rgb: np.ndarray
    source: str = ""
    """The photo's path as given by the user (a record, not an input)."""
    original_size: tuple[int, int] = (0, 0)
    """(width, height) of the photo before resizing, after EXIF orientation."""

    @property
    def height(self) -> int:
        return int(self.rgb.shape[0])

    @property
    def width(self) -> int:
        return int(self.rgb.shape[1])

    @property
    def photo_size(self) -> tuple[int, int]:
        """(width, height) of the photo as displayed (before resizing), in whose pixels sidecar files are given."""
        return self.original_size if all(self.original_size) else (self.width, self.height)

    def to_uint8(self) -> np.ndarray:
        return np.clip(np.rint(self.rgb * 255.0), 0, 255).astype(np.uint8)

    def save(self, directory: Path) -> None:
        write_png(directory / "image.png", np.clip(np.rint(self.rgb * 65535.0), 0, 65535).astype(np.uint16))
        write_json(directory / "image.json", {"source": self.source, "original_size": list(self.original_size)})

    @classmethod
    def load(cls, directory: Path) -> Image:
        data = read_png(directory / "image.png")
        scale = 65535.0 if data.dtype == np.uint16 else 255.0
        meta = read_json(directory / "image.json")
        rgb = (data.astype(np.float32) / scale)[..., :3]
        return cls(rgb=rgb, source=meta["source"], original_size=tuple(meta["original_size"]))


@dataclass
class Camera:
    """Pinhole intrinsics in pixels of the working image, with the estimate's provenance."""

    kind: ClassVar[str] = "camera"
    marker: ClassVar[str] = "camera.json"
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    method: str = ""
    """How the intrinsics were obtained (e.g. ``vanishing_points/orthogonal_triplet``, ``fixed``)."""
    confidence: float = 1.0
    vanishing_points: list[tuple[float, float, float]] = field(default_factory=list)
    """The image vanishing points of the room's axes the estimate found (two or three homogeneous unit-norm
    ``(x, y, w)`` in pixels, ``w = 0`` at infinity; empty when it looked for none): the Manhattan frame the
    ``layout`` segmentation fits its box in."""
    extra: dict[str, Any] = field(default_factory=dict)
    """Estimator details kept for inspection (segment counts, ...)."""

    @classmethod
    def from_vfov(cls, width: int, height: int, vfov_deg: float, **kwargs: Any) -> Camera:
        fy = 0.5 * height / math.tan(math.radians(vfov_deg) / 2.0)
        return cls(width=width, height=height, fx=fy, fy=fy, cx=width / 2.0, cy=height / 2.0, **kwargs)

    @property
    def vfov_deg(self) -> float:
        return math.degrees(2.0 * math.atan(0.5 * self.height / self.fy))

    def resized(self, width: int) -> Camera:
        """The camera for an image ``width`` pixels wide: the intrinsics scaled uniformly (square pixels stay
        square; the rounded height changes the vertical field of view by under half a pixel)."""
        s = width / self.width
        return Camera(
            width=width,
            height=max(1, round(self.height * s)),
            fx=self.fx * s,
            fy=self.fy * s,
            cx=self.cx * s,
            cy=self.cy * s,
            method=self.method,
        )

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def pixel_rays(self) -> np.ndarray:
        """(H, W, 3) camera-frame directions with unit z through the pixel centres (``u + 0.5``, ``v + 0.5``):
        a z-depth map times these is its back-projection."""
        u, v = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        return np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones_like(u)], axis=-1)

    def save(self, directory: Path) -> None:
        data = {k: v for k, v in asdict(self).items()}
        data["vfov_deg"] = self.vfov_deg
        write_json(directory / "camera.json", data)

    @classmethod
    def load(cls, directory: Path) -> Camera:
        data = read_json(directory / "camera.json")
        data.pop("vfov_deg", None)
        if "vanishing_points" in data.get("extra", {}):  # written before they were a field of their own
            data["vanishing_points"] = data["extra"].pop("vanishing_points")
        data["vanishing_points"] = [tuple(v) for v in data.get("vanishing_points", [])]
        return cls(**data)
