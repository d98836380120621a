"""Read the 3D-FUTURE model database (Fu et al. 2021), the one the paper retrieves from (§4.3), in its
official layout:

    <root>/model_info.json                       [{"model_id", "super-category", "category", "style",
                                                   "theme", "material"}, ...]
    <root>/3D-FUTURE-model/<model_id>/raw_model.obj   metres, +Y up, front +Z; ``usemtl`` material groups
                                      model.mtl, texture.png   (colours are read from model.mtl's Kd)
                                      image.jpg                the dataset's own rendering (``db.images``)

3D-FUTURE is not redistributable (its terms allow research use), so nothing of it ships with psdr-room:
users who have it point :func:`read_3dfuture` (or ``psdr-room-db --3d-future DIR``) at their copy. Its
categories are mapped onto ours (:data:`CATEGORY_MAP`, then :data:`SUPER_CATEGORY_MAP`, else ``other``).
Records need each mesh's extent and groups, so the first read parses every mesh (in ``workers``
processes, with a progress bar); the results are kept in the cache directory, keyed by each file's size
and modification time, and later reads only parse what changed.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole

from .database import ModelRecord, ObjectDatabase, ObjectMesh, mesh_from_obj

MODELS_DIR = "3D-FUTURE-model"
MESH_FILE = "raw_model.obj"
MTL_FILE = "model.mtl"
IMAGE_FILE = "image.jpg"
LICENCE = "3D-FUTURE terms of use (Alibaba Tianchi; non-commercial research only, not redistributable)"
READER_VERSION = 1

CATEGORY_MAP: dict[str, str] = {
    "children cabinet": "cabinet",
    "nightstand": "cabinet",
    "bookcase / jewelry armoire": "shelf",
    "wardrobe": "cabinet",
    "coffee table": "table",
    "corner/side table": "table",
    "sideboard / side cabinet / console table": "cabinet",
    "wine cabinet": "cabinet",
    "tv stand": "cabinet",
    "drawer chest / corner cabinet": "cabinet",
    "shelf": "shelf",
    "round end table": "table",
    "king-size bed": "bed",
    "bunk bed": "bed",
    "bed frame": "bed",
    "single bed": "bed",
    "kids bed": "bed",
    "double bed": "bed",
    "couch bed": "sofa",
    "dining chair": "chair",
    "lounge chair / cafe chair / office chair": "chair",
    "lounge chair / book-chair / computer chair": "chair",
    "dressing chair": "chair",
    "classic chinese chair": "chair",
    "barstool": "chair",
    "armchair": "chair",
    "hanging chair": "chair",
    "folding chair": "chair",
    "dressing table": "desk",
    "dining table": "table",
    "desk": "desk",
    "tea table": "table",
    "bar": "table",
    "three-seat / multi-seat sofa": "sofa",
    "three-seat / multi-person sofa": "sofa",
    "two-seat sofa": "sofa",
    "loveseat sofa": "sofa",
    "l-shaped sofa": "sofa",
    "u-shaped sofa": "sofa",
    "lazy sofa": "sofa",
    "chaise longue sofa": "sofa",
    "footstool / sofastool / bed end stool / stool": "ottoman",
    "pendant lamp": "lamp",
    "ceiling lamp": "lamp",
    "floor lamp": "lamp",
    "wall lamp": "lamp",
    "shoe cabinet": "cabinet",
    "electronics": "tv",
}
"""3D-FUTURE fine category (lower case) → ours."""

SUPER_CATEGORY_MAP: dict[str, str] = {
    "sofa": "sofa",
    "chair": "chair",
    "table": "table",
    "bed": "bed",
    "cabinet/shelf/desk": "cabinet",
    "pier/stool": "chair",
    "lighting": "lamp",
}
"""3D-FUTURE super-category (lower case) → ours, for fine categories not in :data:`CATEGORY_MAP`."""


def map_category(category: Any, super_category: Any) -> str:
    """Our category for a 3D-FUTURE (category, super-category) pair (either may be None)."""
    if isinstance(category, str) and category.strip().lower() in CATEGORY_MAP:
        return CATEGORY_MAP[category.strip().lower()]
    if isinstance(super_category, str) and super_category.strip().lower() in SUPER_CATEGORY_MAP:
        return SUPER_CATEGORY_MAP[super_category.strip().lower()]
    return "other"


class Future3dLoader:
    """Meshes of a 3D-FUTURE tree by our id (picklable)."""

    def __init__(self, models_dir: Path, front_axis: str = "+z") -> None:
        self.models_dir = Path(models_dir)
        self.front_axis = front_axis

    def path(self, model_id: str) -> Path:
        return self.models_dir / model_id.partition("/")[2] / MESH_FILE

    def __call__(self, model_id: str) -> ObjectMesh:
        return mesh_from_obj(
            self.path(model_id), up_axis="+y", front_axis=self.front_axis, unit_scale=1.0, mtl_names=(MTL_FILE,)
        )


def _measure(args: tuple[str, str, str]) -> tuple[str, list[str], list[float]] | tuple[str, str]:
    """(id, groups, extent) of one model, or (id, error message)."""
    model_id, models_dir, front_axis = args
    try:
        mesh = Future3dLoader(Path(models_dir), front_axis)(model_id)
    except PsdrRoomError as exc:
        return model_id, str(exc)
    return model_id, list(mesh.groups), list(mesh.extent)


def _read_info(path: Path) -> list[dict[str, Any]]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise PsdrRoomError(
            f"{path}: cannot read it ({exc.strerror}); point --3d-future at the folder holding "
            f"model_info.json and {MODELS_DIR}/"
        ) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PsdrRoomError(f"{path}: not valid JSON ({exc}); download model_info.json again") from None
    if not isinstance(data, list):
        raise PsdrRoomError(
            f"{path}: must be a list of models (the 3D-FUTURE model_info.json), got {type(data).__name__}"
        )
    for i, item in enumerate(data):
        if not isinstance(item, Mapping) or not isinstance(item.get("model_id"), str) or not item["model_id"]:
            raise PsdrRoomError(
                f"{path}: entry [{i}] has no field 'model_id' (a string); is this 3D-FUTURE's model_info.json?"
            )
        if "/" in item["model_id"] or item["model_id"].startswith("."):
            raise PsdrRoomError(f"{path}: entry [{i}] field 'model_id' = {item['model_id']!r} is not a folder name")
    return [dict(item) for item in data]


def read_3dfuture(
    root: Path, front_axis: str = "+z", workers: int | None = None, strict: bool = False, progress: bool | None = None
) -> ObjectDatabase:
    """The 3D-FUTURE models under ``root`` as an :class:`ObjectDatabase` (ids ``3dfuture/<model_id>``).

    Models listed in ``model_info.json`` whose ``raw_model.obj`` is missing or unreadable are skipped with
    a warning on stderr (an error with ``strict``). ``workers`` processes parse meshes on the first read
    (default: the CPU count, at most 8); ``progress`` shows a bar (default: when many meshes are parsed)."""
    from psdr_room_core.engine.cache import default_cache_dir

    root = Path(root)
    info_path = root / "model_info.json"
    info = _read_info(info_path)
    models_dir = root / MODELS_DIR
    if not models_dir.is_dir():
        raise PsdrRoomError(f"{models_dir}: not found; unpack 3D-FUTURE-model.zip into {root}")
    loader = Future3dLoader(models_dir, front_axis)
    root_key = hashlib.sha256(str(root.resolve()).encode()).hexdigest()[:16]
    cache_path = default_cache_dir() / "object_db" / f"3dfuture-{root_key}.json"
    try:
        cache = json.loads(cache_path.read_text(encoding="utf-8")) if cache_path.is_file() else {}
        if cache.get("version") != READER_VERSION or cache.get("front_axis") != front_axis:
            cache = {}
    except (OSError, ValueError, AttributeError):
        cache = {}
    known: dict[str, Any] = cache.get("models", {}) if isinstance(cache.get("models"), dict) else {}
    stamps: dict[str, str] = {}
    todo = []
    missing = []
    for item in info:
        model_id = f"3dfuture/{item['model_id']}"
        path = loader.path(model_id)
        try:
            stat = path.stat()
        except OSError:
            missing.append(f"{path} (missing)")
            continue
        stamps[model_id] = f"{stat.st_size}:{stat.st_mtime_ns}"
        entry = known.get(model_id)
        if not (isinstance(entry, dict) and entry.get("stamp") == stamps[model_id]):
            todo.append(model_id)
    if todo:
        jobs = [(model_id, str(models_dir), front_axis) for model_id in todo]
        count = workers if workers is not None else min(8, os.cpu_count() or 1)
        show = progress if progress is not None else len(todo) > 50
        from tqdm import tqdm

        bar = tqdm(total=len(jobs), desc="3D-FUTURE meshes", unit="model", file=sys.stderr, disable=not show)
        results = []
        if count > 1 and len(jobs) > 16:
            with ProcessPoolExecutor(count) as pool:
                for result in pool.map(_measure, jobs, chunksize=16):
                    results.append(result)
                    bar.update()
        else:
            for job in jobs:
                results.append(_measure(job))
                bar.update()
        bar.close()
        for result in results:
            if len(result) == 2:
                known.pop(result[0], None)
                missing.append(str(result[1]))
            else:
                model_id, groups, extent = result
                known[model_id] = {"stamp": stamps[model_id], "groups": groups, "extent": extent}
        with contextlib.suppress(OSError):
            write_whole(
                cache_path,
                json.dumps(
                    {"version": READER_VERSION, "front_axis": front_axis, "root": str(root.resolve()), "models": known}
                )
                + "\n",
            )
    if missing:
        message = f"{root}: {len(missing)} of {len(info)} models in model_info.json cannot be read, e.g. {missing[0]}"
        if strict:
            raise PsdrRoomError(message + "; re-extract the dataset or read without strict")
        print(f"warning: {message}; skipping them", file=sys.stderr)
    records, images = [], {}
    for item in info:
        model_id = f"3dfuture/{item['model_id']}"
        entry = known.get(model_id)
        if model_id not in stamps or not isinstance(entry, dict) or entry.get("stamp") != stamps[model_id]:
            continue
        category = map_category(item.get("category"), item.get("super-category"))
        details = [str(item[k]) for k in ("style", "theme", "material") if item.get(k) not in (None, "", "Others")]
        label = item.get("category") or item.get("super-category") or "model"
        name = f"{label} ({', '.join(details)})" if details else str(label)
        records.append(
            ModelRecord(
                id=model_id,
                category=category,
                name=" ".join(name.split()),
                source=f"{MODELS_DIR}/{item['model_id']}/{MESH_FILE}",
                licence=LICENCE,
                groups=tuple(entry["groups"]),
                extent=tuple(entry["extent"]),
            )
        )
        image = models_dir / item["model_id"] / IMAGE_FILE
        if image.is_file():
            images[model_id] = image
    if not records:
        raise PsdrRoomError(
            f"{root}: none of the {len(info)} models in model_info.json has a readable "
            f"{MODELS_DIR}/<model_id>/{MESH_FILE}; check the folder"
        )
    digest = hashlib.sha256(
        b"3dfuture\0"
        + info_path.read_bytes()
        + f"\0{front_axis}\0{READER_VERSION}\0".encode()
        + json.dumps(sorted(stamps.items())).encode()
    ).hexdigest()
    return ObjectDatabase(records, loader, digest=digest, label=f"3D-FUTURE ({root})", images=images)
