"""Readers for user-supplied depth files ("sidecars" next to a photo).

Encodings (``DEPTH_ENCODINGS``):

- ``png16``: single-channel uint16 PNG, depth = value / scale (NYU: scale 1000 = millimetres; TUM: 5000).
- ``sun``:   SUN RGB-D uint16 PNG, bits rotated right by 3, then / 1000 = metres.
- ``exr``:   float OpenEXR (channel Z, depth, Y, R, ... in that order of preference), in the file's units.
- ``npy``:   2-D float NumPy array, in the file's units.

Zero, negative and non-finite values are invalid. Every problem raises :class:`SidecarError` with a
one-line message that names the file and says how to fix it.

EXR files with NONE, RLE, ZIPS or ZIP compression are decoded here (pure NumPy + zlib). Other codecs
(PIZ, PXR24, B44, DWA, tiled or multi-part files) go through OpenCV when it was built with OpenEXR,
else through Mitsuba's ``Bitmap`` when Mitsuba is installed.
"""

from __future__ import annotations

import json
import math
import os
import struct
import zlib
from pathlib import Path

import numpy as np

# OpenCV reads OPENCV_IO_ENABLE_OPENEXR the first time it decodes an EXR, so setting it here works even
# when cv2 was imported earlier, provided no EXR was decoded before. An explicit user value is kept.
os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
import cv2

__all__ = [
    "DEPTH_ENCODINGS",
    "DEPTH_SUFFIXES",
    "SidecarError",
    "find_depth_sidecar",
    "read_depth",
    "read_depth_options",
]

DEPTH_ENCODINGS = ("png16", "sun", "exr", "npy")
DEPTH_SUFFIXES = (".depth.png", ".depth.exr", ".depth.npy")
"""Sidecar names tried beside ``photo.jpg``: ``photo.depth.png``, ``photo.depth.exr``, ``photo.depth.npy``."""


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
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SidecarError(f"{meta_path}: not valid JSON ({exc}); write e.g. {{\"encoding\": \"png16\", \"scale\": 1000}}") from None
    if not isinstance(meta, dict):
        raise SidecarError(f"{meta_path}: expected a JSON object; write e.g. {{\"encoding\": \"png16\", \"scale\": 1000}}")
    unknown = sorted(set(meta) - {"encoding", "scale"})
    if unknown:
        raise SidecarError(f"{meta_path}: unknown key(s) {', '.join(unknown)}; only \"encoding\" and \"scale\" are read")
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
        raise SidecarError(f"{path}: every depth value is invalid (0, negative or not finite); the file must hold {hint}")
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
        raise SidecarError(f"{path}: depth scale must be a positive number (raw units per metre, e.g. 1000 for mm), got {scale!r}")
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


def _read_png16(path: Path, encoding: str) -> np.ndarray:
    try:
        buf = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise SidecarError(f"{path}: cannot read the file ({exc.strerror or exc}); check its permissions") from None
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
    try:
        arr = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SidecarError(f"{path}: not a readable .npy array ({msg}); save it with numpy.save(path, depth.astype('float32'))") from None
    if not isinstance(arr, np.ndarray):  # an .npz archive under a .npy name
        if hasattr(arr, "close"):
            arr.close()
        raise SidecarError(f"{path}: is an .npz archive, not a single array; save the depth with numpy.save")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[..., 0]
    if arr.ndim == 3 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 2:
        raise SidecarError(f"{path}: expected a 2-D HxW depth array, got shape {arr.shape}; save depth[:, :] as float32")
    if not np.issubdtype(arr.dtype, np.floating):
        raise SidecarError(
            f"{path}: expected a float depth array, got {arr.dtype}; convert to float32 in your units "
            f"(e.g. depth_mm / 1000) or save integer depth as a 16-bit PNG"
        )
    return arr.astype(np.float32)


# ---------------------------------------------------------------------------------------- OpenEXR
_EXR_MAGIC = 20000630
_EXR_CODECS = ("NONE", "RLE", "ZIPS", "ZIP", "PIZ", "PXR24", "B44", "B44A", "DWAA", "DWAB", "HTJ2K256", "HTJ2K32")
_EXR_LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16}  # codecs decoded here
_EXR_TYPES = {0: (np.dtype("<u4"), "UINT"), 1: (np.dtype("<f2"), "HALF"), 2: (np.dtype("<f4"), "FLOAT")}
_DEPTH_CHANNELS = ("z", "depth", "d", "distance", "y", "r", "v", "gray", "grey", "l")


class _Unsupported(Exception):
    """The EXR is valid but uses a feature the built-in decoder lacks (message: which)."""


def _read_exr(path: Path) -> np.ndarray:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SidecarError(f"{path}: cannot read the file ({exc.strerror or exc}); check its permissions") from None
    try:
        return _decode_exr(data, path)
    except _Unsupported as exc:
        reason = str(exc)
    except (struct.error, zlib.error, IndexError, ValueError) as exc:
        if isinstance(exc, SidecarError):
            raise
        raise SidecarError(f"{path}: damaged or not an OpenEXR file ({type(exc).__name__}); re-export the depth as EXR or .npy") from None
    depth = _read_exr_fallback(path)
    if depth is None:
        raise SidecarError(
            f"{path}: {reason}, which needs OpenCV built with OpenEXR or Mitsuba 3; "
            f"re-save the EXR with ZIP or no compression (scanline), or save depth as .npy"
        )
    return depth


def _pick_channel(names: list[str], path: Path) -> int:
    if len(names) == 1:
        return 0
    keys = [n.lower().rsplit(".", 1)[-1] for n in names]
    for wanted in _DEPTH_CHANNELS:
        if wanted in keys:
            return keys.index(wanted)
    raise SidecarError(f"{path}: cannot tell which EXR channel holds depth (channels: {', '.join(names)}); name it Z or depth, or save a single channel")


def _decode_exr(data: bytes, path: Path) -> np.ndarray:
    magic, version = struct.unpack_from("<ii", data, 0)
    if magic != _EXR_MAGIC:
        raise SidecarError(f"{path}: not an OpenEXR file (bad magic number); export depth as float EXR or .npy")
    if version & 0x800:
        raise SidecarError(f"{path}: deep EXR images are not depth maps; export a flat float EXR or .npy")
    if version & 0x200:
        raise _Unsupported("tiled EXR")
    if version & 0x1000:
        raise _Unsupported("multi-part EXR")

    pos = 8
    header: dict[str, tuple[str, bytes]] = {}
    while True:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode("latin-1")
        pos = end + 1
        if not name:
            break
        end = data.index(b"\0", pos)
        typ = data[pos:end].decode("latin-1")
        pos = end + 1
        (size,) = struct.unpack_from("<i", data, pos)
        pos += 4
        header[name] = (typ, data[pos : pos + size])
        pos += size
    for key in ("channels", "compression", "dataWindow"):
        if key not in header:
            raise SidecarError(f"{path}: EXR header lacks '{key}'; re-export the depth as EXR or .npy")

    channels = []  # (name, dtype, type name)
    raw = header["channels"][1]
    cpos = 0
    while cpos < len(raw) and raw[cpos] != 0:
        end = raw.index(b"\0", cpos)
        cname = raw[cpos:end].decode("latin-1")
        ptype, _linear, xs, ys = struct.unpack_from("<iB3xii", raw, end + 1)
        cpos = end + 1 + 16
        if ptype not in _EXR_TYPES:
            raise SidecarError(f"{path}: EXR channel {cname!r} has unknown pixel type {ptype}; re-export as float EXR or .npy")
        if xs != 1 or ys != 1:
            raise _Unsupported(f"subsampled channel {cname!r}")
        channels.append((cname, *_EXR_TYPES[ptype]))
    if not channels:
        raise SidecarError(f"{path}: EXR has no channels; re-export the depth as EXR or .npy")
    pick = _pick_channel([c[0] for c in channels], path)

    codec = header["compression"][1][0]
    if codec not in _EXR_LINES_PER_CHUNK:
        name = _EXR_CODECS[codec] if codec < len(_EXR_CODECS) else f"#{codec}"
        raise _Unsupported(f"{name} compression")
    lines = _EXR_LINES_PER_CHUNK[codec]
    xmin, ymin, xmax, ymax = struct.unpack("<iiii", header["dataWindow"][1])
    width, height = xmax - xmin + 1, ymax - ymin + 1
    if width <= 0 or height <= 0:
        raise SidecarError(f"{path}: EXR data window is empty; re-export the depth as EXR or .npy")

    n_chunks = -(-height // lines)
    offsets = np.frombuffer(data, dtype="<u8", count=n_chunks, offset=pos)
    bytes_per_line = sum(c[1].itemsize for c in channels) * width
    ch_start = sum(c[1].itemsize for c in channels[:pick]) * width
    ch_dtype = channels[pick][1]
    out = np.zeros((height, width), dtype=np.float32)
    for off in offsets:
        y, size = struct.unpack_from("<ii", data, int(off))
        payload = data[int(off) + 8 : int(off) + 8 + size]
        row = y - ymin
        n = min(lines, height - row)
        if row < 0 or n <= 0:
            raise SidecarError(f"{path}: EXR chunk at line {y} lies outside the data window; re-export the file")
        expected = bytes_per_line * n
        if size < expected:
            if codec == 1:
                payload = _exr_unpredict(_exr_rle(payload, expected))
            elif codec in (2, 3):
                payload = _exr_unpredict(np.frombuffer(zlib.decompress(payload), dtype=np.uint8))
            else:
                raise _Unsupported("compressed NONE chunk")
        block = np.frombuffer(payload, dtype=np.uint8)
        if block.size != expected:
            raise SidecarError(f"{path}: EXR chunk at line {y} has {block.size} bytes, expected {expected}; re-export the file")
        block = block.reshape(n, bytes_per_line)[:, ch_start : ch_start + ch_dtype.itemsize * width]
        out[row : row + n] = np.ascontiguousarray(block).view(ch_dtype).reshape(n, width)
    return out


def _exr_unpredict(t: np.ndarray) -> bytes:
    """Undo the ZIP/RLE byte predictor and the even/odd byte split of OpenEXR."""
    if t.size == 0:
        return b""
    d = t.astype(np.int64)
    d[1:] -= 128
    t = (np.cumsum(d) & 0xFF).astype(np.uint8)
    out = np.empty_like(t)
    half = (t.size + 1) // 2
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


def _exr_rle(src: bytes, expected: int) -> np.ndarray:
    out = bytearray()
    i = 0
    while i < len(src):
        count = struct.unpack_from("b", src, i)[0]
        i += 1
        if count < 0:
            out += src[i : i - count]
            i -= count
        else:
            out += src[i : i + 1] * (count + 1)
            i += 1
    if len(out) != expected:
        raise ValueError("bad RLE data")
    return np.frombuffer(bytes(out), dtype=np.uint8)


def _read_exr_fallback(path: Path) -> np.ndarray | None:
    """Decode an EXR the built-in decoder cannot (PIZ, DWA, tiled ...) with OpenCV or Mitsuba, if available."""
    try:
        img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    except cv2.error:
        img = None
    if img is not None:
        if img.ndim == 3:
            img = img[..., 2] if img.shape[2] >= 3 else img[..., 0]  # BGR(A): take R
        return img.astype(np.float32)
    try:
        import mitsuba as mi  # optional; Bitmap needs no variant
    except Exception:  # noqa: BLE001 - any import failure means "not available"
        return None
    try:
        bmp = mi.Bitmap(str(path))
        names = [field.name for field in bmp.struct_()]
        arr = np.array(bmp)
    except Exception:  # noqa: BLE001
        return None
    if arr.ndim == 3:
        arr = arr[..., _pick_channel(names, path)] if arr.shape[2] > 1 else arr[..., 0]
    return arr.astype(np.float32)
