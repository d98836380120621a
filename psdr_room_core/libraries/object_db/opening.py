"""Opening an object database by the name a setting gives (``builtin`` or a folder), and reading a model's mesh
with a one-line error for an unknown id: what retrieval implementations and the studio share."""

from __future__ import annotations

from pathlib import Path

from psdr_room_core.engine.errors import PsdrRoomError

from .builtin import builtin_database
from .database import ObjectDatabase, ObjectMesh


def open_database(database: str, fraction: float, seed: int) -> ObjectDatabase:
    """The object database: ``builtin`` (shipped with the package) or a folder in our format, optionally a
    random ``fraction`` of it per category (the paper's Fig. 10 database-size ablation)."""
    if database == "builtin":
        db = builtin_database()
    else:
        root = Path(database).expanduser()
        if not (root / "index.json").is_file():
            raise PsdrRoomError(
                f"{root}: not an object database (no index.json); set retrieval.<impl>.database=builtin "
                "or a folder written by `psdr-room-db`"
            )
        db = ObjectDatabase.load(root)
    return db if float(fraction) >= 1.0 else db.subset(float(fraction), int(seed))


def object_mesh(db: ObjectDatabase, model_id: str) -> ObjectMesh:
    """A database model's mesh, or a one-line error naming the unknown id."""
    try:
        return db.mesh(model_id)
    except KeyError:
        raise PsdrRoomError(
            f"object model '{model_id}' is not in the database; pick one listed by `psdr-room-db list`"
        ) from None
