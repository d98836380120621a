"""One object per thing (§4.3, before the model search): segments that are parts of one object are merged.

An automatic segmentation cuts a bed into its headboard with the pillows and its mattress front, a sofa into
its back and its seat, or finds one thing twice; each part would become an object of its own (a second bed
standing behind the first). Two guessed segments may be one thing where the fitted room says so:

* **stacked parts**: one rests on the other (its lowest pixels sit on the other's mask), both are of a
  category whose parts a segmentation cuts apart (``splittable``: beds and sofas) or one is a named part of
  the other (``parts``: a bed's pillows, a sofa's seat taken for a chair), and together they have the size of
  one such object. Where the depth is not measured (``depth=layout`` stands every segment on the floor where
  its lowest pixel meets it, which puts a headboard far behind its bed), the upper part is stood on the
  lower one's top, as the support rules of §4.3 would, before the size is measured;
* **the same space**: their floor footprints overlap (``same_space`` of the smaller, each grown by
  ``margin``) at overlapping heights, and their categories agree (or one is unknown). A part whose depth gives
  its direction only (``DepthMap.unplaced``: ``depth=layout`` found no floor contact for it inside the room and put
  it just in front of the room's surface) has no footprint: two desks of a classroom row, one behind the other,
  both beyond a wall fitted too near, would share a sliver of that wall. It is never the same space as another
  part.

Such a pair is merged only where one model explains it: ``judge`` (the stage's model search) scores the best
model of the whole's category on the two together and on each alone, and the pair is merged where the union
scores at least ``keep_score`` of the better part's score: one thing explained whole is explained no worse than
its best part. A floor region that a weak "bed" label put under a bed fails here (no bed covers the carpet),
and so do two desks of a classroom row that a detector called beds. Chairs in a row, twin beds side by side and a table with
its chairs are not even candidates: not of one splittable category, or side by side, or too big together.
Segments a person drew (no score) are never merged.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, replace

import numpy as np

from .artifacts import Camera, Panoptic, PointCloud, RoomBox, Segment
from .labels import primary_category
from .objects import OBJECT_CATEGORIES, mask_distance
from .params import GroupParams
from .sizes import size_range

log = logging.getLogger("psdr_room")


@dataclass(frozen=True)
class Part:
    """A segment as a part of something: what the judge sees of it."""

    segment: Segment
    category: str
    """Its label's database category (``object``: unknown)."""
    mask: np.ndarray
    points: np.ndarray
    """(N, 3) world points."""
    index: np.ndarray
    """(N,) their indices in the point cloud."""
    placed: bool
    """Whether its points say where it stands (see ``DepthMap.unplaced``)."""


Judge = Callable[[str, Part, Sequence[Part]], tuple[float, list[float]]]
"""(whole's category, the union, its parts) → (the best score of a model of that category on the union, on each
part): higher is better."""


def _rests_on(upper: np.ndarray, lower: np.ndarray, params: GroupParams) -> bool:
    """Whether ``upper``'s lowest pixels sit on ``lower``'s mask, along ``rests_share`` of their columns."""
    columns = np.flatnonzero(upper.any(axis=0))
    if not columns.size:
        return False
    height = upper.shape[0]
    bottoms = height - 1 - np.argmax(upper[::-1, columns], axis=0)
    reach = int(np.ceil(params.edge_px))
    below = np.zeros(columns.size, bool)
    for step in range(1, reach + 1):
        rows = np.minimum(bottoms + step, height - 1)
        below |= lower[rows, columns] & (bottoms + step < height)
    return bool(below.mean() >= params.rests_share)


def _stood_on(upper: Part, lower: Part, camera: Camera, camera_to_world: np.ndarray) -> np.ndarray:
    """``upper``'s points moved along their camera rays onto the vertical plane (facing the camera) through the
    point where its lowest pixel's ray meets ``lower``'s top; as they are where that ray does not go down to it."""
    top = float(np.percentile(lower.points[:, 1], 98))
    origin = camera_to_world[:3, 3]
    rows = np.flatnonzero(upper.mask.any(axis=1))
    bottom = int(rows[-1])
    column = int(np.median(np.flatnonzero(upper.mask[bottom])))
    ray = camera_to_world[:3, :3] @ np.array(
        [(column + 0.5 - camera.cx) / camera.fx, (bottom + 0.5 - camera.cy) / camera.fy, 1.0]
    )
    if ray[1] >= -1e-6 or origin[1] <= top:
        return upper.points
    contact = origin + ray * (top - origin[1]) / ray[1]
    normal = np.array([ray[0], 0.0, ray[2]]) / max(float(np.hypot(ray[0], ray[2])), 1e-9)
    directions = upper.points - origin
    along = directions @ normal
    t = np.where(along > 1e-6, float((contact - origin) @ normal) / np.maximum(along, 1e-6), 1.0)
    return origin + directions * t[:, None]


def _fits(category: str, points: np.ndarray, room: RoomBox, slack: float) -> bool:
    """Whether ``points`` (world) are no bigger than one ``category`` object (× ``slack``)."""
    local = room.local(points)
    lo, hi = np.percentile(local, 2, axis=0), np.percentile(local, 98, axis=0)
    top = float(np.percentile(points[:, 1], 98))
    across = sorted((float(hi[0] - lo[0]), float(hi[2] - lo[2])), reverse=True)
    sizes = size_range(category)
    return (
        top <= sizes.height[1] * slack and across[0] <= sizes.length[1] * slack and across[1] <= sizes.width[1] * slack
    )


def _footprint_share(a: np.ndarray, b: np.ndarray, room: RoomBox, margin: float) -> float:
    """Overlap of the two point sets' floor footprints (room-aligned boxes of their 5-95% extents, grown by
    ``margin``) as a share of the smaller, 0 where their heights do not overlap."""
    boxes = []
    for points in (a, b):
        local = room.local(points)
        boxes.append((np.percentile(local, 5, axis=0) - margin, np.percentile(local, 95, axis=0) + margin))
    (alo, ahi), (blo, bhi) = boxes
    if min(ahi[1], bhi[1]) <= max(alo[1], blo[1]):
        return 0.0
    overlap = np.maximum(0.0, np.minimum(ahi, bhi) - np.maximum(alo, blo))[[0, 2]].prod()
    smaller = min((ahi - alo)[[0, 2]].prod(), (bhi - blo)[[0, 2]].prod())
    return float(overlap / max(smaller, 1e-9))


def _whole(a: Part, b: Part, params: GroupParams) -> str | None:
    """The category of the thing ``a`` and ``b`` would be parts of when stacked, or None."""
    if a.category == b.category and a.category in params.splittable:
        return a.category
    if b.category in params.parts.get(a.category, ()):
        return a.category
    if a.category in params.parts.get(b.category, ()):
        return b.category
    return None


def _candidate(
    a: Part, b: Part, camera: Camera, camera_to_world: np.ndarray, room: RoomBox, metric: bool, params: GroupParams
) -> tuple[str, np.ndarray, np.ndarray, str, bool] | None:
    """(whole's category, the union's world points, their cloud indices, why, whether those points say where it
    stands) where ``a`` and ``b`` may be one thing, else None (a resting part's points are stood on the part below,
    where the depth is not measured)."""
    if mask_distance(a.mask, b.mask) <= params.edge_px:
        whole = _whole(a, b, params)
        for upper, lower in ((a, b), (b, a)):
            if whole is not None and _rests_on(upper.mask, lower.mask, params):
                points = upper.points if metric else _stood_on(upper, lower, camera, camera_to_world)
                union = np.vstack([points, lower.points])
                if _fits(whole, union, room, params.slack):
                    order = np.concatenate([upper.index, lower.index])
                    placed = lower.placed and (upper.placed or not metric)  # not measured: stood on the lower
                    return whole, union, order, f"{upper.segment.id} rests on {lower.segment.id}", placed
    agree = a.category == b.category or "object" in (a.category, b.category) or _whole(a, b, params) is not None
    if (
        agree
        and a.placed
        and b.placed
        and _footprint_share(a.points, b.points, room, params.margin) >= params.same_space
    ):
        whole = b.category if a.category == "object" else a.category
        union = np.vstack([a.points, b.points])
        if _fits(whole, union, room, params.slack):
            return (
                whole,
                union,
                np.concatenate([a.index, b.index]),
                f"{a.segment.id} and {b.segment.id} occupy the same space",
                True,
            )
    return None


def group_segments(
    panoptic: Panoptic,
    cloud: PointCloud,
    camera: Camera,
    room: RoomBox,
    metric: bool,
    params: GroupParams,
    judge: Judge,
    unplaced: Collection[int] = (),
) -> tuple[Panoptic, PointCloud, list[str]]:
    """The segmentation and point cloud with each group of parts merged into one segment (module docstring);
    ``metric``: the depth is measured (its points are where the parts are); ``unplaced``: segments whose depth
    gives their direction only (``DepthMap.unplaced``). Also one line per pair judged.

    A merged segment keeps the id, label and score of its part of the whole's category with the most pixels,
    the union of the parts' masks, points and prompt boxes."""
    to_world = np.asarray(room.camera_to_world)
    world = cloud.points.astype(np.float64) @ to_world[:3, :3].T + to_world[:3, 3]
    parts: dict[int, Part] = {}
    for segment in panoptic.segments:
        if segment.category not in OBJECT_CATEGORIES or segment.score is None:
            continue
        category = primary_category(segment.label, segment.category)
        index = np.flatnonzero(cloud.segment == segment.id)
        if category is not None and len(index) >= 3:
            parts[segment.id] = Part(
                segment, category, panoptic.ids == segment.id, world[index], index, segment.id not in unplaced
            )
    merged_into: dict[int, int] = {}
    notes = []
    judged: set[tuple[int, int]] = set()
    changed = True
    while changed:
        changed = False
        ids = sorted(parts)
        for i, a_id in enumerate(ids):
            for b_id in ids[i + 1 :]:
                if (a_id, b_id) in judged:
                    continue
                a, b = parts[a_id], parts[b_id]
                found = _candidate(a, b, camera, to_world, room, metric, params)
                if found is None:
                    continue
                judged.add((a_id, b_id))
                whole, points, index, why, placed = found
                keep, gone = sorted((a, b), key=lambda p: (p.category != whole, -int(p.mask.sum())))
                boxes = [p.segment.box for p in (a, b) if p.segment.box is not None]
                box = (
                    (
                        min(x[0] for x in boxes),
                        min(x[1] for x in boxes),
                        max(x[2] for x in boxes),
                        max(x[3] for x in boxes),
                    )
                    if len(boxes) == 2
                    else None
                )
                segment = replace(keep.segment, score=max(a.segment.score or 0.0, b.segment.score or 0.0), box=box)
                union = Part(segment, whole, a.mask | b.mask, points, index, placed)
                together, apart = judge(whole, union, (a, b))
                verdict = together >= params.keep_score * max(apart)
                notes.append(
                    f"{a.segment.id}:{a.segment.label} + {b.segment.id}:{b.segment.label}: {why}; one "
                    f"{whole} scores {together:.3f} on both, {apart[0]:.3f} / {apart[1]:.3f} apart: "
                    + ("merged" if verdict else "kept apart")
                )
                if not verdict:
                    continue
                parts[keep.segment.id] = union
                del parts[gone.segment.id]
                merged_into[gone.segment.id] = keep.segment.id
                changed = True
                break
            if changed:
                break
    if not merged_into:
        return panoptic, cloud, notes
    root = {gone_id: _root(gone_id, merged_into) for gone_id in merged_into}
    new_ids = panoptic.ids.copy()
    labels = cloud.segment.copy()
    points = cloud.points.copy()
    for gone_id, keep_id in root.items():
        new_ids[panoptic.ids == gone_id] = keep_id
        labels[cloud.segment == gone_id] = keep_id
    for keep_id in set(root.values()):  # a resting part's points where it was stood
        part = parts[keep_id]
        points[part.index] = ((part.points - to_world[:3, 3]) @ to_world[:3, :3]).astype(points.dtype)
    segments = [parts[s.id].segment if s.id in parts else s for s in panoptic.segments if s.id not in root]
    return (
        Panoptic(ids=new_ids, segments=segments),
        PointCloud(points=points, colors=cloud.colors, segment=labels, segments=segments),
        notes,
    )


def _root(segment_id: int, merged_into: dict[int, int]) -> int:
    while segment_id in merged_into:
        segment_id = merged_into[segment_id]
    return segment_id
