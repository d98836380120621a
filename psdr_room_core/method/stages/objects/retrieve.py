"""The model search (paper §4.3, "Model search"): the database models that best explain each object segment."""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import Any

import numpy as np

from psdr_room_core.engine.dag import StageContext

from ...artifacts import Camera, Candidate, Image, ObjectCandidates, Panoptic, PointCloud, RoomBox
from ...capabilities import ObjectRetriever
from ...labels import meaning
from ...objects import OBJECT_CATEGORIES, ObjectQuery, object_queries
from ...visualize import candidate_sheet
from ..settings import RetrieveObjects

log = logging.getLogger("psdr_room")


def retrieve_objects(
    ctx: StageContext, image: Image, panoptic: Panoptic, cloud: PointCloud, camera: Camera, room: RoomBox
) -> ObjectCandidates:
    """Rank ``top_k`` database models for every object segment with the ``retrieval`` capability (§4.3), among
    the categories its label names (:mod:`~psdr_room_core.method.labels`). A guessed segment's label may mislead
    (the detector calls desks "bed"): its alternates are ranked too, and taken only where their best scores
    ``alternate_margin`` (a share) above the label's own best: the shape says otherwise. Both decisions are
    logged, as are segments whose label names nothing the database holds; segments under ``min_points`` depth
    points or ``min_pixels`` pixels are left out."""
    settings = ctx.settings(RetrieveObjects)
    retriever = ctx.impl("retrieval", ObjectRetriever)
    c2w = np.asarray(room.camera_to_world)
    queries = object_queries(image, panoptic, cloud, room, settings.min_points, settings.min_pixels)
    unmodelled = [
        f"{s.id}:{s.label}"
        for s in panoptic.segments
        if s.category in OBJECT_CATEGORIES and meaning(s.label, s.category) is None
    ]
    if unmodelled:
        log.info("retrieve_objects: not in the object database, left out: %s", ", ".join(unmodelled))
    ranked = {
        q.segment_id: _rank_by_label(
            retriever, q, camera=camera, c2w=c2w, k=settings.top_k, margin=settings.alternate_margin
        )
        for q in ctx.progress(queries, total=len(queries))
    }
    return ObjectCandidates(
        ranked=ranked,
        labels={q.segment_id: q.label for q in queries},
        source=retriever.describe(),
        sheet=candidate_sheet(queries, ranked, retriever),
    )


def _rank_by_label(
    retriever: Any, q: ObjectQuery, *, camera: Camera, c2w: np.ndarray, k: int, margin: float
) -> list[Candidate]:
    """The ``k`` best models among the label's categories, or among its alternates where the shape says so."""
    own = retriever.rank(q, camera, c2w, k)
    if not q.alternates:
        return own
    other = retriever.rank(replace(q, categories=q.alternates), camera, c2w, k)
    if not other:
        return own
    best_own = own[0].score if own else 0.0
    taken = other[0].score > (1.0 + margin) * best_own
    log.info(
        "retrieve_objects: segment %d '%s' %s %s (%s %.3f against %s %.3f)",
        q.segment_id,
        q.label,
        "is a" if taken else "stays a",
        other[0].category if taken else (own[0].category if own else q.label),
        other[0].model_id,
        other[0].score,
        own[0].model_id if own else "-",
        best_own,
    )
    return other if taken else own
