"""Readers for user-supplied depth files ("sidecars" next to a photo).

Encodings (``DEPTH_ENCODINGS``):

- ``png16``: single-channel uint16 PNG, depth = value / scale (NYU: scale 1000 = millimetres; TUM: 5000).
- ``sun``:   SUN RGB-D uint16 PNG, bits rotated right by 3, then / 1000 = metres.
- ``exr``:   OpenEXR, read with Mitsuba's ``Bitmap`` (any compression); channel Z, depth, D, distance, Y,
  R, ... in that order of preference, in the file's units.
- ``npy``:   2-D float NumPy array, in the file's units.

Zero, negative and non-finite values are invalid. A file is read only once its size, and the size its header
declares, are within :data:`MAX_SIDECAR_PIXELS`. Every problem raises :class:`SidecarError` with a one-line message
that names the file and says how to fix it.
"""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine.bounded import JsonLimits, load_json, size_text
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.libraries.bounded_npy import load_npy

__all__ = [
    "DEPTH_ENCODINGS",
    "DEPTH_SUFFIXES",
    "MAX_SIDECAR_PIXELS",
    "SidecarError",
    "find_depth_sidecar",
    "read_depth",
    "read_depth_options",
]

DEPTH_ENCODINGS = ("png16", "sun", "exr", "npy")
DEPTH_SUFFIXES = (".depth.png", ".depth.exr", ".depth.npy")
"""Sidecar names tried beside ``photo.jpg``: ``photo.depth.png``, ``photo.depth.exr``, ``photo.depth.npy``."""
MAX_SIDECAR_PIXELS = 100_000_000
"""The most pixels a depth map or segmentation may have: those of the largest photo ``load_image`` takes by
default."""
MAX_DEPTH_BYTES = MAX_SIDECAR_PIXELS * 8
"""The largest depth file read: :data:`MAX_SIDECAR_PIXELS` float64 values."""
OPTIONS_LIMITS = JsonLimits(max_bytes=1_000_000, max_string=1000)
"""What a depth file's ``.json`` of options (two keys) may hold."""


class SidecarError(ValueError):
    """A sidecar file is missing, unreadable or malformed; the message is one line: file, problem, fix."""

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split()))


# ----------------------------------------------------------------------------------------------- API
def find_depth_sidecar(photo: Path) -> Path | None:
    """Return ``<stem>.depth.png|.exr|.npy`` beside ``photo`` (first that exists), else None."""
    photo = Path(photo)
    for suffix in DEPTH_SUFFIXES:
        candidate = photo.with_name(photo.stem + suffix)
        if candidate.is_file():
            return candidate
    return None


def read_depth_options(depth_path: Path) -> dict:
    """Read the optional ``<name>.json`` beside a depth file (``photo.depth.png`` -> ``photo.depth.json``).

    Returns the keyword arguments for :func:`read_depth` it holds (``encoding``, ``scale``); ``{}`` if absent.
    """
    depth_path = Path(depth_path)
    meta_path = depth_path.with_suffix(".json")
    if not meta_path.is_file():
        return {}
    example = '{"encoding": "png16", "scale": 1000}'
    try:
        meta = load_json(meta_path, OPTIONS_LIMITS, f"write e.g. {example}")
    except PsdrRoomError as exc:
        raise SidecarError(str(exc)) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SidecarError(
            f'{meta_path}: not valid JSON ({exc}); write e.g. {{"encoding": "png16", "scale": 1000}}'
        ) from None
    if not isinstance(meta, dict):
        raise SidecarError(f'{meta_path}: expected a JSON object; write e.g. {{"encoding": "png16", "scale": 1000}}')
    unknown = sorted(set(meta) - {"encoding", "scale"})
    if unknown:
        raise SidecarError(f'{meta_path}: unknown key(s) {", ".join(unknown)}; only "encoding" and "scale" are read')
    options: dict = {}
    if "encoding" in meta:
        options["encoding"] = _check_encoding(meta["encoding"], meta_path)
    if "scale" in meta:
        options["scale"] = _check_scale(meta["scale"], meta_path)
    return options


def read_depth(path: Path, encoding: str = "auto", scale: float = 1000.0) -> tuple[np.ndarray, np.ndarray]:
    """Read a depth file.

    Returns ``(depth, valid)``: float32 HxW depth (metres for png16/sun; the file's own units for exr/npy,
    where ``scale`` is ignored) and a bool HxW mask of valid pixels (finite and > 0; invalid depth is 0).
    ``encoding="auto"`` picks by suffix: ``.png`` -> png16, ``.exr`` -> exr, ``.npy`` -> npy; SUN RGB-D
    files must be named explicitly (``encoding="sun"``).
    """
    path = Path(path)
    encoding = _check_encoding(encoding, path)
    if not path.exists():
        raise SidecarError(
            f"{path}: depth file not found; put the depth map there or name an existing file "
            f"(sidecars are looked up as <photo stem>{'|'.join(DEPTH_SUFFIXES)})"
        )
    if not path.is_file():
        raise SidecarError(f"{path}: is not a file; give the path of a depth map (.png, .exr or .npy)")
    if path.stat().st_size > MAX_DEPTH_BYTES:
        raise SidecarError(
            f"{path}: {size_text(path.stat().st_size)}, larger than a depth map of {MAX_SIDECAR_PIXELS:,} pixels; "
            "save the depth at the photo's size"
        )
    if encoding == "auto":
        encoding = _encoding_from_suffix(path)

    if encoding in ("png16", "sun"):
        raw = _read_png16(path, encoding)
        if encoding == "sun":
            raw = ((raw >> 3) | (raw << 13)).astype(np.uint16)  # rotate right by 3 bits
            depth = raw.astype(np.float32) / np.float32(1000.0)
        else:
            depth = raw.astype(np.float32) / np.float32(_check_scale(scale, path))
        valid = raw > 0
        hint = "a uint16 depth image that is not all zeros"
    elif encoding == "exr":
        depth = _read_exr(path)
        valid = np.isfinite(depth) & (depth > 0)
        hint = "positive finite depth values"
    else:  # npy
        depth = _read_npy(path)
        valid = np.isfinite(depth) & (depth > 0)
        hint = "positive finite depth values (invalid pixels as 0 or NaN)"

    if not valid.any():
        raise SidecarError(
            f"{path}: every depth value is invalid (0, negative or not finite); the file must hold {hint}"
        )
    depth = np.where(valid, depth, np.float32(0.0)).astype(np.float32, copy=False)
    return depth, valid


# ------------------------------------------------------------------------------------------ helpers
def _check_encoding(encoding: object, path: Path) -> str:
    allowed = ("auto",) + DEPTH_ENCODINGS
    if not isinstance(encoding, str) or encoding.lower() not in allowed:
        raise SidecarError(f"{path}: unknown depth encoding {encoding!r}; use one of {', '.join(allowed)}")
    return encoding.lower()


def _check_scale(scale: object, path: Path) -> float:
    try:
        value = float(scale)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        value = float("nan")
    if isinstance(scale, bool) or not math.isfinite(value) or value <= 0:
        raise SidecarError(
            f"{path}: depth scale must be a positive number (raw units per metre, e.g. 1000 for mm), got {scale!r}"
        )
    return value


def _encoding_from_suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix == ".png":
        return "png16"
    if suffix == ".exr":
        return "exr"
    if suffix == ".npy":
        return "npy"
    raise SidecarError(
        f"{path}: cannot tell the depth encoding from the suffix {suffix or '(none)'!r}; "
        f"save it as .png (uint16), .exr or .npy, or set the encoding ({', '.join(DEPTH_ENCODINGS)})"
    )


def _describe_image(img: np.ndarray) -> str:
    bits = {np.dtype(np.uint8): "8-bit", np.dtype(np.uint16): "16-bit", np.dtype(np.float32): "32-bit float"}.get(
        img.dtype, str(img.dtype)
    )
    channels = 1 if img.ndim == 2 else img.shape[2]
    kind = {1: "single-channel", 2: "gray+alpha", 3: "RGB", 4: "RGBA"}.get(channels, f"{channels}-channel")
    return f"{bits} {kind}"


def _check_pixels(path: Path, width: int, height: int) -> None:
    if width * height > MAX_SIDECAR_PIXELS:
        raise SidecarError(
            f"{path}: the header declares {width}x{height} pixels, over the {MAX_SIDECAR_PIXELS:,} a depth map may "
            "have; save the depth at the photo's size"
        )


def _read_png16(path: Path, encoding: str) -> np.ndarray:
    try:
        buf = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise SidecarError(f"{path}: cannot read the file ({exc.strerror or exc}); check its permissions") from None
    header = buf[:24].tobytes()
    if header[:8] == b"\x89PNG\r\n\x1a\n" and header[12:16] == b"IHDR":
        _check_pixels(path, *struct.unpack(">II", header[16:24]))
    img = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED) if buf.size else None
    if img is None:
        raise SidecarError(f"{path}: not a readable image; save depth as a 16-bit single-channel PNG")
    fix = (
        "keep the original SUN RGB-D depth PNG (uint16, bit-rotated)"
        if encoding == "sun"
        else "save depth as uint16 millimetres (depth.file.scale=1000) or with your own scale (TUM: 5000)"
    )
    # some tools write gray as 3 identical channels: accept that, refuse real colour
    if (
        img.ndim == 3
        and img.shape[2] > 1
        and img.dtype == np.uint16
        and all(np.array_equal(img[..., 0], img[..., c]) for c in range(1, min(img.shape[2], 3)))
    ):
        img = img[..., 0]
    if img.dtype != np.uint16 or img.ndim != 2:
        raise SidecarError(f"{path}: expected a 16-bit single-channel PNG, got {_describe_image(img)}; {fix}")
    return img


def _read_npy(path: Path) -> np.ndarray:
    fix = "save it with numpy.save(path, depth.astype('float32')) at the photo's size"
    try:
        arr = load_npy(path, MAX_DEPTH_BYTES, fix)
    except PsdrRoomError as exc:
        raise SidecarError(str(exc)) from None
    except (OSError, ValueError, EOFError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SidecarError(f"{path}: not a readable .npy array ({msg}); {fix}") from None
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[..., 0]
    if arr.ndim == 3 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 2:
        raise SidecarError(
            f"{path}: expected a 2-D HxW depth array, got shape {arr.shape}; save depth[:, :] as float32"
        )
    if not np.issubdtype(arr.dtype, np.floating):
        raise SidecarError(
            f"{path}: expected a float depth array, got {arr.dtype}; convert to float32 in your units "
            f"(e.g. depth_mm / 1000) or save integer depth as a 16-bit PNG"
        )
    return arr.astype(np.float32)


# ---------------------------------------------------------------------------------------- OpenEXR
_DEPTH_CHANNELS = ("z", "depth", "d", "distance", "y", "r", "v", "gray", "grey", "l")
"""EXR channel names that hold depth, preferred first; matched case-insensitively on the last part of
layered names (``ViewLayer.Depth.Z`` -> ``z``)."""


def _exr_size(path: Path) -> tuple[int, int] | None:
    """(width, height) of an OpenEXR file's ``dataWindow`` from its header (attributes: name, type, size, value);
    None when the header cannot be followed (the EXR reader then says what is wrong)."""
    with open(path, "rb") as file:
        header = file.read(1 << 16)
    if header[:4] != b"\x76\x2f\x31\x01":
        return None
    at = 8
    try:
        while header[at] != 0:
            name_end = header.index(b"\0", at)
            type_end = header.index(b"\0", name_end + 1)
            (size,) = struct.unpack_from("<i", header, type_end + 1)
            if header[at:name_end] == b"dataWindow" and size == 16:
                x0, y0, x1, y1 = struct.unpack_from("<4i", header, type_end + 5)
                return x1 - x0 + 1, y1 - y0 + 1
            at = type_end + 5 + size
    except (IndexError, ValueError, struct.error):
        return None
    return None


def _read_exr(path: Path) -> np.ndarray:
    import mitsuba as mi  # imported here: slow to load and only EXR needs it; Bitmap needs no variant

    size = _exr_size(path)
    if size is not None:
        _check_pixels(path, *size)
    try:
        bitmap = mi.Bitmap(str(path), mi.Bitmap.FileFormat.OpenEXR)
    except RuntimeError:
        raise SidecarError(
            f"{path}: damaged or not an OpenEXR file; re-export the depth as float EXR or .npy"
        ) from None
    names = [field.name for field in bitmap.struct_()]
    data = np.array(bitmap)
    if data.ndim == 3:
        data = data[..., _pick_channel(names, path)]
    return data.astype(np.float32)


def _pick_channel(names: list[str], path: Path) -> int:
    if len(names) == 1:
        return 0
    keys = [n.lower().rsplit(".", 1)[-1] for n in names]
    for wanted in _DEPTH_CHANNELS:
        if wanted in keys:
            return keys.index(wanted)
    raise SidecarError(
        f"{path}: cannot tell which EXR channel holds depth (channels: {', '.join(names)}); name it Z or depth, or save a single channel"
    )
