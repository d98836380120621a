"""Initial object poses (paper §4.3, "Coarse geometry prediction"): each object's model posed on its support at
its real size, then the scene made physically possible."""

from __future__ import annotations

import logging
import math
from typing import Any, NamedTuple

import cv2
import numpy as np

from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError

from ...artifacts import (
    Camera,
    Candidate,
    Image,
    ObjectCandidates,
    ObjectMesh,
    Panoptic,
    Placement,
    Placements,
    PointCloud,
    RoomBox,
    vec3,
)
from ...backs import BACKED
from ...capabilities import ObjectRetriever
from ...objects import ObjectQuery, best_yaw, initial_pose, object_queries, support_relations, wall_frame
from ...physical import prompt_scores, settle_logged, support_top
from ...sizes import SizePrior
from ...view_search import ViewTarget, fit_view
from ..settings import PlaceObjects

log = logging.getLogger("psdr_room")


def place_objects(
    ctx: StageContext,
    candidates: ObjectCandidates,
    image: Image,
    panoptic: Panoptic,
    cloud: PointCloud,
    camera: Camera,
    room: RoomBox,
) -> Placements:
    """Initial poses (§4.3) with the support rules (floor, parent, wall), at real sizes, made physically possible.

    Each object's model (its best candidate, or the one ``pick`` names) is posed on each support the rules allow
    (:func:`~psdr_room_core.method.objects.support_relations`), parents before the children on them: by the
    occlusion-aware view search at the object's apparent size and depth (``init=silhouette``,
    :func:`_searched_pose`) or from the points' median and radius as the paper does (``init=radius``,
    :func:`_radius_pose`). An object the segmentation guessed (its segment has a ``score``) is dropped, and
    logged, when the posed model's visible silhouette overlaps its mask by less than ``prune.min_iou``. Then
    :func:`~psdr_room_core.method.physical.settle` drops the objects that need an implausible size and those
    that occupy another's space (duplicates), and moves the rest inside the room and out of each other;
    segments a person drew are kept whatever the fit (scaled into range)."""
    settings = ctx.settings(PlaceObjects)
    retriever = ctx.impl("retrieval", ObjectRetriever)
    # set up: the objects to place, each one's model, and what supports what
    cam = camera.resized(min(settings.render_width, camera.width))
    queries = [
        q
        for q in object_queries(image, panoptic, cloud, room, settings.min_points, settings.min_pixels)
        if candidates.ranked.get(q.segment_id)
    ]
    chosen = _chosen_models(queries, candidates, settings.pick)
    categories = {sid: retriever.category(model_id) for sid, model_id in chosen.items()}
    relations = support_relations(queries, panoptic.mask("floor"), room, settings.support, categories)
    guessed = set(prompt_scores(panoptic))
    # search: each object's pose on the supports the rules allow (a dropped parent holds nothing)
    placement_of: dict[int, Placement] = {}
    pruned: list[str] = []
    parents_first = sorted(queries, key=lambda q: relations[q.segment_id][0][0] == "parent")
    for q in parents_first:
        model_id, category = chosen[q.segment_id], categories[q.segment_id]
        mesh = retriever.mesh(model_id)
        supports = [
            (kind, anchor) for kind, anchor in relations[q.segment_id] if kind != "parent" or anchor in placement_of
        ]
        supports = supports or [("free", None)]
        if settings.init == "silhouette":
            pose = _searched_pose(
                q,
                mesh,
                category,
                supports=supports,
                placement_of=placement_of,
                camera=camera,
                room=room,
                settings=settings,
            )
        else:
            pose = _radius_pose(
                q, mesh, support=supports[0], placement_of=placement_of, camera=cam, room=room, settings=settings
            )
        if q.segment_id in guessed and pose.view_iou is not None and pose.view_iou < settings.prune.min_iou:
            explains = f"explains {pose.view_iou:.2f} of its segment"
            pruned.append(f"{q.segment_id}:{q.label} ({model_id.split('/')[-1]}): {explains}")
            continue
        placement_of[q.segment_id] = _placement(q, pose, model_id=model_id, mesh=mesh, category=category, room=room)
    # decide: the guessed objects no posed model explains are dropped (above), the rest made physically possible
    if pruned:
        log.info("place_objects: dropped %d guessed object(s) no model explains: %s", len(pruned), ", ".join(pruned))
    objects = [placement_of[q.segment_id] for q in queries if q.segment_id in placement_of]
    settled = settle_logged(
        objects,
        room=room,
        camera=cam,
        panoptic=panoptic,
        physical=settings.physical,
        stage="place_objects",
        final=False,
    )
    # report
    return Placements(
        objects=settled.placements, extra={"pruned": pruned + settled.dropped, "settled": settled.changed}
    )


def _chosen_models(queries: list[ObjectQuery], candidates: ObjectCandidates, pick: Any) -> dict[int, str]:
    """Segment id → the model to place: its best candidate, or the one ``pick`` (segment id → rank or model id)
    names."""
    picks = {int(k): v for k, v in (pick or {}).items()}
    unknown = set(picks) - {q.segment_id for q in queries}
    if unknown:
        raise PsdrRoomError(
            f"place_objects.pick: no object segment {sorted(unknown)}; segments: "
            f"{sorted(q.segment_id for q in queries)} (see the candidates artifact)"
        )
    return {
        q.segment_id: _pick(candidates.ranked[q.segment_id], picks.get(q.segment_id), q.segment_id) for q in queries
    }


def _pick(candidates: list[Candidate], choice: Any, segment_id: int) -> str:
    """The chosen model: the best candidate, or ``place_objects.pick`` ``<rank>`` (0-based) / ``<model id>``."""
    if choice is None:
        return candidates[0].model_id
    if isinstance(choice, int) or (isinstance(choice, str) and choice.isdigit()):
        rank = int(choice)
        if not 0 <= rank < len(candidates):
            raise PsdrRoomError(
                f"place_objects.pick.{segment_id}={choice}: only {len(candidates)} candidates; "
                f"use a rank below {len(candidates)} or a model id"
            )
        return candidates[rank].model_id
    return str(choice)


class _Pose(NamedTuple):
    """An object's pose on one of its supports."""

    position: np.ndarray
    yaw: float
    scale: float
    support: str
    anchor: int | None
    view_iou: float | None
    """IoU of the model's visible silhouette with the mask (the view search's); None: not measured."""


def _searched_pose(
    q: ObjectQuery,
    mesh: ObjectMesh,
    category: str,
    *,
    supports: list[tuple[str, int | None]],
    placement_of: dict[int, Placement],
    camera: Camera,
    room: RoomBox,
    settings: PlaceObjects,
) -> _Pose:
    """The view search's best pose over ``supports`` (:func:`~psdr_room_core.method.view_search.fit_view`): it
    sweeps ``search.n_yaw`` rotations at the object's apparent size and depth and refines the best, occlusion
    aware, so the yaw is chosen where it can be seen, which the paper's small start cannot, and an object half
    hidden behind another keeps its whole size. Database models are real size, so the search's error holds the
    size prior of the model's category (``size_prior`` weights): a bed is not posed at twice its size to match
    a depth that may be off. A model that stands with its back to a wall pays ``search.back_weight`` for
    showing the camera its back and ``search.wall_weight`` per metre for backing onto a wall farther than the
    nearest (:mod:`~psdr_room_core.method.backs`). Where the segmenting network boxed the object in 3D
    (:attr:`~psdr_room_core.method.objects.ObjectQuery.seen`), its box is a start of the search and the
    ``search.seen_*_weight`` terms hold the pose near its depth and yaw."""
    prior = SizePrior.of(
        category, np.ptp(mesh.vertices, axis=0), settings.size_prior.scale_weight, settings.size_prior.range_weight
    )
    c2w = np.asarray(room.camera_to_world)
    target = ViewTarget.build(
        camera, c2w, q.mask, q.points, q.scene_points, settings.render_width, box=q.box, room=room, seen=q.seen
    )
    fits = [
        (
            fit_view(
                target,
                mesh.vertices,
                mesh.faces,
                params=settings.search,
                support_height=_support_height(k, a, placement_of=placement_of, points=q.points, room=room),
                prior=prior,
                backed=category in BACKED,
            ),
            k,
            a,
        )
        for k, a in supports
    ]
    view, kind, anchor = min(fits, key=lambda f: f[0].error)
    return _Pose(view.position, view.yaw, view.scale, kind, anchor, view.iou)


def _radius_pose(
    q: ObjectQuery,
    mesh: ObjectMesh,
    *,
    support: tuple[str, int | None],
    placement_of: dict[int, Placement],
    camera: Camera,
    room: RoomBox,
    settings: PlaceObjects,
) -> _Pose:
    """The paper's start on ``support``: centred on the points' median, ``radius_factor`` × the points' radius,
    the best of ``search.n_yaw`` rotations by silhouette L1 in ``camera`` (the render's)."""
    kind, anchor = support
    mask = cv2.resize(q.mask.astype(np.uint8), (camera.width, camera.height), interpolation=cv2.INTER_AREA) > 0
    position, scale = initial_pose(q.points, mesh.vertices, settings.radius_factor)
    c2w = np.asarray(room.camera_to_world)
    yaw, _ = best_yaw(camera, c2w, mesh.vertices, mesh.faces, position, scale, mask, settings.search.n_yaw)
    height = _support_height(kind, anchor, placement_of=placement_of, points=q.points, room=room)
    if height is not None:
        position[1] = height
    return _Pose(position, yaw, scale, kind, anchor, None)


def _support_height(
    kind: str, anchor: int | None, *, placement_of: dict[int, Placement], points: np.ndarray, room: RoomBox
) -> float | None:
    """Where a supported object's bottom stays: the room's floor, its parent's surface under its ``points``;
    None for wall and free objects."""
    if kind == "floor":
        return room.floor
    if kind == "parent":
        return support_top(placement_of[anchor], np.median(points[:, [0, 2]], axis=0))  # type: ignore[index]
    return None


def _placement(
    q: ObjectQuery, pose: _Pose, *, model_id: str, mesh: ObjectMesh, category: str, room: RoomBox
) -> Placement:
    """The object at ``pose``; on a wall, turned to face into the room with its back on the wall."""
    position, yaw = pose.position, pose.yaw
    if pose.support == "wall":
        assert pose.anchor is not None  # a wall support names its side of the box
        inward, _, offset = wall_frame(room, pose.anchor)
        yaw = math.atan2(inward[0], inward[2])  # the model's front (+Z) faces into the room
        depth = float(np.ptp(mesh.vertices[:, 2]))
        position = position + (offset + 0.5 * pose.scale * depth - inward @ position) * inward
    return Placement(
        segment_id=q.segment_id,
        label=q.label,
        model_id=model_id,
        mesh=mesh,
        position=vec3(position),
        yaw=float(yaw),
        scale=float(pose.scale),
        support=pose.support,
        anchor=pose.anchor,
        category=category,
        explained=pose.view_iou,
    )
