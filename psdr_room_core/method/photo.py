"""Reading a user's photo: any of JPEG/PNG/TIFF/WebP, 8 or 16 bit, gray/RGB/RGBA, EXIF-oriented."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import PIL.Image

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.inputs import require_file

FORMATS = ("JPEG", "PNG", "TIFF", "WEBP", "MPO")
"""Formats accepted (MPO: the multi-picture JPEG some phones write)."""

MIN_SIDE = 64
"""Photos (and working images) with a shorter side than this hold too little to reconstruct a room from."""

_EXIF_ORIENTATION = 0x0112


def _orient(array: np.ndarray, orientation: int) -> np.ndarray:
    """Apply an EXIF orientation (1-8) so the array is upright."""
    ops = {
        2: lambda a: a[:, ::-1],
        3: lambda a: a[::-1, ::-1],
        4: lambda a: a[::-1],
        5: lambda a: np.swapaxes(a, 0, 1),
        6: lambda a: np.swapaxes(a, 0, 1)[:, ::-1],
        7: lambda a: np.swapaxes(a, 0, 1)[::-1, ::-1],
        8: lambda a: np.swapaxes(a, 0, 1)[::-1],
    }
    return np.ascontiguousarray(ops[orientation](array)) if orientation in ops else array


def _to_rgb_float(data: np.ndarray) -> np.ndarray:
    """OpenCV-decoded pixels (BGR/BGRA/gray, uint8/uint16/float) → float32 RGB in [0, 1]."""
    if data.dtype == np.uint8:
        data = data.astype(np.float32) / 255.0
    elif data.dtype == np.uint16:
        data = data.astype(np.float32) / 65535.0
    else:
        data = np.clip(np.nan_to_num(data.astype(np.float32)), 0.0, 1.0)
    if data.ndim == 2:
        data = data[..., None]
    channels = data.shape[2]
    if channels == 1:
        return np.repeat(data, 3, axis=2)
    if channels == 2:  # gray + alpha
        gray, alpha = data[..., :1], data[..., 1:2]
        return np.repeat(gray * alpha + (1.0 - alpha), 3, axis=2)
    rgb = data[..., 2::-1]
    if channels == 4:  # composite over white: transparent pixels carry no colour
        alpha = data[..., 3:4]
        rgb = rgb * alpha + (1.0 - alpha)
    return np.ascontiguousarray(rgb, dtype=np.float32)


def read_photo(path: Path, max_pixels: int) -> np.ndarray:
    """Read ``path`` as upright float32 RGB in [0, 1] at full resolution.

    Raises :class:`PsdrRoomError` with a one-line message for a missing file, a non-image or
    unsupported format, a truncated file, or more than ``max_pixels`` pixels.
    """
    require_file(path)
    PIL.Image.MAX_IMAGE_PIXELS = None  # the limit below replaces PIL's decompression-bomb guard
    try:
        with PIL.Image.open(path) as pil:
            if pil.format not in FORMATS:
                raise PsdrRoomError(
                    f"{path}: {pil.format} images are not supported; convert it to JPEG, PNG, TIFF or WebP"
                )
            width, height = pil.size
            if width * height > max_pixels:
                raise PsdrRoomError(
                    f"{path}: {width}x{height} is {width * height / 1e6:.1f} MP, over load_image.max_pixels="
                    f"{max_pixels}; downscale the photo or raise load_image.max_pixels"
                )
            if min(width, height) < MIN_SIDE:
                raise PsdrRoomError(
                    f"{path}: {width}x{height} is too small to reconstruct a room from; give a photo "
                    f"at least {MIN_SIDE} px on its short side"
                )
            orientation = int(pil.getexif().get(_EXIF_ORIENTATION, 1))
            pil.load()  # decodes fully: raises on truncated or corrupt data
    except PIL.UnidentifiedImageError:
        raise PsdrRoomError(
            f"{path}: not an image (or an unsupported one); give a JPEG, PNG, TIFF or WebP photo"
        ) from None
    except OSError as exc:
        raise PsdrRoomError(f"{path}: damaged or truncated image ({exc}); re-export or re-download the photo") from None
    data = cv2.imdecode(np.fromfile(path, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if data is None:
        raise PsdrRoomError(f"{path}: OpenCV cannot decode this {pil.format} file; re-save it as PNG or JPEG")
    rgb = _to_rgb_float(_orient(data, orientation))
    if float(np.ptp(rgb)) == 0.0:
        raise PsdrRoomError(f"{path}: every pixel has the same colour, there is no room to see; give a photo of a room")
    return rgb


def resize_to_working(rgb: np.ndarray, max_side: int) -> np.ndarray:
    """Downscale (area filter) so the long side is at most ``max_side``; never upscale."""
    if max_side < MIN_SIDE:
        raise PsdrRoomError(
            f"load_image.max_side={max_side}: the working image needs at least {MIN_SIDE} px; "
            "set it to 320 or more (default 800)"
        )
    height, width = rgb.shape[:2]
    scale = max_side / max(height, width)
    if scale >= 1.0:
        return rgb
    size = (max(1, round(width * scale)), max(1, round(height * scale)))
    return cv2.resize(rgb, size, interpolation=cv2.INTER_AREA)
