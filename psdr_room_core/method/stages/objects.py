"""Object stage (paper §4.3): retrieve a model per segmented object, initialise its pose from the point
cloud with support relations, then refine all poses jointly by differentiable rendering (eq. 3)."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Collection, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import cv2
import numpy as np
import torch

from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError

from ..artifacts import (
    Camera,
    Candidate,
    DepthMap,
    Image,
    ObjectCandidates,
    OptimizationLog,
    Panoptic,
    Placement,
    Placements,
    PointCloud,
    RoomBox,
    rotation_y,
    vec3,
)
from ..backs import BACKED, back_shown, wall_gap
from ..capabilities import ObjectRetriever, Optimizer, Renderer
from ..convergence import BestIterate, untimed
from ..geometry import TriangleMesh, weld
from ..grouping import Part, group_segments
from ..image_boxes import box_iou, mask_box
from ..labels import meaning
from ..objects import (
    OBJECT_CATEGORIES,
    ObjectQuery,
    best_yaw,
    initial_pose,
    object_queries,
    square_crop,
    support_relations,
    wall_frame,
)
from ..physical import PhysicalParams, Settled, interpenetrations, settle, support_top, weak_guesses
from ..silhouette import silhouette
from ..sizes import SizePrior, scale_range, size_excess
from ..solids import field_lookup, overlap, solid_of
from ..view_search import ViewTarget, fit_view
from ..visualize import plot_curves, segment_overlay
from .settings import FitObjects, GroupObjects, PlaceObjects, RetrieveObjects

log = logging.getLogger("psdr_room")


def group_objects(
    ctx: StageContext,
    image: Image,
    panoptic: Panoptic,
    cloud: PointCloud,
    camera: Camera,
    room: RoomBox,
    depth: DepthMap,
) -> dict[str, Any]:
    """One object per thing: merge the guessed segments that are parts of one object, by their geometry in the
    fitted room (:func:`~psdr_room_core.method.grouping.group_segments`: stacked parts of a bed or a sofa,
    segments occupying the same space) where the ``retrieval`` capability's best model of the whole's category
    explains the two together as well as apart, before the model search. Each pair judged is logged.

    Params: :class:`~.settings.GroupObjects`, the :class:`~psdr_room_core.method.grouping.GroupParams` fields and
    ``enabled`` (false passes the segmentation through).
    """
    group = ctx.settings(GroupObjects)
    if not group.enabled:
        return {"panoptic": panoptic, "cloud": cloud}
    retriever = ctx.impl("retrieval", ObjectRetriever)
    c2w = np.asarray(room.camera_to_world)
    rgb8 = image.to_uint8()
    scene = cloud.points.astype(np.float64) @ c2w[:3, :3].T + c2w[:3, 3]

    def judge(whole: str, union: Part, parts: Sequence[Part]) -> tuple[float, list[float]]:
        def best(part: Part) -> float:
            query = ObjectQuery(
                part.segment.id,
                part.segment.label,
                (whole,),
                part.mask,
                part.points,
                square_crop(rgb8, part.mask),
                scene,
                part.segment.box,
                room=room,
            )
            ranked = retriever.rank(query, camera, c2w, 1)
            return ranked[0].score if ranked else 0.0

        return best(union), [best(p) for p in parts]

    grouped, regrouped, notes = group_segments(
        panoptic, cloud, camera, room, depth.metric, group, judge, set(depth.unplaced)
    )
    for note in notes:
        log.info("group_objects: %s", note)
    return {"panoptic": grouped, "cloud": regrouped}


def retrieve_objects(
    ctx: StageContext, image: Image, panoptic: Panoptic, cloud: PointCloud, camera: Camera, room: RoomBox
) -> ObjectCandidates:
    """Rank ``top_k`` database models for every object segment with the ``retrieval`` capability, among the
    categories its label names (:mod:`~psdr_room_core.method.labels`). A guessed segment's label may mislead (the
    detector calls desks "bed"): its alternates are ranked too, and taken only where their best scores
    ``alternate_margin`` (a share) above the label's own best: the shape says otherwise. Both decisions are
    logged, as are segments whose label names nothing the database holds.

    Params: ``top_k``, ``alternate_margin``, ``min_points`` and ``min_pixels`` (smaller segments are left out).
    """
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
        q.segment_id: _rank_by_label(retriever, q, camera, c2w, settings.top_k, settings.alternate_margin)
        for q in ctx.progress(queries, total=len(queries))
    }
    return ObjectCandidates(
        ranked=ranked,
        labels={q.segment_id: q.label for q in queries},
        source=retriever.describe(),
        sheet=candidate_sheet(queries, ranked, retriever),
    )


def _rank_by_label(
    retriever: Any, q: ObjectQuery, camera: Camera, c2w: np.ndarray, k: int, margin: float
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


def candidate_sheet(
    queries: list[ObjectQuery], ranked: dict[int, list[Candidate]], retriever: Any, cell: int = 96
) -> np.ndarray | None:
    """One row per object: its crop, then each candidate's thumbnail with its id and score."""
    rows = []
    for q in queries:
        tiles = [_tile(q.crop, f"{q.segment_id}: {q.label}", cell)]
        tiles += [
            _tile(retriever.thumbnail(c.model_id), f"{c.model_id.split('/')[-1]} {c.score:.2f}", cell)
            for c in ranked[q.segment_id]
        ]
        row = np.full((cell + 14, cell * (1 + max(len(r) for r in ranked.values())), 3), 255, np.uint8)
        row[:, : cell * len(tiles)] = np.hstack(tiles)
        rows.append(row)
    return np.vstack(rows) if rows else None


def _tile(rgb8: np.ndarray, caption: str, cell: int) -> np.ndarray:
    scale = cell / max(rgb8.shape[:2])
    small = cv2.resize(
        rgb8, (max(1, round(rgb8.shape[1] * scale)), max(1, round(rgb8.shape[0] * scale))), interpolation=cv2.INTER_AREA
    )
    tile = np.full((cell + 14, cell, 3), 255, np.uint8)
    y0, x0 = (cell - small.shape[0]) // 2, (cell - small.shape[1]) // 2
    tile[y0 : y0 + small.shape[0], x0 : x0 + small.shape[1]] = small
    cv2.putText(tile, caption[:18], (2, cell + 11), cv2.FONT_HERSHEY_SIMPLEX, 0.32, (0, 0, 0), 1, cv2.LINE_AA)
    return tile


def _pick(candidates: list[Candidate], choice: Any, segment_id: int) -> str:
    """The chosen model: the best candidate, or ``objects`` pick ``<rank>`` (0-based) / ``<model id>``."""
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

    ``init=radius`` is the paper's: centre on the points' median, radius ``radius_factor`` × the points'
    radius, the best of ``search.n_yaw`` rotations by silhouette L1. ``init=silhouette`` (default) sweeps the same
    rotations at the object's apparent size and depth and refines the best by the occlusion-aware view search
    (:func:`~psdr_room_core.method.view_search.fit_view`): the yaw is chosen where it can be seen, which the small
    paper start cannot, and an object half hidden behind another keeps its whole size. Database models are real
    size, so the search's error holds the size prior of the model's category
    (:class:`~psdr_room_core.method.sizes.SizePrior`, ``size_prior`` weights): a bed is not posed at twice its
    size to match a depth that may be off. Beds, cabinets, shelves and refrigerators stand with their backs to a
    wall, so a pose showing the camera their back costs ``search.back_weight``, and one backing onto a wall farther
    than the nearest ``search.wall_weight`` per metre (:mod:`~psdr_room_core.method.backs`): a bed is not posed with
    its headboard towards the camera, nor turned a quarter turn to show its side.

    Objects the segmentation guessed (segments with a ``score``: ``segmentation=layout``'s discoveries) are
    dropped, and logged, when the posed model's visible silhouette overlaps the mask by less than
    ``prune.min_iou``. Then :func:`~psdr_room_core.method.physical.settle` (``physical``) drops the objects that
    need an implausible size and those that occupy another's space (duplicates), and moves the rest inside
    the room and out of each other. Segments a person drew are kept whatever the fit (scaled into range).

    Params: :class:`~.settings.PlaceObjects`: ``init``, ``pick`` (segment id → rank or model id),
    ``radius_factor``, ``render_width``, ``search`` (:class:`~psdr_room_core.method.view_search.SearchParams`),
    ``size_prior`` {``scale_weight``, ``range_weight``}, ``support``
    (:class:`~psdr_room_core.method.objects.SupportParams`), ``prune`` {``min_iou``}, ``physical``
    (:class:`~psdr_room_core.method.physical.PhysicalParams`), ``min_points``, ``min_pixels``.
    """
    settings = ctx.settings(PlaceObjects)
    retriever = ctx.impl("retrieval", ObjectRetriever)
    c2w = np.asarray(room.camera_to_world)
    cam = camera.resized(min(settings.render_width, camera.width))
    picks = {int(k): v for k, v in (settings.pick or {}).items()}
    queries = [
        q
        for q in object_queries(image, panoptic, cloud, room, settings.min_points, settings.min_pixels)
        if candidates.ranked.get(q.segment_id)
    ]
    unknown = set(picks) - {q.segment_id for q in queries}
    if unknown:
        raise PsdrRoomError(
            f"place_objects.pick: no object segment {sorted(unknown)}; segments: "
            f"{sorted(q.segment_id for q in queries)} (see the candidates artifact)"
        )
    search = settings.search
    chosen = {
        q.segment_id: _pick(candidates.ranked[q.segment_id], picks.get(q.segment_id), q.segment_id) for q in queries
    }
    categories = {sid: retriever.category(model_id) for sid, model_id in chosen.items()}
    relations = support_relations(queries, panoptic.mask("floor"), room, settings.support, categories)
    guessed = set(prompt_scores(panoptic))
    placed: dict[int, Placement] = {}
    pruned: list[str] = []
    order = sorted(queries, key=lambda q: relations[q.segment_id][0][0] == "parent")  # parents before children
    for q in order:
        model_id, category = chosen[q.segment_id], categories[q.segment_id]
        mesh = retriever.mesh(model_id)
        prior = SizePrior.of(
            category, np.ptp(mesh.vertices, axis=0), settings.size_prior.scale_weight, settings.size_prior.range_weight
        )
        supports = [(k, a) for k, a in relations[q.segment_id] if k != "parent" or a in placed] or [("free", None)]
        explained = None
        if (
            settings.init == "silhouette"
        ):  # each support the rules allow (a dropped parent holds nothing); the search picks
            target = ViewTarget.build(
                camera, c2w, q.mask, q.points, q.scene_points, settings.render_width, box=q.box, room=room
            )
            fits = [
                (
                    fit_view(
                        target,
                        mesh.vertices,
                        mesh.faces,
                        search,
                        _support_height(k, a, placed, q, room),
                        prior,
                        backed=category in BACKED,
                    ),
                    k,
                    a,
                )
                for k, a in supports
            ]
            view, kind, anchor = min(fits, key=lambda f: f[0].error)
            position, yaw, scale, explained = view.position, view.yaw, view.scale, view.iou
            if q.segment_id in guessed and view.iou < settings.prune.min_iou:
                pruned.append(
                    f"{q.segment_id}:{q.label} ({model_id.split('/')[-1]}): explains {view.iou:.2f} of its segment"
                )
                continue
        else:
            kind, anchor = supports[0]
            mask_target = cv2.resize(q.mask.astype(np.uint8), (cam.width, cam.height), interpolation=cv2.INTER_AREA) > 0
            position, scale = initial_pose(q.points, mesh.vertices, settings.radius_factor)
            yaw, _ = best_yaw(cam, c2w, mesh.vertices, mesh.faces, position, scale, mask_target, search.n_yaw)
            height = _support_height(kind, anchor, placed, q, room)
            if height is not None:
                position[1] = height
        if kind == "wall":
            assert anchor is not None  # a wall support names its side of the box
            inward, _, offset = wall_frame(room, anchor)
            yaw = math.atan2(inward[0], inward[2])  # the model's front (+Z) faces into the room
            depth = float(np.ptp(mesh.vertices[:, 2]))
            position = position + (offset + 0.5 * scale * depth - inward @ position) * inward
        placed[q.segment_id] = Placement(
            segment_id=q.segment_id,
            label=q.label,
            model_id=model_id,
            mesh=mesh,
            position=vec3(position),
            yaw=float(yaw),
            scale=float(scale),
            support=kind,
            anchor=anchor,
            category=category,
            explained=explained,
        )
    if pruned:
        log.info("place_objects: dropped %d guessed object(s) no model explains: %s", len(pruned), ", ".join(pruned))
    objects = [placed[q.segment_id] for q in queries if q.segment_id in placed]
    settled = _settle(objects, room, cam, panoptic, settings.physical, "place_objects", final=False)
    return Placements(
        objects=settled.placements, extra={"pruned": pruned + settled.dropped, "settled": settled.changed}
    )


def _settle(
    objects: list[Placement],
    room: RoomBox,
    camera: Camera,
    panoptic: Panoptic,
    physical: PhysicalParams,
    stage: str,
    final: bool,
) -> Settled:
    """:func:`~psdr_room_core.method.physical.settle` with its changes logged (segments with no score were drawn;
    the others' prompt scores weigh their evidence)."""
    drawn = {s.id for s in panoptic.segments if s.score is None}
    scores = prompt_scores(panoptic)
    counts = np.bincount(panoptic.ids.ravel())
    pixels = {s.id: int(counts[s.id]) for s in panoptic.segments if s.id < len(counts)}
    settled = settle(
        objects, room, camera, drawn, pixels, physical, final, panoptic.ids_at(camera.width, camera.height), scores
    )
    for note in settled.changed:
        log.info("%s: %s", stage, note)
    if settled.dropped:
        log.info("%s: dropped %d object(s): %s", stage, len(settled.dropped), "; ".join(settled.dropped))
    return settled


def prompt_scores(panoptic: Panoptic) -> dict[int, float]:
    """Segment id → its prompt's score, for the segments guessed automatically (a drawn segment has none)."""
    return {s.id: s.score for s in panoptic.segments if s.score is not None}


def _support_height(
    kind: str, anchor: int | None, placed: dict[int, Placement], q: ObjectQuery, room: RoomBox
) -> float | None:
    """Where a supported object's bottom stays: the room's floor, its parent's surface under its points; None for
    wall and free objects."""
    if kind == "floor":
        return room.floor
    if kind == "parent":
        return support_top(placed[anchor], np.median(q.points[:, [0, 2]], axis=0))  # type: ignore[index]
    return None


# ------------------------------------------------------------------------------------------ refinement
@dataclass(frozen=True)
class ObjectTargets:
    """Eq. 3's targets at render resolution: per-object coverage and the depth-weighted coverage."""

    masks: np.ndarray
    """[P,h,w] area-filtered masks of the objects' segments."""
    masked_depth: np.ndarray
    """[P,h,w] mask × mean depth of the segment's pixels with valid depth."""
    weights: np.ndarray
    """[P,h,w] how much each pixel counts in the object's terms: 0 on the free pixels of a prompted segment
    (its prompt box outside its mask: the object may reach there or not), 1 elsewhere."""
    boxes: np.ndarray
    """[P,4] each segment's prompt box (x0, y0, x1, y1) at render resolution; NaN where it has none."""


def object_targets(placements: Placements, panoptic: Panoptic, depth: DepthMap, size: tuple[int, int]) -> ObjectTargets:
    def area(x: np.ndarray) -> np.ndarray:
        return cv2.resize(x.astype(np.float32), size, interpolation=cv2.INTER_AREA)

    boxes = {s.id: s.box for s in panoptic.segments}
    masks, masked, weights, prompts = [], [], [], []
    to_render = size[0] / panoptic.ids.shape[1]
    for p in placements.objects:
        mask = panoptic.ids == p.segment_id
        valid = mask & depth.valid
        weight = area(valid)
        mean_depth = np.where(weight > 0, area(np.where(valid, depth.depth, 0.0)) / np.maximum(weight, 1e-6), 0.0)
        coverage = area(mask)
        masks.append(coverage)
        masked.append(coverage * mean_depth)
        free = np.zeros(mask.shape, bool)
        box = boxes.get(p.segment_id)
        if box is not None:
            x0, y0, x1, y1 = (max(0, int(round(v))) for v in box)
            free[y0:y1, x0:x1] = True
        weights.append(1.0 - area(free & ~mask))
        prompts.append(np.full(4, np.nan) if box is None else np.asarray(box, np.float64) * to_render)
    return ObjectTargets(
        masks=np.stack(masks).astype(np.float32),
        masked_depth=np.stack(masked).astype(np.float32),
        weights=np.stack(weights).astype(np.float32),
        boxes=np.stack(prompts),
    )


@dataclass(frozen=True)
class Explained:
    """How well each object's render explains its segment."""

    mask: np.ndarray
    """[P] render IoU with the segment's mask."""
    box: np.ndarray
    """[P] IoU of the render's box with the segment's prompt box (the detector's box reaches the thin legs and
    the floor that a cut mask loses); NaN where the segment has no prompt box or the object is out of view."""


def mask_ious(masks: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """[P] soft IoU of each rendered mask [P,h,w] with its target coverage [P,h,w]."""
    return (masks * targets).sum((1, 2)) / (masks + targets - masks * targets).sum((1, 2)).clamp_min(1e-6)


def explained(masks: torch.Tensor, targets: ObjectTargets) -> Explained:
    """:class:`Explained` of rendered ``masks`` [P,h,w] (a pixel over half covered is in a render's box)."""
    ious = mask_ious(masks, torch.from_numpy(targets.masks))
    boxes = np.full(len(masks), np.nan)
    for i, (mask, prompt) in enumerate(zip(masks.numpy() > 0.5, targets.boxes)):
        box = mask_box(mask)
        if box is not None and not np.isnan(prompt).any():
            boxes[i] = box_iou(prompt, box[None])[0]
    return Explained(mask=ious.numpy(), box=boxes)


def gaussian_pyramid_blur(masks: torch.Tensor, sigmas: tuple[float, ...]) -> torch.Tensor:
    """[P,H,W] masks blurred by Gaussians of each sigma (pixels), stacked: [S,P,H,W]."""
    blurred = []
    for sigma in sigmas:
        radius = max(1, int(3 * sigma))
        x = torch.arange(-radius, radius + 1, dtype=torch.float32)
        kernel = torch.exp(-0.5 * (x / sigma) ** 2)
        kernel = kernel / kernel.sum()
        m = masks[:, None]
        m = torch.nn.functional.conv2d(
            torch.nn.functional.pad(m, (radius, radius, 0, 0), mode="replicate"), kernel.view(1, 1, 1, -1)
        )
        m = torch.nn.functional.conv2d(
            torch.nn.functional.pad(m, (0, 0, radius, radius), mode="replicate"), kernel.view(1, 1, -1, 1)
        )
        blurred.append(m[:, 0])
    return torch.stack(blurred)


class PoseModel:
    """Differentiable object poses with their support constraints (§4.3): scale, horizontal translation and
    yaw per object; floor objects keep their bottom on the floor, children on the spot of their parent's
    surface they were placed on (its height scales with the parent), wall objects slide and scale along their
    wall facing into the room. :meth:`size_penalty` is the size prior of each object's category, :meth:`back_penalty`
    and :meth:`wall_penalty` what showing the camera its back and backing onto a far wall cost a piece that stands
    with its back to a wall; ``weak``: the segment ids of weak guesses, which yield in :meth:`collision_penalty`."""

    def __init__(self, placements: Placements, room: RoomBox, unit: float, weak: Collection[int] = ()) -> None:
        self.placements = placements.objects
        self.room = room
        self.unit = unit
        self.index = {p.segment_id: i for i, p in enumerate(self.placements)}
        self.rest = {
            i: (p.position[1] - self.placements[self.parent(p)].position[1]) / self.placements[self.parent(p)].scale
            for i, p in enumerate(self.placements)
            if p.support == "parent"
        }
        """Child index → its height above its parent's origin, in the parent's model units."""
        self.ranges = [scale_range(p.category, np.ptp(p.mesh.vertices, axis=0)) for p in self.placements]
        self.pairs = [
            (i, j)
            for i, a in enumerate(self.placements)
            for j, b in enumerate(self.placements)
            if i < j and a.anchor != b.segment_id and b.anchor != a.segment_id and _near(a, b)
        ]
        """Pairs of objects that may touch (neither stands on the other): their interpenetration is paid for."""
        self.weak = {i for i, p in enumerate(self.placements) if p.segment_id in weak}
        """The objects of weak guesses (``weak``: their segment ids): they yield to surer ones."""
        self.solids = {i: solid_of(self.placements[i]) for pair in self.pairs for i in pair}
        self.fields = {i: torch.from_numpy(solid.depth)[None, None] for i, solid in self.solids.items()}
        self.samples = {
            i: torch.from_numpy(solid.centres[:: max(1, len(solid.centres) // 200)]) for i, solid in self.solids.items()
        }
        n = len(self.placements)
        self.theta = {
            "translation": torch.zeros(n, 3, requires_grad=True),
            "log_scale": torch.zeros(n, requires_grad=True),
            "yaw": torch.zeros(n, requires_grad=True),
        }
        self.welded = [weld(TriangleMesh(p.mesh.vertices, p.mesh.faces)) for p in self.placements]
        self.backed = [p.category in BACKED and p.support != "wall" for p in self.placements]
        """Per object: it stands with its back to a wall and may turn (wall objects face into the room)."""

    def parent(self, placement: Placement) -> int:
        """The index of the object ``placement`` rests on (its support is ``parent``)."""
        assert placement.anchor is not None
        return self.index[placement.anchor]

    def poses(self) -> list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]]:
        """(position [3], yaw (radians), scale) per object, constraints applied."""
        t, log_s, yaw_deg = self.theta["translation"], self.theta["log_scale"], self.theta["yaw"]
        poses: list[Any] = [None] * len(self.placements)
        order = sorted(range(len(self.placements)), key=lambda i: self.placements[i].support == "parent")
        for i in order:
            p = self.placements[i]
            scale = p.scale * torch.exp(log_s[i])
            position = torch.tensor(p.position, dtype=torch.float32)
            yaw = p.yaw + torch.deg2rad(yaw_deg[i])
            if p.support == "wall":
                assert p.anchor is not None  # a wall support names its side of the box
                frame = wall_frame(self.room, p.anchor)
                inward, tangent = (torch.as_tensor(v, dtype=torch.float32) for v in frame[:2])
                offset = frame[2]
                depth = float(np.ptp(p.mesh.vertices[:, 2]))
                moved = position + self.unit * (t[i, 0] * tangent + t[i, 1] * torch.tensor([0.0, 1.0, 0.0]))
                position = moved + (offset + 0.5 * scale * depth - inward @ moved) * inward
                yaw = torch.tensor(p.yaw, dtype=torch.float32)
            else:
                horizontal = self.unit * torch.stack([t[i, 0], torch.zeros(()), t[i, 2]])
                position = position + horizontal
                if p.support == "parent":
                    parent_position, _, parent_scale = poses[self.parent(p)]
                    top = parent_position[1] + parent_scale * self.rest[i]
                    position = torch.stack([position[0], top, position[2]])
            poses[i] = (position, yaw, scale)
        return poses

    def vertices(self) -> dict[str, torch.Tensor]:
        """World positions of each object's welded mesh."""
        out = {}
        for i, (position, yaw, scale) in enumerate(self.poses()):
            local = torch.as_tensor(self.welded[i].vertices, dtype=torch.float32)
            out[f"object_{self.placements[i].segment_id}"] = (scale * local) @ _rotation(yaw).T + position
        return out

    def size_penalty(self, scale_weight: float, range_weight: float) -> torch.Tensor:
        """[P] each object's size prior (:class:`~psdr_room_core.method.sizes.SizePrior`) at its current scale."""
        log_scale = torch.stack([torch.log(scale) for _, _, scale in self.poses()])
        low = torch.tensor([math.log(lo) if lo > 0 else -math.inf for lo, _ in self.ranges])
        high = torch.tensor([math.log(hi) for _, hi in self.ranges])
        outside = torch.relu(low - log_scale) + torch.relu(log_scale - high)
        return scale_weight * log_scale.abs() + range_weight * outside

    def back_penalty(self) -> torch.Tensor:
        """[P] how far each object that stands with its back to a wall shows the camera its back
        (:func:`~psdr_room_core.method.backs.back_shown`; 0 for the others)."""
        eye = np.asarray(self.room.camera_to_world)[:3, 3]
        shown = [
            back_shown(torch.sin(yaw), torch.cos(yaw), position[0] - float(eye[0]), position[2] - float(eye[2]))
            if backed
            else torch.zeros(())
            for (position, yaw, _), backed in zip(self.poses(), self.backed)
        ]
        return torch.stack(shown)

    def wall_penalty(self) -> torch.Tensor:
        """[P] how much farther (metres) than the nearest wall the wall behind each object that stands with its back
        to one is (:func:`~psdr_room_core.method.backs.wall_gap`; 0 for the others)."""
        centre, half = np.asarray(self.room.center), np.asarray(self.room.half_size)
        turn, sine, cosine = float(self.room.yaw), math.sin(self.room.yaw), math.cos(self.room.yaw)
        gaps = []
        for (position, yaw, _), backed in zip(self.poses(), self.backed):
            if not backed:
                gaps.append(torch.zeros(()))
                continue
            x, z = position[0] - float(centre[0]), position[2] - float(centre[2])  # into the room's frame: R_y(-yaw)
            local_x, local_z = cosine * x - sine * z, sine * x + cosine * z
            gaps.append(
                wall_gap(torch.sin(yaw - turn), torch.cos(yaw - turn), local_x, local_z, float(half[0]), float(half[2]))
            )
        return torch.stack(gaps)

    def collision_penalty(self) -> torch.Tensor:
        """[P] how deep each object passes through the others: for each pair, the mean depth (metres) of each
        one's sampled volume inside the other, both ways, half to each. Between a weak guess and a surer object
        (:attr:`weak`) the surer one's pose is held (no gradient): a guess never pushes what the photo is surer
        of, as in the settling (:func:`~psdr_room_core.method.physical.settle`)."""
        if not self.pairs:
            return torch.zeros(len(self.placements))
        moving = self.poses()
        partners: dict[tuple[int, bool], list[int]] = {}  # (a, a's pose held) → the others
        for i, j in self.pairs:
            for a, b in ((i, j), (j, i)):
                partners.setdefault((a, self.holds(a, b)), []).append(b)
        poses = {  # each solid's pose, and its held copy where a weak guess meets it
            (i, h): tuple(v.detach() for v in moving[i]) if h else moving[i] for i, h in partners
        }
        rotations = {key: _rotation(pose[1]) for key, pose in poses.items()}
        world = {key: pose[2] * self.samples[key[0]] @ rotations[key].T + pose[0] for key, pose in poses.items()}
        depth: dict[tuple[int, int], torch.Tensor] = {}  # (a, b): b's samples' mean depth inside a, metres
        for (a, a_held), others in partners.items():
            position, _, scale = poses[(a, a_held)]
            samples = torch.cat([world[(b, self.holds(b, a))] for b in others])
            inside = scale * field_lookup(
                self.solids[a], self.fields[a], (samples - position) @ rotations[(a, a_held)] / scale
            )
            for b, part in zip(others, torch.split(inside, [len(self.samples[b]) for b in others])):
                depth[(a, b)] = part.mean()
        shares: list[list[torch.Tensor]] = [[] for _ in self.placements]
        for i, j in self.pairs:
            half = 0.5 * (depth[(i, j)] + depth[(j, i)])
            shares[i].append(half)
            shares[j].append(half)
        return torch.stack([torch.stack(s).sum() if s else torch.zeros(()) for s in shares])

    def holds(self, a: int, b: int) -> bool:
        """Whether object ``a`` holds its pose against ``b``: ``b`` is a weak guess and ``a`` is not."""
        return a not in self.weak and b in self.weak

    def room_penalty(self, vertices: dict[str, torch.Tensor]) -> torch.Tensor:
        """[P] how far (metres) each object's mesh reaches beyond the room box, at its farthest vertex."""
        rotation = torch.as_tensor(rotation_y(self.room.yaw), dtype=torch.float32)
        centre = torch.as_tensor(np.asarray(self.room.center), dtype=torch.float32)
        half = torch.as_tensor(np.asarray(self.room.half_size), dtype=torch.float32)
        return torch.stack([torch.relu(((v - centre) @ rotation).abs() - half).max() for v in vertices.values()])

    def placements_now(self) -> list[Placement]:
        return [
            replace(p, position=vec3(position.detach()), yaw=float(yaw), scale=float(scale))
            for p, (position, yaw, scale) in zip(self.placements, self.poses())
        ]


def fit_objects(
    ctx: StageContext,
    placements: Placements,
    camera: Camera,
    room: RoomBox,
    depth: DepthMap,
    panoptic: Panoptic,
    image: Image,
) -> dict[str, Any]:
    """Refine all object poses jointly (§4.3, eq. 3) by differentiable rendering of their masks and depth.

    Minimises ``Σ_i L1(M_i^r · D^r, M_i^t · D_i) / d + w_blur · Σ_i L1(G(M_i^r), G(M_i^t)) + Σ_i P_i(s_i) +
    w_room · Σ_i R_i + w_collision · Σ_i C_i + w_back · Σ_i B_i + w_wall · Σ_i W_i`` with ``d`` the targets'
    98th-percentile depth, ``G`` Gaussian blurs of ``blur_sigmas`` pixels (a prompted segment's free pixels, its
    prompt box outside its mask, left out: :class:`ObjectTargets`), ``P_i`` the size prior of object i's category on
    its scale (``size_prior`` weights: :meth:`PoseModel.size_penalty`), ``R_i`` how far it reaches beyond the room box
    (:meth:`PoseModel.room_penalty`), ``C_i`` how deep it passes through the others
    (:meth:`PoseModel.collision_penalty`; a weak guess, a prompt scored below ``physical.weak_score``, never pushes a
    surer object), ``B_i`` how far it shows the camera its back where it stands with its back to a wall
    (:meth:`PoseModel.back_penalty`) and ``W_i`` how much farther than the nearest wall the wall behind it is
    (:meth:`PoseModel.wall_penalty`), over each object's scale, horizontal translation and yaw under
    its support constraint (:class:`PoseModel`), with the ``renderer`` and the ``optimizer``. The fit runs until the
    yaw test (or a plateau of the loss before it), then, where an object turned or the loss had not flattened, on to
    ``iterations`` (or a plateau); each phase leaves its best iterate. An object the fit left explaining less than
    ``keep_share`` of what it explained when placed, whose render's box the fit took off its prompt box
    (``same_box``), or whose size it took outside its category's (``physical.size_tolerance``), goes back to its
    placed pose (:func:`restore_lost`), unless that costs the settling an object (:func:`settle_restored`). The
    fitted scene is then made physically possible
    (:func:`~psdr_room_core.method.physical.settle`, ``physical``: place_objects' settings): real sizes, inside the
    room (which grows where an object the photo shows cannot be brought inside it: the room box after the objects,
    ``room``), no interpenetration beyond ``physical.penetration``, duplicates dropped; what remains passing
    through something is reported.

    Params (:class:`~.settings.FitObjects`): ``iterations``, ``render_width``, ``blur_sigmas``, ``blur_weight``,
    ``size_prior`` {``scale_weight``, ``range_weight``}, ``room_weight``, ``collision_weight``, ``back_weight``,
    ``wall_weight``, ``learning_rates`` {translation (room half-size units), log_scale, yaw (degrees)}, ``yaw_test``
    {``at``: fraction of the iterations after which :func:`try_yaw_turns` runs, ``angles``, ``min_gain``},
    ``keep_share``, ``same_box``, ``convergence`` (:class:`~psdr_room_core.method.convergence.Plateau`), ``physical``.
    """
    if not placements.objects:
        return {
            "placements": placements,
            "log": OptimizationLog(history=[], images={}, summary={"objects": 0}),
            "room": room,
        }
    settings = ctx.settings(FitObjects)
    cam = camera.resized(min(settings.render_width, camera.width))
    targets = object_targets(placements, panoptic, depth, (cam.width, cam.height))
    weak = weak_guesses(prompt_scores(panoptic), settings.physical.weak_score)
    model = PoseModel(placements, room, unit=float(np.mean(room.half_size)), weak=weak)
    initial_vertices = {k: v.detach().numpy() for k, v in model.vertices().items()}
    meshes = {
        name: TriangleMesh(initial_vertices[name], model.welded[i].faces) for i, name in enumerate(initial_vertices)
    }
    parts = {name: i for i, name in enumerate(meshes)}
    renderer = ctx.impl("renderer", Renderer).geometry(cam, np.asarray(room.camera_to_world), meshes, parts)
    t_masks, t_masked = torch.from_numpy(targets.masks), torch.from_numpy(targets.masked_depth)
    t_weights = torch.from_numpy(targets.weights)
    valid = targets.masked_depth[targets.masks > 0.5] / np.maximum(targets.masks[targets.masks > 0.5], 1e-6)
    depth_scale = float(np.percentile(valid, 98)) if valid.size else 1.0
    sigmas = tuple(settings.blur_sigmas)
    t_blur = gaussian_pyramid_blur(t_masks, sigmas)

    def per_object(iteration: int) -> tuple[torch.Tensor, torch.Tensor, dict[str, float]]:
        """Eq. 3's term of each object [P], the rendered masks [P,h,w], and the logged terms."""
        vertices = model.vertices()
        masks, weighted_depth, alpha = renderer.render(vertices, iteration)
        rendered_depth = weighted_depth / alpha.clamp_min(1e-3)
        depth_term = (t_weights * (masks * rendered_depth - t_masked).abs()).mean(dim=(1, 2)) / depth_scale
        blur_term = (t_weights * (gaussian_pyramid_blur(masks, sigmas) - t_blur).abs()).mean(dim=(2, 3)).sum(dim=0)
        size_term = model.size_penalty(settings.size_prior.scale_weight, settings.size_prior.range_weight)
        room_term = settings.room_weight * model.room_penalty(vertices)
        collision_term = settings.collision_weight * model.collision_penalty()
        back_term = settings.back_weight * model.back_penalty()
        wall_term = settings.wall_weight * model.wall_penalty()
        ious = mask_ious(masks, t_masks)
        terms = {
            "mask_depth_l1": depth_term.sum().item(),
            "blurred_mask_l1": blur_term.sum().item(),
            "size_prior": size_term.sum().item(),
            "beyond_room": room_term.sum().item(),
            "interpenetration": collision_term.sum().item(),
            "back_shown": back_term.sum().item(),
            "wall_gap": wall_term.sum().item(),
            "mean_iou": ious.mean().item(),
        }
        total = (
            depth_term
            + settings.blur_weight * blur_term
            + size_term
            + room_term
            + collision_term
            + back_term
            + wall_term
        )
        return total, masks.detach(), terms

    best = BestIterate(model.theta)
    with torch.no_grad():
        placed = explained(per_object(0)[1], targets)

    def loss(iteration: int) -> tuple[torch.Tensor, dict[str, float]]:
        terms, _, logged = per_object(iteration)
        total = terms.sum()
        best.observe(float(total.detach()), iteration)
        return total, logged

    iterations, plateau = settings.iterations, settings.convergence
    optimizer, rates = ctx.impl("optimizer", Optimizer), asdict(settings.learning_rates)
    phase = round(iterations * settings.yaw_test.at)
    history = optimizer.minimize(model.theta, rates, loss, phase, lambda it: ctx.progress(it, total=phase), plateau)
    first = len(history)
    best.restore()
    turned = try_yaw_turns(model, lambda: per_object(first)[0], settings.yaw_test.angles, settings.yaw_test.min_gain)
    if turned or first == phase:  # turned poses are a new start (the best is theirs); or not converged yet
        if turned:
            best = BestIterate(model.theta)
        history += optimizer.minimize(
            model.theta,
            rates,
            lambda it: loss(first + it),
            iterations - first,
            lambda it: ctx.progress(it, total=iterations - first),
            plateau,
        )
        best.restore()
    with torch.no_grad():
        fitted = explained(per_object(len(history))[1], targets)
        fitted_poses = [replace(p, explained=float(iou)) for p, iou in zip(model.placements_now(), fitted.mask)]
        restored = restore_lost(
            model, placed, fitted, settings.keep_share, settings.same_box, settings.physical.size_tolerance
        )
        ious = explained(per_object(len(history))[1], targets).mask if restored else fitted.mask
        posed = [replace(p, explained=float(iou)) for p, iou in zip(model.placements_now(), ious)]
    settled, undone = settle_restored(
        posed,
        fitted_poses,
        restored,
        lambda objects: _settle(objects, room, cam, panoptic, settings.physical, "fit_objects", final=True),
        settings.physical.penetration,
    )
    kept = []
    for i in restored:
        p = model.placements[i]
        why = (
            f"{p.segment_id}:{p.label} ({p.model_id.split('/')[-1]}): the fit left it explaining "
            f"{fitted.mask[i]:.2f} of its segment ({placed.mask[i]:.2f} placed), its box {fitted.box[i]:.2f} of its "
            f"prompt box ({placed.box[i]:.2f} placed), at scale {fitted_poses[i].scale:.2f} ({p.scale:.2f} placed)"
        )
        if i in undone:
            log.info("fit_objects: kept the fitted pose of %s, as its placed pose cost the settling an object", why)
        else:
            kept.append(why)
            log.info("fit_objects: kept the placed pose of %s", why)
    through = interpenetrations(settled.placements, settings.physical.penetration)
    history = untimed(history, ctx.timings)
    final = history[best.iteration]
    result = Placements(
        objects=settled.placements,
        extra={
            "interpenetrations": through,
            "turned": turned,
            "kept_placed": kept,
            "final": final,
            "dropped": settled.dropped,
            "settled": settled.changed,
        },
    )
    record = _objects_log(history, image, camera, room, placements, result, panoptic, through)
    record.summary.update(
        turned=turned, kept_placed=kept, final=final, best_iteration=best.iteration, dropped=settled.dropped
    )
    return {"placements": result, "log": record, "room": settled.room}


def _rotation(yaw: torch.Tensor) -> torch.Tensor:
    """R_y(yaw) as a differentiable 3x3 tensor."""
    c, s = torch.cos(yaw), torch.sin(yaw)
    zero, one = torch.zeros_like(c), torch.ones_like(c)
    return torch.stack([torch.stack([c, zero, s]), torch.stack([zero, one, zero]), torch.stack([-s, zero, c])])


def _near(a: Placement, b: Placement, margin: float = 0.25) -> bool:
    """Whether two objects' bounding spheres come within ``margin`` metres (they may touch while fitted)."""

    def sphere(p: Placement) -> tuple[np.ndarray, float]:
        v = p.world_vertices()
        return (v.min(axis=0) + v.max(axis=0)) / 2.0, 0.5 * float(np.linalg.norm(np.ptp(v, axis=0)))

    (ca, ra), (cb, rb) = sphere(a), sphere(b)
    return float(np.linalg.norm(ca - cb)) < ra + rb + margin


def restore_lost(
    model: PoseModel, placed: Explained, fitted: Explained, share: float, same_box: float, size_tolerance: float
) -> list[int]:
    """The objects the fit lost, put back in their placed pose (their fit parameters zeroed): those it left
    explaining less than ``share`` of what their render explained of their segment when placed, those whose
    render's box matched their prompt box (box IoU ``same_box`` or more: the one object there) when placed and
    no longer does, and those it took outside their category's real sizes (by more than ``size_tolerance``, log
    scale, which the settling drops) from a size inside them. The joint fit can push an object off its segment
    (out of a collision with a neighbour the photo shows in front of it, or shrunk by its size prior) where no
    gradient brings it back, it fits a cut mask that lost the thin legs or the base of a chair by a smaller
    chair farther away, whose box no longer reaches the floor where the detector's did, and it halves a chair
    the frame cuts to match a depth that may be off: eq. 3 must not lose what the placement found. Returns
    their indices."""

    def excess(p: Placement) -> float:
        return size_excess(p.category, np.ptp(p.mesh.vertices, axis=0), p.scale)

    now = model.placements_now()
    lost = [
        i
        for i in range(len(placed.mask))
        if fitted.mask[i] < share * placed.mask[i]
        or (placed.box[i] >= same_box and not fitted.box[i] >= same_box)
        or excess(now[i]) > size_tolerance >= excess(model.placements[i])
    ]
    with torch.no_grad():
        for values in model.theta.values():
            values[lost] = 0.0
    return lost


def settle_restored(
    posed: list[Placement],
    fitted: list[Placement],
    restored: list[int],
    settle_scene: Callable[[list[Placement]], Settled],
    penetration: float,
) -> tuple[Settled, list[int]]:
    """Settle ``posed`` (``settle_scene``), in which the objects ``restored`` (indices) stand in their placed pose;
    where the settling drops a restored object, or one that passes through a restored object by more than
    ``penetration`` metres, those restores are undone (their ``fitted`` pose back) and the scene settled again.
    A placed pose the fit left was collision-free among the placed poses, not among the fitted ones: restoring it
    beside a neighbour the fit moved must not cost the scene that neighbour or itself. Returns the settled scene
    and the indices of the restores undone."""
    settled = settle_scene(posed)
    left = {p.segment_id for p in settled.placements}
    gone = [p for p in posed if p.segment_id not in left]
    undone = [
        i
        for i in restored
        if posed[i].segment_id not in left
        or any(overlap(posed[i], g).thickness > penetration for g in gone if g.segment_id != posed[i].segment_id)
    ]
    if not undone:
        return settled, []
    return settle_scene([fitted[i] if i in undone else p for i, p in enumerate(posed)]), undone


def try_yaw_turns(
    model: PoseModel, evaluate: Callable[[], torch.Tensor], angles: list[float], min_gain: float
) -> dict[int, float]:
    """Turn each free-standing object by each of ``angles`` (degrees) in turn and keep a turn that lowers both
    its own loss term by at least ``min_gain`` (a share of it) and the joint loss; ``evaluate`` gives every
    object's term [P] (one fixed-seed render). Returns segment id → degrees turned.

    Masks and depth seen from one side leave a model's front and back (and, for boxy furniture, its side)
    nearly alike; gradient descent on yaw never crosses the ridge between them. A near-symmetric model's turn
    changes its term by less than the render's noise: ``min_gain`` keeps it as it is. Wall objects keep their
    orientation (they face into the room)."""
    turned: dict[int, float] = {}
    with torch.no_grad():
        best = evaluate()
        yaw = model.theta["yaw"]
        for i, p in enumerate(model.placements):
            if p.support == "wall":
                continue
            start = float(yaw[i])
            for angle in angles:
                yaw[i] = start + angle
                value = evaluate()
                if value[i] < (1.0 - min_gain) * best[i] and value.sum() < best.sum():
                    best, turned[p.segment_id] = value, angle
            yaw[i] = start + turned.get(p.segment_id, 0.0)
    return turned


# ------------------------------------------------------------------------------------------ reporting
def footprint(p: Placement) -> tuple[np.ndarray, float, float]:
    """(4x2 xz corners of the object's rotated bounding box, bottom y, top y) in the world."""
    v = p.mesh.vertices
    lo, hi = v.min(axis=0) * p.scale, v.max(axis=0) * p.scale
    corners = np.array([[lo[0], lo[2]], [hi[0], lo[2]], [hi[0], hi[2]], [lo[0], hi[2]]])
    c, s = math.cos(p.yaw), math.sin(p.yaw)
    xz = corners @ np.array([[c, -s], [s, c]]) + [
        p.position[0],
        p.position[2],
    ]  # R_y acts on (x, z) as [[c, s], [-s, c]]
    return xz, p.position[1] + lo[1], p.position[1] + hi[1]


def _outlines(rgb8: np.ndarray, camera: Camera, room: RoomBox, placements: Placements) -> np.ndarray:
    out = rgb8.copy()
    c2w = np.asarray(room.camera_to_world)
    for k, p in enumerate(placements.objects):
        mask = silhouette(camera, c2w, p.world_vertices(), p.mesh.faces).astype(np.uint8)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        colour = tuple(
            int(c) for c in cv2.applyColorMap(np.array([[37 * k % 255]], np.uint8), cv2.COLORMAP_HSV)[0, 0][::-1]
        )
        cv2.drawContours(out, contours, -1, colour, 2)
        if contours:
            x, y = contours[0][0][0]
            cv2.putText(
                out,
                f"{p.segment_id}:{p.model_id.split('/')[-1]} ({p.support})",
                (int(x), max(12, int(y) - 4)),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.4,
                colour,
                1,
                cv2.LINE_AA,
            )
    return out


def _objects_log(
    history: list[dict[str, float]],
    image: Image,
    camera: Camera,
    room: RoomBox,
    before: Placements,
    after: Placements,
    panoptic: Panoptic,
    through: list[tuple[int, int, float]],
) -> OptimizationLog:
    base = segment_overlay(image.to_uint8(), panoptic, alpha=0.25)
    curves = {k: [h[k] for h in history] for k in history[0]}
    return OptimizationLog(
        history=history,
        images={
            "before": _outlines(base, camera, room, before),
            "after": _outlines(base, camera, room, after),
            "loss": plot_curves(curves, title="fit_objects"),
        },
        summary={
            "objects": len(after.objects),
            "iterations": len(history),
            "initial": history[0],
            "interpenetrations": through,
            "supports": {p.segment_id: p.support for p in after.objects},
        },
    )
