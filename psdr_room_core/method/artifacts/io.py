"""File formats the artifacts are saved in: JSON, NPY, PNG, PLY point clouds, OBJ mesh groups."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError

from ..geometry import TriangleMesh


def write_json(path: Path, data: Any) -> None:
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")


def read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise PsdrRoomError(f"{path}: missing; the artifact directory is incomplete") from None
    except json.JSONDecodeError as exc:
        raise PsdrRoomError(f"{path}: invalid JSON ({exc.msg} at line {exc.lineno}); fix or regenerate it") from None


def read_npy(path: Path) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise PsdrRoomError(f"{path}: missing; the artifact directory is incomplete") from None
    except ValueError as exc:
        raise PsdrRoomError(f"{path}: not a readable .npy array ({exc}); regenerate it") from None


def write_png(path: Path, array: np.ndarray) -> None:
    """Write an RGB (HxWx3) or gray array as PNG (uint8/uint16 as is), making its folder; encoded in memory, so a
    failed write is an OSError (a full disk: ENOSPC) for the caller to report, not a message from libpng."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if array.ndim == 3:
        array = array[..., ::-1]
    encoded, data = cv2.imencode(".png", np.ascontiguousarray(array))
    if not encoded:
        raise PsdrRoomError(f"{path}: a {array.dtype} array of shape {array.shape} cannot be written as PNG")
    path.write_bytes(data.tobytes())


def read_png(path: Path) -> np.ndarray:
    data = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if data is None:
        raise PsdrRoomError(f"{path}: missing or not a readable PNG; regenerate it")
    return data[..., ::-1].copy() if data.ndim == 3 else data


PLY_FIELDS = [
    ("x", "<f4"),
    ("y", "<f4"),
    ("z", "<f4"),
    ("red", "u1"),
    ("green", "u1"),
    ("blue", "u1"),
    ("segment", "<i4"),
]

PLY_TYPES = {"<f4": "float", "u1": "uchar", "<i4": "int"}


def ply_bytes(points: np.ndarray, colors: np.ndarray, segment: np.ndarray) -> bytes:
    """Binary little-endian PLY with per-vertex colour and an integer ``segment`` property."""
    data = np.empty(len(points), dtype=PLY_FIELDS)
    data["x"], data["y"], data["z"] = points[:, 0], points[:, 1], points[:, 2]
    data["red"], data["green"], data["blue"] = colors[:, 0], colors[:, 1], colors[:, 2]
    data["segment"] = segment
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(points)}"]
    header += [f"property {PLY_TYPES[t]} {name}" for name, t in PLY_FIELDS] + ["end_header"]
    return ("\n".join(header) + "\n").encode("ascii") + data.tobytes()


def read_ply(path: Path) -> np.ndarray:
    """Read a PLY written by :func:`ply_bytes` (structured array with :data:`PLY_FIELDS`)."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise PsdrRoomError(f"{path}: missing; the artifact directory is incomplete") from None
    end = raw.find(b"end_header\n")
    header = raw[:end].decode("ascii", "replace").splitlines()
    expected = [f"property {PLY_TYPES[t]} {name}" for name, t in PLY_FIELDS]
    if end < 0 or header[1:2] != ["format binary_little_endian 1.0"] or header[3:] != expected:
        raise PsdrRoomError(f"{path}: not a psdr-room point cloud PLY (binary, x y z red green blue segment)")
    count = int(header[2].split()[-1])
    return np.frombuffer(raw[end + len(b"end_header\n") :], dtype=PLY_FIELDS, count=count)


def save_meshes(path: Path, meshes: dict[str, TriangleMesh]) -> None:
    arrays = {}
    for k, (_name, mesh) in enumerate(meshes.items()):
        arrays[f"v{k}"], arrays[f"f{k}"] = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    np.savez(path, **arrays)  # type: ignore[arg-type]  # numpy's stub lets ** fill allow_pickle


def load_meshes(path: Path, names: list[str]) -> dict[str, TriangleMesh]:
    try:
        with np.load(path, allow_pickle=False) as data:
            return {name: TriangleMesh(data[f"v{k}"], data[f"f{k}"]) for k, name in enumerate(names)}
    except (FileNotFoundError, KeyError, ValueError) as exc:
        raise PsdrRoomError(f"{path}: missing or incomplete ({exc}); regenerate the artifact") from None
