"""The object model database (§4.3 "Model database"): furniture meshes with material groups, for retrieval.

    db = builtin_database()                    # Kenney Furniture Kit (CC0) + parametric furniture
    sofas = db.category("sofa")                # [ModelRecord, ...]
    mesh = db.mesh(sofas[0].id)                # ObjectMesh: canonical frame, metres, +Y up, front +Z
    views = db.thumbnails(sofas[0].id)         # uint8 RGB renders, cached

:mod:`.database` (records, meshes, our on-disk format), :mod:`.builtin` and :mod:`.parametric` (the shipped
library), :mod:`.future3d` (the 3D-FUTURE layout), :mod:`.thumbnails` (Mitsuba views) and the
``psdr-room-db`` command (:mod:`psdr_room_core.applications.db`). A library, not a plugin: retrieval
implementations use it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .builtin import builtin_database
from .database import CATEGORIES, ModelRecord, ObjectDatabase, ObjectMesh

__all__ = ["CATEGORIES", "ObjectMesh", "ModelRecord", "ObjectDatabase", "builtin_database", "read_3dfuture"]


def read_3dfuture(root: Path, **kwargs: Any) -> ObjectDatabase:
    """See :func:`.future3d.read_3dfuture` (imported lazily)."""
    from .future3d import read_3dfuture as read

    return read(root, **kwargs)
