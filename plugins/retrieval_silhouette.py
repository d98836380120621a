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
from psdr_room_core.method.params import SearchParams, SizePriorWeights
from psdr_room_core.method.silhouette import MeshCaster
from psdr_room_core.method.sizes import SizePrior
from psdr_room_core.method.view_search import ViewSearch, ViewTarget

if TYPE_CHECKING:
    from psdr_room_core.libraries.object_db import ObjectDatabase


class SilhouetteRetrieval:
    """Rank models by how well each, posed by the view search, explains the object's mask and depth at a real
    size: score ``1 / (1 + error)`` (:class:`~psdr_room_core.method.view_search.ViewFit`), the error holding the
    size prior (``size_prior``: :class:`~psdr_room_core.method.sizes.SizePrior`, database models are in metres) and
    the terms of the ``search``'s error (:class:`~psdr_room_core.method.view_search.SearchParams`: a pose reaching
    beyond the query's room box, a model that stands with its back to a wall showing the camera its back, ...).
    Every model is scored so at its best moment-matched start; the ``shortlist`` best, or the best
    ``shortlist_share`` of them where that is more (at least ``k``; ``shortlist`` 0: all), are refined and ranked
    by their refined score."""

    def __init__(
        self,
        *,
        database: str,
        fraction: float,
        seed: int,
        search: SearchParams,
        size_prior: SizePriorWeights,
        render_width: int,
        max_pixels: int,
        shortlist: int,
        shortlist_share: float,
    ) -> None:
        self.spec = (str(database), float(fraction), int(seed))
        self.search, self.size_prior = search, size_prior
        self.render_width, self.max_pixels = render_width, max_pixels
        self.shortlist, self.shortlist_share = shortlist, shortlist_share
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
        return self.rank_models(query, camera, camera_to_world, [r.id for r in models], k)

    def rank_models(
        self, query: ObjectQuery, camera: Camera, camera_to_world: np.ndarray, model_ids: list[str], k: int
    ) -> list[Candidate]:
        """The ``k`` of ``model_ids`` that, posed, best explain ``query``, best first."""
        models = [self.database.record(model_id) for model_id in model_ids]
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
            query.seen,
        )
        starts = []
        for record in models:
            mesh = self.database.mesh(record.id)
            prior = SizePrior.of(
                record.category, record.extent, self.size_prior.scale_weight, self.size_prior.range_weight
            )
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
    """``retrieval=silhouette``: which database, how each model is posed and what its error holds, which models
    are refined."""

    database: str = setting(
        doc="The object database: builtin (the shipped library, `psdr-room-db list`) or a folder in its format "
        "(e.g. converted 3D-FUTURE)."
    )
    fraction: float = setting(
        gt=0,
        le=1,
        doc="A random fraction of the database's models per category is used (the paper's Fig. 10 ablation).",
    )
    seed: int = setting(doc="Seed of that random fraction.")
    search: SearchParams = setting(
        doc="The view search each model is posed by (:mod:`psdr_room_core.method.view_search`)."
    )
    size_prior: SizePriorWeights = setting(doc="Each pose's size prior (priors.size, as place_objects').")
    render_width: int = setting(ge=16, doc="Silhouettes are compared at this width, pixels ...")
    max_pixels: int = setting(
        ge=0, doc="... or narrower where the object would cover more pixels than this (speed; 0: no limit)."
    )
    shortlist: int = setting(
        ge=0, doc="Only the models the rotation sweep ranks best are refined: this many (at least top_k; 0: all) ..."
    )
    shortlist_share: float = setting(
        ge=0, le=1, doc="... or this share of them where more (a label naming no category ranks all the models)."
    )


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation(
        "retrieval", "silhouette", SilhouetteRetrieval, version="5", params=SilhouetteSettings, reads_files=False
    )


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import ObjectRetriever

    _SilhouetteRetrieval_is_a_retrieval: type[ObjectRetriever] = SilhouetteRetrieval
