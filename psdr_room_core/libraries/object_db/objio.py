"""Wavefront OBJ/MTL, the subset furniture files use: ``v``, ``f`` (any ``v/vt/vn`` form, polygons
fan-triangulated, negative indices), ``usemtl`` groups and ``mtllib``; MTL ``newmtl`` and ``Kd``.

Everything else (normals, texture coordinates, ``g``/``o``/``s`` lines, other MTL statements) is skipped:
the database keeps positions and material groups only, and renders flat colours. Errors are
:class:`~psdr_room_core.engine.errors.PsdrRoomError` naming the file and line.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole

DEFAULT_GROUP = "default"
"""Group of the faces that come before any ``usemtl`` line."""

DEFAULT_COLOR = (0.6, 0.6, 0.6)
"""Colour of a group that the MTL file does not define (or when there is no MTL file)."""


@dataclass(frozen=True)
class ObjData:
    """An OBJ file's triangles as read: positions in the file's own units and axes."""

    vertices: np.ndarray
    """(N, 3) float64."""
    faces: np.ndarray
    """(M, 3) int64, zero-based."""
    face_group: np.ndarray
    """(M,) int64 index into ``groups``."""
    groups: tuple[str, ...]
    """Material names in order of first use."""
    mtllib: tuple[str, ...]
    """The ``mtllib`` file names, relative to the OBJ's folder."""


def read_obj(path: Path) -> ObjData:
    """Triangles and ``usemtl`` groups of an OBJ file (unused groups are dropped)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise PsdrRoomError(f"{path}: cannot read the mesh ({exc.strerror}); check the path") from None
    vertices: list[list[float]] = []
    faces: list[tuple[int, int, int]] = []
    face_group: list[int] = []
    groups: dict[str, int] = {}
    mtllib: list[str] = []
    current = -1
    for number, line in enumerate(text.splitlines(), 1):
        if not line:
            continue
        if line[0] in " \t":
            line = line.lstrip()
        if not line or line[0] not in "vfum":
            continue
        parts = line.split()
        if not parts:
            continue
        key = parts[0]
        try:
            if key == "v":
                vertices.append([float(parts[1]), float(parts[2]), float(parts[3])])
            elif key == "f":
                n = len(vertices)
                corners = []
                for token in parts[1:]:
                    index = int(token.split("/", 1)[0])
                    index = index - 1 if index > 0 else n + index
                    if not 0 <= index < n:
                        raise IndexError(token)
                    corners.append(index)
                if len(corners) < 3:
                    raise ValueError("a face needs 3 corners")
                if current < 0:
                    current = groups.setdefault(DEFAULT_GROUP, len(groups))
                for k in range(1, len(corners) - 1):
                    faces.append((corners[0], corners[k], corners[k + 1]))
                    face_group.append(current)
            elif key == "usemtl":
                name = line[len("usemtl") :].strip() or DEFAULT_GROUP
                current = groups.setdefault(name, len(groups))
            elif key == "mtllib":
                mtllib.extend(parts[1:])
        except IndexError:
            raise PsdrRoomError(
                f"{path}:{number}: face refers to a vertex that is not defined ({line.strip()!r}); re-export the mesh"
            ) from None
        except ValueError:
            raise PsdrRoomError(f"{path}:{number}: cannot parse {line.strip()!r}; re-export the mesh as OBJ") from None
    if not faces:
        raise PsdrRoomError(f"{path}: no faces; the mesh file is empty or not an OBJ file")
    vertex_array = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(vertex_array)):
        raise PsdrRoomError(f"{path}: vertex coordinates are not finite numbers; re-export the mesh")
    face_array = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    group_array = np.asarray(face_group, dtype=np.int64)
    names = tuple(groups)
    used = np.unique(group_array)
    if len(used) != len(names):  # drop usemtl names with no faces, renumber
        remap = np.full(len(names), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        group_array = remap[group_array]
        names = tuple(names[i] for i in used)
    return ObjData(vertex_array, face_array, group_array, names, tuple(mtllib))


def read_mtl(path: Path) -> dict[str, tuple[float, float, float]]:
    """``Kd`` colour of every ``newmtl`` in an MTL file (materials without ``Kd`` get :data:`DEFAULT_COLOR`)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise PsdrRoomError(f"{path}: cannot read the material file ({exc.strerror}); check the path") from None
    colors: dict[str, tuple[float, float, float]] = {}
    current: str | None = None
    for number, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "newmtl":
            current = line.strip()[len("newmtl") :].strip()
            colors[current] = DEFAULT_COLOR
        elif parts[0] == "Kd" and current is not None:
            try:
                rgb = tuple(float(x) for x in parts[1:4])
            except ValueError:
                raise PsdrRoomError(f"{path}:{number}: cannot parse {line.strip()!r}; Kd needs three numbers") from None
            if len(rgb) == 1:
                rgb = rgb * 3
            if len(rgb) != 3 or not all(np.isfinite(rgb)):
                raise PsdrRoomError(f"{path}:{number}: Kd needs three numbers in [0, 1], got {line.strip()!r}")
            colors[current] = tuple(float(np.clip(c, 0.0, 1.0)) for c in rgb)  # type: ignore[assignment]
    return colors


def group_colors(obj: ObjData, folder: Path, mtl_names: Sequence[str] = ()) -> np.ndarray:
    """(G, 3) colours of ``obj``'s groups from its MTL files (those named by ``mtllib`` and ``mtl_names``,
    where they exist); groups no file defines get :data:`DEFAULT_COLOR`."""
    colors: dict[str, tuple[float, float, float]] = {}
    for name in (*obj.mtllib, *mtl_names):
        candidate = Path(folder) / name
        if candidate.is_file():
            for key, value in read_mtl(candidate).items():
                colors.setdefault(key, value)
    return np.array([colors.get(g, DEFAULT_COLOR) for g in obj.groups], dtype=np.float64).reshape(-1, 3)


def write_obj(
    path: Path,
    vertices: np.ndarray,
    faces: np.ndarray,
    face_group: np.ndarray,
    groups: Sequence[str],
    colors: np.ndarray,
    header: str = "",
) -> None:
    """Write ``path`` (OBJ, faces sorted into one ``usemtl`` block per group) and the MTL beside it (same
    stem, ``.mtl``), each atomically."""
    path = Path(path)
    mtl = path.with_suffix(".mtl")
    lines = [f"# {line}" for line in header.splitlines()] + [f"mtllib {mtl.name}"]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in np.asarray(vertices, dtype=np.float64)]
    faces = np.asarray(faces, dtype=np.int64) + 1
    face_group = np.asarray(face_group, dtype=np.int64)
    for index, name in enumerate(groups):
        lines.append(f"usemtl {name}")
        lines += [f"f {a} {b} {c}" for a, b, c in faces[face_group == index]]
    mtl_lines = [f"# {line}" for line in header.splitlines()]
    for name, rgb in zip(groups, np.asarray(colors, dtype=np.float64)):
        mtl_lines += [f"newmtl {name}", f"Kd {rgb[0]:.9g} {rgb[1]:.9g} {rgb[2]:.9g}", ""]
    write_whole(mtl, "\n".join(mtl_lines) + "\n")
    write_whole(path, "\n".join(lines) + "\n")
