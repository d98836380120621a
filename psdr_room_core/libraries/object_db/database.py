"""The object model database of the object stage (§4.3 "Model database"): records, meshes, the on-disk format.

The paper retrieves furniture from 3D-FUTURE, whose models have *split material groups* (a sofa's frame,
cushions and legs are separate parts, so each can get its own material in §4.4) and whose own materials are
discarded. This module is that database in a format of our own:

    <root>/index.json                 {"format": "psdr-room-object-db", "version": 1, "models": [record, ...]}
    <root>/<id>/model.json            the record, plus how to read the mesh: "mesh", "up_axis", "front_axis",
                                      "unit_scale" (see MODEL_KEYS)
    <root>/<id>/mesh.obj + mesh.mtl   triangles with one ``usemtl`` block per material group; Kd = base colour

A record (:class:`ModelRecord`) names the model's category (one of :data:`CATEGORIES`), source, licence,
material groups and size. A mesh (:class:`ObjectMesh`) is always given in the *canonical frame*: metres,
+Y up, bottom at y = 0, bounding box centred on x = z = 0, front facing +Z, triangles counter-clockwise seen
from outside. Readers convert to it (:func:`canonical_vertices`) from the file's up/front axes and unit.

:func:`~.builtin.builtin_database` is the library shipped with the package (:mod:`.builtin`: the CC0 Kenney
Furniture Kit and the parametric furniture of :mod:`.parametric`); :func:`.future3d.read_3dfuture` reads the
3D-FUTURE layout; :meth:`ObjectDatabase.thumbnails` renders and caches views (:mod:`.thumbnails`).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole
from psdr_room_core.method.artifacts import ObjectMesh

from .objio import group_colors, read_obj, write_obj

CATEGORIES = (
    "chair",
    "table",
    "sofa",
    "bed",
    "cabinet",
    "shelf",
    "desk",
    "lamp",
    "rug",
    "pillow",
    "plant",
    "tv",
    "ottoman",
    "refrigerator",
    "appliance",
    "frame",
    "box",
    "other",
)
"""Object categories: those of the built-in library (``tv`` holds monitors, ``cabinet`` kitchen units,
``appliance`` microwaves, ovens and washing machines, ``frame`` pictures, mirrors and boards, ``box`` boxes,
bins and baskets); ``other`` takes whatever a foreign database has that maps onto none of them."""

FORMAT = "psdr-room-object-db"
VERSION = 1
AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
MODEL_KEYS = (
    "id",
    "category",
    "name",
    "source",
    "licence",
    "groups",
    "extent",
    "mesh",
    "up_axis",
    "front_axis",
    "unit_scale",
)
"""Keys of ``model.json``: the record's, then ``mesh`` (file name, default ``mesh.obj``), ``up_axis`` and
``front_axis`` (the file's axes pointing up and towards the object's front, defaults ``+y``/``+z``) and
``unit_scale`` (metres per file unit, default 1)."""

_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*(/[A-Za-z0-9][A-Za-z0-9_.\-]*)*$")
EXTENT_TOLERANCE = 2e-3
"""Largest difference (metres, and relative) allowed between a record's extent and its mesh's."""


# ----------------------------------------------------------------------------------------------- records
@dataclass(frozen=True)
class ModelRecord:
    """One model of the database (what retrieval lists and filters on; the mesh is loaded on demand)."""

    id: str
    """Unique, path-like: ``kenney/loungeSofa``, ``parametric/sofa_017``, ``3dfuture/<uuid>``."""
    category: str
    """One of :data:`CATEGORIES`."""
    name: str
    """Human-readable description."""
    source: str
    """Where the model comes from (a file, a generator and its parameters)."""
    licence: str
    """One line, e.g. ``CC0 1.0 (Kenney Furniture Kit 2.0, www.kenney.nl)``."""
    groups: tuple[str, ...]
    """Material group names, in the mesh's order."""
    extent: tuple[float, float, float]
    """Bounding-box size in metres (x, y, z) in the canonical frame."""

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "category": self.category,
            "name": self.name,
            "source": self.source,
            "licence": self.licence,
            "groups": list(self.groups),
            "extent": [round(float(e), 6) for e in self.extent],
        }

    @classmethod
    def from_json(cls, data: Any, where: str) -> ModelRecord:
        """Validate a record read from ``where`` (a file name, for the error message)."""
        if not isinstance(data, Mapping):
            raise PsdrRoomError(f"{where}: a model record must be a JSON object, got {type(data).__name__}")
        model_id = _field(data, "id", str, where)
        where = f"{where} (model {model_id!r})" if "model.json" not in where else where
        if not _ID.match(model_id) or ".." in model_id.split("/"):
            raise PsdrRoomError(
                f"{where}: field 'id' = {model_id!r} is not a valid model id; use letters, digits, "
                "'_', '-', '.' and '/' between parts"
            )
        category = _field(data, "category", str, where)
        if category not in CATEGORIES:
            raise PsdrRoomError(
                f"{where}: field 'category' = {category!r} is not a known category; use one of {', '.join(CATEGORIES)}"
            )
        groups = _field(data, "groups", list, where)
        if (
            not groups
            or not all(isinstance(g, str) and g.strip() == g and g for g in groups)
            or len(set(groups)) != len(groups)
        ):
            raise PsdrRoomError(
                f"{where}: field 'groups' must be a non-empty list of distinct names without "
                f"spaces at the ends, got {groups!r}"
            )
        extent = _field(data, "extent", list, where)
        if len(extent) != 3 or not all(isinstance(e, (int, float)) and math.isfinite(e) and e >= 0 for e in extent):
            raise PsdrRoomError(f"{where}: field 'extent' must be three sizes in metres (x, y, z), got {extent!r}")
        return cls(
            id=model_id,
            category=category,
            name=_field(data, "name", str, where, default=model_id),
            source=_field(data, "source", str, where, default=""),
            licence=_field(data, "licence", str, where),
            groups=tuple(groups),
            extent=(float(extent[0]), float(extent[1]), float(extent[2])),
        )


def _field(data: Mapping[str, Any], key: str, kind: type, where: str, default: Any = None) -> Any:
    if key not in data:
        if default is not None:
            return default
        raise PsdrRoomError(
            f"{where}: field {key!r} is missing; add it (see psdr_room_core.libraries.object_db.database)"
        )
    value = data[key]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or isinstance(value, bool):
        raise PsdrRoomError(f"{where}: field {key!r} must be a {kind.__name__}, got {value!r}")
    if isinstance(value, str) and "\n" in value:
        raise PsdrRoomError(f"{where}: field {key!r} must be one line, got {value!r}")
    return value


# ------------------------------------------------------------------------------------------------ meshes
def axis_rotation(up_axis: str = "+y", front_axis: str = "+z") -> np.ndarray:
    """The rotation taking a file's ``up_axis`` to +Y and ``front_axis`` to +Z (a proper rotation, so
    triangle winding is kept)."""

    def unit(axis: str) -> np.ndarray:
        vector = np.zeros(3)
        vector["xyz".index(axis[1])] = 1.0 if axis[0] == "+" else -1.0
        return vector

    if up_axis not in AXES or front_axis not in AXES or up_axis[1] == front_axis[1]:
        raise PsdrRoomError(
            f"up_axis={up_axis!r}, front_axis={front_axis!r}: each must be one of {', '.join(AXES)}, on different axes"
        )
    up, front = unit(up_axis), unit(front_axis)
    return np.stack([np.cross(up, front), up, front])


def canonical_vertices(
    vertices: np.ndarray, up_axis: str = "+y", front_axis: str = "+z", unit_scale: float = 1.0
) -> np.ndarray:
    """Vertices in the canonical frame: rotated (file axes → +Y up, +Z front), scaled to metres, bottom at
    y = 0 and the bounding box centred on x = z = 0."""
    v = (np.asarray(vertices, dtype=np.float64) @ axis_rotation(up_axis, front_axis).T) * float(unit_scale)
    lo, hi = v.min(axis=0), v.max(axis=0)
    return v - np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])


def clean_faces(vertices: np.ndarray, faces: np.ndarray, face_group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop degenerate triangles (a repeated corner or no area) and return (faces, face_group)."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    scale = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 1.0
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    keep &= area2 > 1e-12 * max(scale, 1e-9) ** 2
    return faces[keep], face_group[keep]


def mesh_from_obj(
    path: Path,
    up_axis: str = "+y",
    front_axis: str = "+z",
    unit_scale: float = 1.0,
    mtl_names: Sequence[str] = (),
    colors: Mapping[str, Sequence[float]] | None = None,
) -> ObjectMesh:
    """Read an OBJ file (and its MTL colours) into a canonical :class:`ObjectMesh`.

    Vertices no face uses are dropped, so that the bounding box is that of the surface."""
    path = Path(path)
    obj = read_obj(path)
    group_rgb = group_colors(obj, path.parent, mtl_names)
    if colors:
        group_rgb = np.array([colors.get(g, c) for g, c in zip(obj.groups, group_rgb)], dtype=np.float64)
    used = np.unique(obj.faces)
    remap = np.full(len(obj.vertices), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    vertices = canonical_vertices(obj.vertices[used], up_axis, front_axis, unit_scale)
    faces, face_group = clean_faces(vertices, remap[obj.faces], obj.face_group)
    order = np.argsort(face_group, kind="stable")  # one block per group, as written back (round trips)
    faces, face_group = faces[order], face_group[order]
    if len(faces) == 0:
        raise PsdrRoomError(f"{path}: every face is degenerate (no area); re-export the mesh")
    present = np.unique(face_group)
    if len(present) != len(obj.groups):  # a group whose every face was degenerate
        renumber = np.full(len(obj.groups), -1, dtype=np.int64)
        renumber[present] = np.arange(len(present))
        face_group = renumber[face_group]
        groups = tuple(obj.groups[i] for i in present)
        group_rgb = group_rgb[present]
    else:
        groups = obj.groups
    mesh = ObjectMesh(vertices=vertices, faces=faces, face_group=face_group, groups=groups, colors=group_rgb)
    mesh.check(str(path))
    return mesh


def check_extent(record: ModelRecord, mesh: ObjectMesh, where: str) -> None:
    """The record must describe the mesh: same groups, same extent (within :data:`EXTENT_TOLERANCE`)."""
    if tuple(mesh.groups) != tuple(record.groups):
        raise PsdrRoomError(
            f"{where}: field 'groups' = {list(record.groups)} but the mesh has groups "
            f"{list(mesh.groups)}; rebuild the index (psdr-room-db index --root DIR)"
        )
    actual = np.array(mesh.extent)
    if np.any(np.abs(actual - np.array(record.extent)) > EXTENT_TOLERANCE * np.maximum(1.0, actual)):
        raise PsdrRoomError(
            f"{where}: field 'extent' = {list(record.extent)} but the mesh measures "
            f"{[round(float(e), 4) for e in actual]} m; rebuild the index (psdr-room-db index --root DIR)"
        )


# -------------------------------------------------------------------------------------------- database
class _MeshCache:
    """A thread-safe LRU of loaded meshes, shared by a database and its subsets."""

    def __init__(self, loader: Callable[[str], ObjectMesh], size: int) -> None:
        self.loader = loader
        self.size = size
        self.items: OrderedDict[str, ObjectMesh] = OrderedDict()
        self.lock = threading.Lock()

    def get(self, model_id: str) -> ObjectMesh:
        with self.lock:
            if model_id in self.items:
                self.items.move_to_end(model_id)
                return self.items[model_id]
        mesh = self.loader(model_id)
        with self.lock:
            self.items[model_id] = mesh
            while len(self.items) > self.size:
                self.items.popitem(last=False)
        return mesh


class ObjectDatabase:
    """Records plus a way to load each one's mesh (cached), and thumbnails rendered on demand.

    ``digest`` identifies the content (it keys the thumbnail cache); subsets keep their parent's.
    ``images`` maps model ids to renderings the database ships (3D-FUTURE's ``image.jpg``)."""

    def __init__(
        self,
        records: Iterable[ModelRecord],
        loader: Callable[[str], ObjectMesh],
        digest: str,
        label: str = "",
        images: Mapping[str, Path] | None = None,
        cache_size: int = 512,
        _cache: _MeshCache | None = None,
    ) -> None:
        self.records: list[ModelRecord] = list(records)
        self._by_id: dict[str, ModelRecord] = {}
        for record in self.records:
            if record.id in self._by_id:
                raise PsdrRoomError(
                    f"{label or 'object database'}: model id {record.id!r} appears twice; ids must be unique"
                )
            self._by_id[record.id] = record
        self.digest = digest
        self.label = label
        self.images: dict[str, Path] = {k: Path(v) for k, v in (images or {}).items() if k in self._by_id}
        self._cache = _cache or _MeshCache(loader, cache_size)

    # -- construction
    @classmethod
    def load(cls, root: Path) -> ObjectDatabase:
        """A database in our format: ``root/index.json`` and one folder per model."""
        root = Path(root)
        index = root / "index.json"
        try:
            raw = index.read_bytes()
        except OSError as exc:
            raise PsdrRoomError(
                f"{index}: cannot read the database index ({exc.strerror}); point --root at a "
                "folder written by `psdr-room-db export` or run `psdr-room-db index --root DIR`"
            ) from None
        try:
            data = json.loads(raw)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise PsdrRoomError(
                f"{index}: not valid JSON ({exc}); rebuild it with `psdr-room-db index --root {root}`"
            ) from None
        if isinstance(data, Mapping):
            if data.get("format", FORMAT) != FORMAT or data.get("version", VERSION) != VERSION:
                raise PsdrRoomError(
                    f"{index}: field 'format'/'version' = {data.get('format')!r}/"
                    f"{data.get('version')!r}; this reader needs {FORMAT!r} version {VERSION}"
                )
            models = data.get("models")
        else:
            models = data
        if not isinstance(models, list):
            raise PsdrRoomError(f"{index}: field 'models' must be a list of model records")
        records = [ModelRecord.from_json(item, f"{index} models[{i}]") for i, item in enumerate(models)]
        return cls(
            records,
            _FolderLoader(root, {r.id: r for r in records}),
            digest=hashlib.sha256(b"folder\0" + raw).hexdigest(),
            label=str(root / "index.json"),
        )

    # -- queries
    def __len__(self) -> int:
        return len(self.records)

    def __contains__(self, model_id: object) -> bool:
        return model_id in self._by_id

    def record(self, model_id: str) -> ModelRecord:
        try:
            return self._by_id[model_id]
        except KeyError:
            close = [r.id for r in self.records if model_id.split("/")[-1].lower() in r.id.lower()][:5]
            hint = f" (similar: {', '.join(close)})" if close else ""
            raise PsdrRoomError(
                f"{self.label or 'object database'}: no model {model_id!r}{hint}; list them with `psdr-room-db list`"
            ) from None

    def categories(self) -> dict[str, int]:
        """Model count per category present, in :data:`CATEGORIES` order."""
        counts = {c: 0 for c in CATEGORIES}
        for record in self.records:
            counts[record.category] += 1
        return {c: n for c, n in counts.items() if n}

    def category(self, name: str) -> list[ModelRecord]:
        if name not in CATEGORIES:
            raise PsdrRoomError(f"category {name!r} is not known; use one of {', '.join(CATEGORIES)}")
        return [r for r in self.records if r.category == name]

    def mesh(self, model_id: str) -> ObjectMesh:
        """The model's mesh in the canonical frame (loaded once, then cached)."""
        self.record(model_id)
        return self._cache.get(model_id)

    def subset(self, fraction: float, seed: int) -> ObjectDatabase:
        """A random ``fraction`` of each category's models (at least one per category), in the original
        order; for the database-size ablation (paper Fig. 10)."""
        if not 0.0 < float(fraction) <= 1.0:
            raise PsdrRoomError(f"subset fraction={fraction!r}: must be in (0, 1]")
        rng = np.random.default_rng(seed)
        keep: set[str] = set()
        for name in CATEGORIES:
            ids = [r.id for r in self.records if r.category == name]
            if ids:
                count = max(1, int(round(fraction * len(ids))))
                keep.update(ids[i] for i in rng.permutation(len(ids))[:count])
        return self.only(
            [r.id for r in self.records if r.id in keep], label=f"{self.label} (subset {fraction:g}, seed {seed})"
        )

    def only(self, model_ids: Iterable[str], label: str | None = None) -> ObjectDatabase:
        """The database restricted to ``model_ids`` (same digest, so same thumbnails; shared mesh cache)."""
        records = [self.record(i) for i in model_ids]
        return ObjectDatabase(
            records,
            self._cache.loader,
            self.digest,
            label=self.label if label is None else label,
            images=self.images,
            _cache=self._cache,
        )

    def thumbnails(self, model_id: str, views: Sequence[int] | None = None) -> list[np.ndarray]:
        """uint8 RGB views (indices into ``thumbnails.VIEWS``; default all) from the thumbnail cache, rendered
        there if missing."""
        from .thumbnails import thumbnails_for

        self.record(model_id)
        return thumbnails_for(self, model_id, views=views)

    # -- writing
    def save(
        self, root: Path, progress: Callable[[Iterable[ModelRecord]], Iterable[ModelRecord]] | None = None
    ) -> Path:
        """Write every model in our format under ``root`` (canonical frame, metres) and the index; returns
        the index path."""
        root = Path(root)
        records = self.records if progress is None else progress(self.records)
        for record in records:
            write_model(root, record, self.mesh(record.id))
        return write_index(root, self.records)


def write_model(root: Path, record: ModelRecord, mesh: ObjectMesh) -> Path:
    """Write one model's folder (``model.json``, ``mesh.obj``, ``mesh.mtl``) under ``root``."""
    folder = Path(root) / record.id
    header = f"{record.id}: {record.name}\n{record.licence}"
    write_obj(folder / "mesh.obj", mesh.vertices, mesh.faces, mesh.face_group, mesh.groups, mesh.colors, header)
    data = {**record.to_json(), "mesh": "mesh.obj", "up_axis": "+y", "front_axis": "+z", "unit_scale": 1.0}
    _write_json(folder / "model.json", data)
    return folder


def write_index(root: Path, records: Sequence[ModelRecord]) -> Path:
    index = Path(root) / "index.json"
    _write_json(index, {"format": FORMAT, "version": VERSION, "models": [r.to_json() for r in records]})
    return index


def build_index(root: Path) -> Path:
    """(Re)write ``root/index.json`` from the ``model.json`` files under ``root``, measuring each mesh for
    the fields it may leave out (``groups``, ``extent``)."""
    root = Path(root)
    records = []
    for path in sorted(root.rglob("model.json")):
        model_id = path.parent.relative_to(root).as_posix()
        data = _read_json(path)
        data.setdefault("id", model_id)
        if data["id"] != model_id:
            raise PsdrRoomError(
                f"{path}: field 'id' = {data['id']!r} but the folder says {model_id!r}; rename one of them"
            )
        mesh = _FolderLoader.read_mesh(path, data)
        data.setdefault("groups", list(mesh.groups))
        data.setdefault("extent", list(mesh.extent))
        record = ModelRecord.from_json(data, str(path))
        check_extent(record, mesh, str(path))
        records.append(record)
    if not records:
        raise PsdrRoomError(f"{root}: no <id>/model.json files; write one per model first")
    return write_index(root, records)


class _FolderLoader:
    """Meshes of a database in our format (picklable, so thumbnails can be rendered in workers)."""

    def __init__(self, root: Path, records: Mapping[str, ModelRecord]) -> None:
        self.root = Path(root)
        self.records = dict(records)

    def __call__(self, model_id: str) -> ObjectMesh:
        path = self.root / model_id / "model.json"
        data = _read_json(path)
        if data.get("id", model_id) != model_id:
            raise PsdrRoomError(
                f"{path}: field 'id' = {data.get('id')!r} but the index says {model_id!r}; rebuild "
                f"the index (psdr-room-db index --root {self.root})"
            )
        mesh = self.read_mesh(path, data)
        check_extent(self.records[model_id], mesh, str(path))
        return mesh

    @staticmethod
    def read_mesh(path: Path, data: Mapping[str, Any]) -> ObjectMesh:
        where = str(path)
        mesh_name = _field(data, "mesh", str, where, default="mesh.obj")
        if "/" in mesh_name or "\\" in mesh_name or mesh_name.startswith("."):
            raise PsdrRoomError(f"{where}: field 'mesh' = {mesh_name!r} must be a file name in the model's folder")
        up_axis = _field(data, "up_axis", str, where, default="+y")
        front_axis = _field(data, "front_axis", str, where, default="+z")
        for key, value in (("up_axis", up_axis), ("front_axis", front_axis)):
            if value not in AXES:
                raise PsdrRoomError(f"{where}: field {key!r} = {value!r}; use one of {', '.join(AXES)}")
        if up_axis[1] == front_axis[1]:
            raise PsdrRoomError(
                f"{where}: fields 'up_axis' and 'front_axis' ({up_axis}, {front_axis}) must be different axes"
            )
        scale = _field(data, "unit_scale", float, where, default=1.0)
        if not math.isfinite(scale) or scale <= 0:
            raise PsdrRoomError(
                f"{where}: field 'unit_scale' = {scale!r} must be a positive number (metres per file unit)"
            )
        return mesh_from_obj(path.parent / mesh_name, up_axis, front_axis, scale)


def _read_json(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise PsdrRoomError(f"{path}: cannot read it ({exc.strerror}); check the database folder") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PsdrRoomError(f"{path}: not valid JSON ({exc}); fix or rewrite the file") from None
    if not isinstance(data, dict):
        raise PsdrRoomError(f"{path}: must hold a JSON object (the model record)")
    return data


def _write_json(path: Path, data: Any) -> None:
    write_whole(Path(path), json.dumps(data, indent=1) + "\n")
