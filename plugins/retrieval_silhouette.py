"""``retrieval=silhouette``: offline object retrieval by silhouette agreement under the estimated camera.

For each database model of the segment's category (every model when the label maps to none), the model is
placed on the object's point cloud as §4.3 initialises it (at the points' full radius), swept about the
vertical axis, and scored by the best IoU between its rendered silhouette and the object's mask.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np

from psdr_room_core.artifacts import Camera, Candidate, ObjectMesh
from psdr_room_core.errors import PsdrRoomError
from psdr_room_core.hookspecs import hookimpl
from psdr_room_core.objects import ObjectQuery, initial_pose, pose_matrix, transform
from psdr_room_core.plugins import Registry
from psdr_room_core.silhouette import mask_iou, silhouette


def open_database(database: str, fraction: float, seed: int) -> Any:
    """The object database: ``builtin`` (shipped with the package) or a folder in our format, optionally a
    random ``fraction`` of it per category (the paper's Fig. 10 database-size ablation)."""
    from psdr_room_plugins.object_db.database import ObjectDatabase

    if database == "builtin":
        db = ObjectDatabase.builtin()
    else:
        root = Path(database).expanduser()
        if not (root / "index.json").is_file():
            raise PsdrRoomError(f"{root}: not an object database (no index.json); set retrieval.<impl>.database=builtin "
                                "or a folder written by `psdr-room-db`")
        db = ObjectDatabase.load(root)
    return db if float(fraction) >= 1.0 else db.subset(float(fraction), int(seed))


def object_mesh(db: Any, model_id: str) -> ObjectMesh:
    """A database mesh as the artifact type."""
    try:
        mesh = db.mesh(model_id)
    except KeyError:
        raise PsdrRoomError(f"object model '{model_id}' is not in the database; pick one listed by `psdr-room-db list`") from None
    return ObjectMesh(vertices=mesh.vertices, faces=mesh.faces, face_group=mesh.face_group, groups=tuple(mesh.groups),
                      colors=mesh.colors)


class SilhouetteRetrieval:
    """Rank models by the best silhouette IoU over a yaw sweep, each placed on the object's points."""

    def __init__(self, database: str = "builtin", fraction: float = 1.0, seed: int = 0, n_yaw: int = 12,
                 radius_factor: float = 1.0, render_width: int = 160) -> None:
        self.spec = (str(database), float(fraction), int(seed))
        self.n_yaw = int(n_yaw)
        self.radius_factor = float(radius_factor)
        self.render_width = int(render_width)
        self._db: Any = None

    @property
    def database(self) -> Any:
        if self._db is None:
            self._db = open_database(*self.spec)
        return self._db

    def describe(self) -> str:
        database, fraction, seed = self.spec
        return f"silhouette over {database} database" + (f" ({fraction:.0%}, seed {seed})" if fraction < 1 else "")

    def thumbnail(self, model_id: str) -> np.ndarray:
        return self.database.thumbnails(model_id)[0]

    def mesh(self, model_id: str) -> ObjectMesh:
        return object_mesh(self.database, model_id)

    def rank(self, query: ObjectQuery, camera: Camera, camera_to_world: np.ndarray, k: int) -> list[Candidate]:
        models = self.database.category(query.category) if query.category else []
        models = models or list(self.database.records)
        cam = camera.resized(min(self.render_width, camera.width))
        target = cv2.resize(query.mask.astype(np.uint8), (cam.width, cam.height), interpolation=cv2.INTER_NEAREST) > 0
        scored = []
        for record in models:
            mesh = self.database.mesh(record.id)
            position, scale = initial_pose(query.points, mesh.vertices, self.radius_factor)
            best = 0.0
            for yaw in np.arange(self.n_yaw) * (2.0 * np.pi / self.n_yaw):
                world = transform(mesh.vertices, pose_matrix(position, yaw, scale))
                best = max(best, mask_iou(silhouette(cam, camera_to_world, world, mesh.faces), target))
            scored.append(Candidate(record.id, best))
        scored.sort(key=lambda c: (-c.score, c.model_id))
        return scored[:k]


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("retrieval", "silhouette", SilhouetteRetrieval)
