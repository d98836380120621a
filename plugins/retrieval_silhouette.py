"""``retrieval=silhouette``: offline object retrieval by silhouette and depth agreement under the estimated camera.

For each database model of the segment's categories (every model when the label maps to none), the model is
posed by the occlusion-aware view search (:class:`~psdr_room_core.method.view_search.ViewSearch`: a sweep about
the vertical axis at the object's apparent size and depth, the best rotations refined) and scored by how well
its visible silhouette and depth match the object's mask and points there. The sweep is cheap and already
ranks well, so only the ``shortlist`` models it ranks best get the refinement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting
from psdr_room_core.method.artifacts import Camera, Candidate, ObjectMesh
from psdr_room_core.method.backs import BACKED
from psdr_room_core.method.objects import ObjectQuery
from psdr_room_core.method.silhouette import MeshCaster
from psdr_room_core.method.sizes import SizePrior
from psdr_room_core.method.view_search import SearchParams, ViewSearch, ViewTarget

if TYPE_CHECKING:
    from psdr_room_core.libraries.object_db import ObjectDatabase


class SilhouetteRetrieval:
    """Rank models by how well each, posed by the view search, explains the object's mask and depth at a real
    size: score ``1 / (1 + error)`` (:class:`~psdr_room_core.method.view_search.ViewFit`), the error holding the
    size prior (:class:`~psdr_room_core.method.sizes.SizePrior`: ``size_weight · |ln scale|``, database models are
    in metres, plus ``range_weight`` × how far the posed model is outside its category's real sizes) and what the
    pose reaching beyond the query's room box costs (``room_weight`` per metre), and ``back_weight`` for a model
    that stands with its back to a wall posed with its back to the camera, ``wall_weight`` per metre the wall behind it
    is farther than the nearest (:mod:`~psdr_room_core.method.backs`).
    Every model is scored so at its best moment-matched start; the ``shortlist`` best, or the best
    ``shortlist_share`` of them where that is more (at least ``k``; ``shortlist`` 0: all), are refined and ranked
    by their refined score."""

    def __init__(
        self,
        database: str = "builtin",
        fraction: float = 1.0,
        seed: int = 0,
        n_yaw: int = 12,
        refine: int = 2,
        coarse: int = 1,
        explore: int = 3,
        polish: int = 2,
        halvings: int = 2,
        render_width: int = 160,
        max_pixels: int = 3000,
        size_weight: float = 0.3,
        range_weight: float = 5.0,
        box_weight: float = 0.5,
        room_weight: float = 2.0,
        back_weight: float = 0.5,
        wall_weight: float = 0.1,
        shortlist: int = 12,
        shortlist_share: float = 0.2,
    ) -> None:
        self.spec = (str(database), float(fraction), int(seed))
        self.search = SearchParams(
            n_yaw=int(n_yaw),
            refine=int(refine),
            coarse=int(coarse),
            explore=int(explore),
            polish=int(polish),
            halvings=int(halvings),
            turns=[],
            box_weight=float(box_weight),
            room_weight=float(room_weight),
            back_weight=float(back_weight),
            wall_weight=float(wall_weight),
        )
        self.render_width = int(render_width)
        self.max_pixels = int(max_pixels)
        self.size_weight, self.range_weight = float(size_weight), float(range_weight)
        self.shortlist, self.shortlist_share = int(shortlist), float(shortlist_share)
        self._db: ObjectDatabase | None = None
        self._casters: dict[str, MeshCaster] = {}

    @property
    def database(self) -> ObjectDatabase:
        if self._db is None:
            from psdr_room_core.libraries.object_db.opening import open_database  # loaded when first used

            self._db = open_database(*self.spec)
        return self._db

    def describe(self) -> str:
        database, fraction, seed = self.spec
        return f"silhouette over {database} database" + (f" ({fraction:.0%}, seed {seed})" if fraction < 1 else "")

    def thumbnail(self, model_id: str) -> np.ndarray:
        return self.database.thumbnails(model_id, views=[0])[0]

    def mesh(self, model_id: str) -> ObjectMesh:
        from psdr_room_core.libraries.object_db.opening import object_mesh

        return object_mesh(self.database, model_id)

    def category(self, model_id: str) -> str:
        return self.database.record(model_id).category

    def rank(self, query: ObjectQuery, camera: Camera, camera_to_world: np.ndarray, k: int) -> list[Candidate]:
        models = [r for name in query.categories for r in self.database.category(name)] or list(self.database.records)
        target = ViewTarget.build(
            camera,
            camera_to_world,
            query.mask,
            query.points,
            query.scene_points,
            self.render_width,
            self.max_pixels,
            query.box,
            query.room,
        )
        starts = []
        for record in models:
            mesh = self.database.mesh(record.id)
            prior = SizePrior.of(record.category, record.extent, self.size_weight, self.range_weight)
            search = ViewSearch(
                target,
                mesh.vertices,
                mesh.faces,
                self.search,
                caster=self._caster(record.id, mesh),
                prior=prior,
                backed=record.category in BACKED,
            )
            starts.append((self.score(search.start[0]), record, search))
        starts.sort(key=lambda s: (-s[0], s[1].id))
        keep = len(starts)
        if self.shortlist > 0:
            keep = max(self.shortlist, k, math.ceil(self.shortlist_share * len(starts)))
        fits = [(record, search.finish()) for _, record, search in starts[:keep]]
        scored = [
            Candidate(record.id, self.score(fit.error), record.category, {"iou": fit.iou, **fit.terms})
            for record, fit in fits
        ]
        scored.sort(key=lambda c: (-c.score, c.model_id))
        return scored[:k]

    def _caster(self, model_id: str, mesh: ObjectMesh) -> MeshCaster:
        """The model's ray caster, built once per retrieval (its hierarchy serves every object and pose)."""
        if model_id not in self._casters:
            self._casters[model_id] = MeshCaster(mesh.vertices, mesh.faces)
        return self._casters[model_id]

    @staticmethod
    def score(error: float) -> float:
        """A posed model's score from its error (size prior included): higher is better, 1 for a perfect fit at
        the model's own size."""
        return 1.0 / (1.0 + error)


@dataclass
class SilhouetteSettings:
    database: str = setting()
    fraction: float = setting(gt=0, le=1)
    seed: int = setting()
    n_yaw: int = setting(ge=1)
    refine: int = setting(ge=0)
    coarse: int = setting(ge=0)
    explore: int = setting(ge=0)
    polish: int = setting(ge=0)
    halvings: int = setting(ge=0)
    render_width: int = setting(ge=16)
    max_pixels: int = setting(ge=0)
    size_weight: float = setting(ge=0)
    range_weight: float = setting(ge=0)
    box_weight: float = setting(ge=0)
    room_weight: float = setting(ge=0)
    back_weight: float = setting(ge=0)
    wall_weight: float = setting(ge=0)
    shortlist: int = setting(ge=0)
    shortlist_share: float = setting(ge=0, le=1)


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation(
        "retrieval", "silhouette", SilhouetteRetrieval, version="5", params=SilhouetteSettings, reads_files=False
    )


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import ObjectRetriever

    _SilhouetteRetrieval_is_a_retrieval: type[ObjectRetriever] = SilhouetteRetrieval
