"""A physically possible scene (§4.3, after each pose stage): real sizes, one object per thing, inside the room,
nothing passing through anything.

Masks and depth say where an object is seen, not whether the scene could stand. :func:`settle` makes it so,
changing what the photo shows as little as it can (each change is chosen by how well the object's silhouette
keeps its place in the picture, and logged), dropping an object only as the last resort:

1. **real size**: a model outside its category's real sizes (:mod:`.sizes`) by up to ``size_tolerance`` (log
   units) is scaled into them, moved along its camera ray so it keeps its apparent size; beyond that it needs
   an implausible size and a guessed object is dropped (an object a person drew is scaled into range);
2. **one object per thing**: of two objects of one kind (one category, or one of unknown kind) that share more
   than ``duplicate_share`` of the smaller one's volume (a bed found twice, in the photo and in a mirror), the
   one that explains less is dropped (objects of two kinds sharing space collide: rule 4);
3. **inside the room**: an object crossing a side of the room box is moved along its camera ray, back in
   (along its wall, for a wall object) or made smaller in place, whichever keeps its silhouette best (at least
   ``keep_iou`` of it); where none does, the room box is wrong there (its sides are estimates, often of walls
   the photo does not show), and in the ``final`` settling it grows to hold the object, by at most
   ``max_growth``: a guessed object farther out stands where no room is, its depth is implausible, and it is
   dropped;
4. **no interpenetration**: of two objects passing through each other by more than ``penetration`` metres
   (:func:`~.solids.overlap`), the one whose freeing change keeps what the picture shows of it best (the IoU of
   its seen silhouette, in front of the others, with before: at least ``keep_iou``) takes it: a horizontal
   step (up to ``max_shift``) or shrinking in place within its category's sizes (a big table stepping back
   10 cm changes the picture less than the chair tucked under it stepping out), freeing it of the other and
   passing no deeper through anything else (a chair in a crowded row steps out of its desk while still
   brushing its neighbours, who then step aside in their turn). Only the weaker may change where the other is
   more surely there (a person drew it, or its prompt was no weak guess: a detector's sure dresser does not
   shrink out of a guess at the wall beside it). Where no allowed change frees them, in the ``final`` settling
   the weaker is dropped (unless a person drew both), and what changed to make room for it goes back where
   that passes through nothing more. Before it (after ``place_objects``) such a pair is left to the joint fit,
   which pays for interpenetration;
5. **what the photo shows stays in sight**: an object the others hide (seen from the camera, it shows less than
   ``hidden_share`` of the pixels of its segment it covers alone) contradicts the photo, which shows it there,
   and no gradient of the joint fit reaches a fully hidden object. Where the object in front of it is a blob
   whose label names no kind (a clutter proposal posed as a panel in front of a row of chairs) and the hidden
   one's label names its kind, the blob moves back along its camera ray behind it (within its category's
   sizes and ``keep_iou`` of its silhouette, reaching no farther out of the room, passing no deeper through
   anything, hiding nothing else; a wall or a child holds it in place), else it is dropped where that shows
   the hidden one, in either settling, so that the joint fit refines what it hid (unless a person drew it).
   Between two named objects the photo does not say which one's depth is wrong; where the segmenting network
   boxed both in 3D and its boxes put the hidden one nearer by at least ``seen_order`` of its depth (the near
   faces' depths, :func:`~.seen_boxes.near_face_depth`), the one in front moves back behind it in the same way
   (it is not dropped: the network may be wrong). What stays hidden is reported (``benchmarks/real_photos.py``,
   column ``hid``).

Which of two objects is the stronger (:func:`evidence`): one a person drew, then one the segmentation was sure
of (no weak guess: its prompt scored at least ``weak_score``), then the one that explains more of the photo, in
expectation: the share of its segment its posed model covers (IoU) times the segment's pixels, times how sure its
prompt is that it is there (its score), so that a bed that explains most of a large segment outweighs a picture
that explains all of a small one, and of two desks explaining alike the one the detector is surer of stays.
An object's children (objects standing on it) move and are dropped with it.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from .artifacts import Camera, Panoptic, Placement, RoomBox, rotation_y, vec3
from .labels import ANY, meaning
from .params import PhysicalParams
from .seen_boxes import near_face_depth
from .silhouette import depth_map, silhouette
from .sizes import scale_range, size_excess
from .solids import overlap, solid_of, to_model

log = logging.getLogger("psdr_room")


@dataclass
class Settled:
    """What :func:`settle` did."""

    placements: list[Placement]
    room: RoomBox
    """The room box, grown where objects the photo shows reach beyond it (``final`` settling only)."""
    dropped: list[str] = field(default_factory=list)
    """``<segment>:<label> (<model>): <why>`` per dropped object."""
    changed: list[str] = field(default_factory=list)
    """``<segment>:<label> (<model>): <what>`` per scaled or moved object, and the room's growth."""


_MOVABLE = ("floor", "free")
"""Supports whose objects rule 5 may move back along their camera ray (a wall or parent holds the others in place)."""
MIN_SEEN = 10
"""Fewest pixels of its segment an object must cover (in the settling's picture) to count as hidden or not."""


def evidence(
    placement: Placement, drawn: set[int], weak: set[int], pixels: Mapping[int, int], scores: Mapping[int, float]
) -> tuple[int, float, int]:
    """How strongly an object is attested (higher: kept): its :func:`_sureness`, then the pixels of its segment
    the posed model is expected to explain (IoU × segment pixels × prompt score; 1 where there is no score), then
    its segment id (older first)."""
    k = placement.segment_id
    explained = (placement.explained or 0.0) * pixels.get(k, 1) * scores.get(k, 1.0)
    return _sureness(k, drawn, weak), explained, -k


def weak_guesses(scores: Mapping[int, float], weak_score: float) -> set[int]:
    """The segment ids whose prompts (``scores``: segment id → prompt score) scored below ``weak_score``."""
    return {k for k, score in scores.items() if score < weak_score}


def _sureness(segment_id: int, drawn: set[int], weak: set[int]) -> int:
    """2: a person drew the object; 1: the segmentation was sure of it; 0: it is a weak guess."""
    return 2 if segment_id in drawn else 0 if segment_id in weak else 1


def _mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    union = int((a | b).sum())
    return float((a & b).sum()) / union if union else 0.0


def _name(p: Placement) -> str:
    return f"{p.segment_id}:{p.label} ({p.model_id.split('/')[-1]})"


def _stands_on(child: Placement, parent: Placement) -> bool:
    return child.support == "parent" and child.anchor == parent.segment_id


def _unknown(p: Placement) -> bool:
    """Whether ``p``'s label names no kind of thing."""
    return (meaning(p.label) or ANY).primary == "object"


def _one_kind(a: Placement, b: Placement) -> bool:
    """Whether two objects may be one thing: one category, or one of them of unknown kind (its label named none)."""
    return a.category == b.category or _unknown(a) or _unknown(b)


def hidden_by(segment_id: int, depths: Mapping[int, np.ndarray], ids: np.ndarray, share: float) -> int | None:
    """Which object hides object ``segment_id``: the one in front of it on most of the pixels of its segment it
    covers (``ids``: the segmentation's id map; ``depths``: each object's camera depth, inf where it is not seen,
    at ``ids``' size), where it shows less than ``share`` of those pixels (of at least :data:`MIN_SEEN`); else
    None."""
    own = depths[segment_id]
    covered = (ids == segment_id) & np.isfinite(own)
    others = [k for k in depths if k != segment_id]
    if covered.sum() < MIN_SEEN or not others:
        return None
    nearest = np.stack([depths[k] for k in others])
    in_front = covered & (nearest.min(axis=0) < own)
    if in_front.sum() <= (1.0 - share) * covered.sum():
        return None
    return others[int(np.bincount(nearest.argmin(axis=0)[in_front], minlength=len(others)).argmax())]


def along_ray(p: Placement, scale: float, camera_origin: np.ndarray) -> Placement:
    """``p`` at ``scale``, moved along the camera ray through its origin so it keeps its apparent size; a
    supported object keeps its height (it stays on its support)."""
    ratio = scale / p.scale
    position = np.asarray(p.position, np.float64)
    moved = camera_origin + (position - camera_origin) * ratio
    if p.support in ("floor", "parent"):
        moved[1] = position[1]
    return replace(p, scale=float(scale), position=vec3(moved))


def room_excess(p: Placement, room: RoomBox, tolerance: float = 1e-3) -> np.ndarray:
    """(3,) how far the object reaches beyond the room box along each of the box's axes, signed (0: inside, or
    within ``tolerance``; positive: beyond the + side, negative: beyond the − side); NaN where it is longer
    than the room there."""
    local = room.local(p.world_vertices())
    half = np.asarray(room.half_size)
    lo, hi = local.min(axis=0), local.max(axis=0)
    out = np.zeros(3)
    for axis in range(3):
        if hi[axis] - lo[axis] > 2 * half[axis] + tolerance:
            out[axis] = np.nan
        elif hi[axis] > half[axis] + tolerance:
            out[axis] = hi[axis] - half[axis]
        elif lo[axis] < -half[axis] - tolerance:
            out[axis] = lo[axis] + half[axis]
    return out


def grown(room: RoomBox, points: np.ndarray, margin: float = 0.01) -> RoomBox:
    """The room box with each side moved out just enough to hold ``points`` (world); the floor stays."""
    local = room.local(points)
    half = np.asarray(room.half_size, np.float64)
    lo = np.minimum(-half, local.min(axis=0) - margin)
    hi = np.maximum(half, local.max(axis=0) + margin)
    lo[1] = -half[1]  # the floor is the floor
    centre_local = (lo + hi) / 2.0
    centre = np.asarray(room.center, np.float64) + rotation_y(room.yaw) @ centre_local
    return replace(room, center=centre, half_size=(hi - lo) / 2.0)


def support_top(parent: Placement, world_xz: np.ndarray) -> float:
    """Height of the parent's surface under a world point (x, z): the top of its solid's column there, or of its
    nearest solid column."""
    solid = solid_of(parent)
    model = to_model(parent, np.array([world_xz[0], parent.position[1], world_xz[1]], np.float64)[None])[0]
    columns = solid.inside.any(axis=1)
    if not columns.any():
        return parent.position[1] + parent.scale * float(parent.mesh.vertices[:, 1].max())
    index = np.rint((model[[0, 2]] - solid.origin[[0, 2]]) / solid.pitch).astype(int)
    filled = np.argwhere(columns)
    nearest = filled[np.argmin(np.sum((filled - index) ** 2, axis=1))]
    top = int(np.flatnonzero(solid.inside[nearest[0], :, nearest[1]])[-1])
    height = solid.origin[1] + (top + 0.5) * solid.pitch
    return parent.position[1] + parent.scale * min(float(height), float(parent.mesh.vertices[:, 1].max()))


class _Scene:
    """The objects being settled, with what :func:`settle` reports."""

    def __init__(
        self,
        placements: list[Placement],
        room: RoomBox,
        camera: Camera,
        drawn: set[int],
        scores: Mapping[int, float],
        pixels: Mapping[int, int],
        params: PhysicalParams,
        ids: np.ndarray | None,
        seen_depths: Mapping[int, float],
    ) -> None:
        self.objects = {p.segment_id: p for p in placements}
        self.seen_depths = seen_depths
        self.room, self.camera, self.drawn, self.scores = room, camera, drawn, scores
        self.weak = weak_guesses(scores, params.weak_score)
        self.pixels, self.params = pixels, params
        self.ids = ids
        self.c2w = np.asarray(room.camera_to_world)
        self.origin = self.c2w[:3, 3]
        self.dropped: list[str] = []
        self.changed: list[str] = []
        self.depths: dict[int, tuple[Placement, np.ndarray]] = {}

    # -- bookkeeping
    def strength(self, segment_id: int) -> tuple[int, float, int]:
        return evidence(self.objects[segment_id], self.drawn, self.weak, self.pixels, self.scores)

    def drop(self, segment_id: int, why: str) -> None:
        if segment_id not in self.objects:
            return
        self.dropped.append(f"{_name(self.objects.pop(segment_id))}: {why}")
        for child in [c for c in self.objects.values() if c.support == "parent" and c.anchor == segment_id]:
            self.drop(child.segment_id, f"it stood on {segment_id}, dropped")

    def put(self, moved: Placement, what: str) -> None:
        """Replace an object by its moved or scaled self, its children moved along by as much (a change under
        half a centimetre or half a percent is not worth a word)."""
        before = self.objects[moved.segment_id]
        step = np.subtract(moved.position, before.position) * [1.0, 0.0, 1.0]
        self.objects[moved.segment_id] = moved
        moved_by = float(np.linalg.norm(np.subtract(moved.position, before.position)))
        if moved_by > 0.005 or abs(moved.scale / before.scale - 1) > 0.005:
            self.changed.append(f"{_name(before)}: {what}")
        for child in [c for c in self.objects.values() if _stands_on(c, moved)]:
            self.objects[child.segment_id] = self.shifted(child, step)

    # -- measures
    def looks(self, p: Placement) -> np.ndarray:
        return silhouette(self.camera, self.c2w, p.world_vertices(), p.mesh.faces)

    def depth(self, p: Placement) -> np.ndarray:
        """(h, w) camera depth of ``p`` (inf where it is not seen)."""
        d = depth_map(self.camera, self.c2w, p.world_vertices(), p.mesh.faces)
        return np.where(d > 0, d, np.inf)

    def hider(self, segment_id: int, depths: Mapping[int, np.ndarray]) -> int | None:
        """:func:`hidden_by` in this scene's picture."""
        assert self.ids is not None
        return hidden_by(segment_id, depths, self.ids, self.params.hidden_share)

    def hidden(self, depths: Mapping[int, np.ndarray]) -> set[int]:
        """The objects the others hide (``depths``: each one's :meth:`depth`)."""
        return {k for k in depths if self.hider(k, depths) is not None}

    def kept_look(self, before: Placement) -> Callable[[Placement], float]:
        """IoU of a changed object's silhouette with ``before``'s."""
        reference = self.looks(before)
        return lambda after: _mask_iou(self.looks(after), reference)

    def kept_sight(self, before: Placement) -> Callable[[Placement], float]:
        """IoU of what the picture shows of a changed object (where it is in front of every other object but its
        children) with what it showed of ``before``: stepping out in front of another object changes the picture
        even where its own silhouette barely moves."""
        behind = {before.segment_id} | {c.segment_id for c in self.objects.values() if _stands_on(c, before)}
        front = np.full((self.camera.height, self.camera.width), np.inf)
        for k, other in self.objects.items():
            if k not in behind:
                front = np.minimum(front, self.cached_depth(other))
        reference = self.cached_depth(before) < front
        return lambda after: _mask_iou(self.depth(after) < front, reference)

    def cached_depth(self, p: Placement) -> np.ndarray:
        """:meth:`depth` of one of the objects as it stands (computed once per pose)."""
        kept = self.depths.get(p.segment_id)
        if kept is None or kept[0] is not p:
            kept = self.depths[p.segment_id] = (p, self.depth(p))
        return kept[1]

    def collisions(self, p: Placement) -> list[tuple[int, float]]:
        """(other id, interpenetration) of every object ``p`` passes through by more than allowed."""
        found = []
        for other in self.objects.values():
            if other.segment_id == p.segment_id or _stands_on(p, other) or _stands_on(other, p):
                continue  # a child rests on its parent by construction
            thickness = overlap(p, other).thickness
            if thickness > self.params.penetration:
                found.append((other.segment_id, thickness))
        return found

    def inside(self, p: Placement) -> bool:
        return not np.any(np.nan_to_num(room_excess(p, self.room), nan=1.0))

    def reach(self, p: Placement) -> float:
        """How far ``p`` reaches beyond the room box (its largest excess; inf where it is longer than the room)."""
        return float(np.max(np.abs(np.nan_to_num(room_excess(p, self.room), nan=np.inf))))

    # -- moves
    def shifted(self, p: Placement, step: np.ndarray) -> Placement:
        """``p`` moved by ``step`` (on its parent's surface there, for a child)."""
        moved = replace(p, position=vec3(np.asarray(p.position) + step))
        if p.support == "parent" and p.anchor in self.objects:
            top = support_top(self.objects[p.anchor], np.asarray(moved.position)[[0, 2]])
            moved = replace(moved, position=(moved.position[0], top, moved.position[2]))
        return moved

    def directions(self, p: Placement) -> list[np.ndarray]:
        """Horizontal unit directions ``p`` may move in: along its wall for a wall object."""
        if p.support == "wall":
            tangent = rotation_y(self.room.yaw)[:, 0 if p.anchor in (2, 3) else 2]
            return [tangent, -tangent]
        angles = np.arange(self.params.directions) * 2 * math.pi / self.params.directions
        return [np.array([math.cos(a), 0.0, math.sin(a)]) for a in angles]

    def smallest(self, p: Placement) -> float:
        """The smallest scale ``p`` may take (its category's, less the tolerance; 0 for a drawn object)."""
        if p.segment_id in self.drawn:
            return 0.0
        low, _ = scale_range(p.category, np.ptp(p.mesh.vertices, axis=0))
        return low * math.exp(-self.params.size_tolerance)

    @staticmethod
    def first(
        change: Callable[[float], Placement], ok: Callable[[Placement], bool], steps: np.ndarray
    ) -> Placement | None:
        """``change(step)`` for the first of ``steps`` that is ``ok``."""
        for step in steps:
            candidate = change(float(step))
            if ok(candidate):
                return candidate
        return None

    def shortest(
        self,
        change: Callable[[float], Placement],
        ok: Callable[[Placement], bool],
        longest: float,
        resolution: float = 0.01,
    ) -> Placement | None:
        """``change(d)`` for about the smallest ``d`` in (0, ``longest``] that is ``ok``: the first of four
        even steps that is, then halved down to ``resolution``."""
        bad = 0.0
        for d in np.linspace(longest / 4, longest, 4):
            if ok(change(float(d))):
                good = float(d)
                break
            bad = float(d)
        else:
            return None
        while good - bad > resolution:
            middle = (good + bad) / 2.0
            if ok(change(middle)):
                good = middle
            else:
                bad = middle
        return change(good)

    # -- the rules
    def keep_sizes(self) -> None:
        for p in list(self.objects.values()):
            outside = size_excess(p.category, np.ptp(p.mesh.vertices, axis=0), p.scale)
            if outside == 0.0:
                continue
            if outside > self.params.size_tolerance and p.segment_id not in self.drawn:
                size = np.round(np.ptp(p.mesh.vertices, axis=0) * p.scale, 2).tolist()
                self.drop(p.segment_id, f"needs {p.scale:.2f}x its size ({size} m), outside a {p.category}'s")
                continue
            low, high = scale_range(p.category, np.ptp(p.mesh.vertices, axis=0))
            scaled = along_ray(p, min(max(p.scale, low), high), self.origin)
            self.put(scaled, f"scaled {p.scale:.2f} -> {scaled.scale:.2f} (a {p.category}'s real size)")

    def remove_duplicates(self) -> None:
        ids = sorted(self.objects, key=self.strength, reverse=True)
        for k, a in enumerate(ids):
            for b in ids[k + 1 :]:
                if (
                    a in self.objects
                    and b in self.objects
                    and b not in self.drawn
                    and _one_kind(self.objects[a], self.objects[b])
                ):
                    shared = overlap(self.objects[a], self.objects[b]).shared
                    if shared >= self.params.duplicate_share:
                        self.drop(b, f"occupies the space of {_name(self.objects[a])} ({shared:.0%} of it)")

    def keep_inside(self, final: bool) -> None:
        for p in sorted(self.objects.values(), key=lambda o: o.support == "parent"):
            if p.segment_id not in self.objects or self.inside(p):
                continue
            excess = np.nan_to_num(room_excess(p, self.room), nan=0.0)
            inward = -(rotation_y(self.room.yaw) @ np.array([excess[0], 0.0, excess[2]]))
            ratios = np.linspace(0.98, 0.4, 30)
            options = [
                self.first(
                    lambda r: along_ray(p, p.scale * r, self.origin),
                    lambda c: c.scale >= self.smallest(p) and self.inside(c),
                    ratios,
                ),
                self.first(
                    lambda r: replace(p, scale=p.scale * r),
                    lambda c: c.scale >= self.smallest(p) and self.inside(c),
                    ratios,
                ),
            ]
            if not excess[1]:
                options.append(self.shifted(p, inward * 1.001))
            kept = self.kept_look(p)
            scored = sorted(
                ((kept(c), k, c) for k, c in enumerate(options) if c is not None and self.inside(c)),
                key=lambda t: (-t[0], t[1]),
            )
            if scored and scored[0][0] >= self.params.keep_iou:
                iou, _, best = scored[0]
                self.put(
                    best,
                    f"brought inside the room (scale {p.scale:.2f} -> {best.scale:.2f}, moved "
                    f"{float(np.linalg.norm(np.subtract(best.position, p.position))):.2f} m; "
                    f"silhouette IoU {iou:.2f} with before)",
                )
            elif not final:
                continue
            elif self.reach(p) > self.params.max_growth and p.segment_id not in self.drawn:
                self.drop(
                    p.segment_id,
                    f"{self.reach(p):.2f} m beyond the room box, and no change keeps its "
                    "silhouette: its depth is implausible",
                )
            else:
                self.room = grown(self.room, p.world_vertices())
                self.changed.append(
                    f"room box grown to {np.round(2 * np.asarray(self.room.half_size), 2).tolist()} m "
                    f"to hold {_name(p)} (no change kept its silhouette)"
                )

    def free_place(self, p: Placement, other: int) -> tuple[Placement, float] | None:
        """(``p`` freed from ``other`` (passing through nothing else deeper than before, reaching no farther beyond
        the room) by the change that keeps what the picture shows of it best, its :meth:`kept_sight`), of: about
        the shortest horizontal step per direction, and the least shrinking in place (down to its category's
        smallest size); None where no change keeps ``keep_iou`` of it."""
        reach = self.reach(p)
        through = dict(self.collisions(p))

        def free(c: Placement) -> bool:
            if self.reach(c) > reach + 1e-3:
                return False
            now = dict(self.collisions(c))
            return other not in now and all(depth <= through.get(k, 0.0) + 1e-3 for k, depth in now.items())

        options = [
            self.shortest(lambda d: self.shifted(p, d * direction), free, self.params.max_shift)
            for direction in self.directions(p)
        ]
        smallest = self.smallest(p) / p.scale
        options.append(
            self.first(
                lambda r: replace(p, scale=p.scale * r),
                free,
                np.linspace(0.97, 0.6, 13)[np.linspace(0.97, 0.6, 13) >= smallest],
            )
        )
        kept = self.kept_sight(p)
        scored = [(c, kept(c)) for c in options if c is not None]
        best = max(scored, key=lambda t: t[1], default=None)
        return best if best is not None and best[1] >= self.params.keep_iou else None

    def unhide(self, rounds: int = 3) -> None:
        """Rule 5 for every hidden object (the best attested first), until a round changes nothing."""
        if self.ids is None:
            return
        for _ in range(rounds):
            depths = {k: self.cached_depth(p) for k, p in self.objects.items()}
            pairs, changed = [], False
            for k in sorted(self.objects, key=self.strength, reverse=True):
                front = self.hider(k, depths)
                if front is not None and (self.blob_hides(front, k) or self.seen_behind(front, k)):
                    pairs.append((front, k))
            for front, back in pairs:
                if front in self.objects and back in self.objects:
                    changed |= self.show(front, back, depths)
            if not changed:
                return

    def blob_hides(self, front: int, back: int) -> bool:
        """Whether rule 5 acts on ``front`` hiding ``back``: ``front`` is a blob (its label names no kind, no person
        drew it) in front of a named object, neither standing on the other."""
        blob, hidden = self.objects[front], self.objects[back]
        return (
            _unknown(blob)
            and not _unknown(hidden)
            and front not in self.drawn
            and not (_stands_on(blob, hidden) or _stands_on(hidden, blob))
        )

    def seen_behind(self, front: int, back: int) -> bool:
        """Whether rule 5 acts on named ``front`` hiding named ``back`` because the network's 3D boxes put ``back``
        nearer by at least ``seen_order`` of its depth, neither standing on the other."""
        near, far = self.seen_depths.get(back), self.seen_depths.get(front)
        if self.params.seen_order <= 0 or near is None or far is None:
            return False
        hider, hidden = self.objects[front], self.objects[back]
        return (
            not (_unknown(hider) or _unknown(hidden))
            and front not in self.drawn
            and not (_stands_on(hider, hidden) or _stands_on(hidden, hider))
            and far > near * (1.0 + self.params.seen_order)
        )

    def show(self, front: int, back: int, depths: dict[int, np.ndarray]) -> bool:
        """Rule 5 for ``back``, where ``front`` still hides it (``depths``: each object's :meth:`depth`, kept up to
        date): ``front`` moved back, else, where :meth:`blob_hides` it, dropped where that shows ``back``. Returns
        whether anything changed."""
        if self.hider(back, depths) != front:
            return False
        blob, hidden = self.objects[front], self.objects[back]
        moved = self.back_to_show(front, back, depths)
        if moved is not None:
            self.put(
                moved,
                f"moved back along its ray (scale {blob.scale:.2f} -> {moved.scale:.2f}) behind {_name(hidden)}, "
                "which the photo shows there",
            )
            depths[front] = self.depth(moved)
            return True
        if not self.blob_hides(front, back):
            return False
        if self.hider(back, {k: d for k, d in depths.items() if k != front}) is not None:
            return False
        self.drop(
            front,
            f"hides {_name(hidden)}, which the photo shows there; it cannot move back, and its label names no kind",
        )
        for gone in [k for k in depths if k not in self.objects]:  # with its children
            del depths[gone]
        return True

    def back_to_show(self, front: int, hidden: int, depths: Mapping[int, np.ndarray]) -> Placement | None:
        """``front`` moved back along its camera ray, grown to keep its apparent size (:func:`along_ray`, by up to
        3x), just far enough that ``hidden`` is no longer hidden, within its category's sizes and ``keep_iou`` of
        its silhouette, reaching no farther beyond the room, passing no deeper through anything, and hiding
        nothing else; None where nothing does, or its support holds it in place, or something stands on it."""
        p = self.objects[front]
        if p.support not in _MOVABLE or any(_stands_on(c, p) for c in self.objects.values()):
            return None
        largest = scale_range(p.category, np.ptp(p.mesh.vertices, axis=0))[1] * math.exp(self.params.size_tolerance)
        keeps, reach = self.kept_look(p), self.reach(p)
        through = dict(self.collisions(p))
        already = self.hidden(depths) - {hidden}

        def ok(c: Placement) -> bool:
            if c.scale > largest or self.reach(c) > reach + 1e-3 or keeps(c) < self.params.keep_iou:
                return False
            if any(t > through.get(k, 0.0) + 1e-3 for k, t in self.collisions(c)):
                return False
            trial = {**depths, front: self.depth(c)}
            return self.hider(hidden, trial) is None and self.hidden(trial) <= already

        return self.first(lambda r: along_ray(p, p.scale * r, self.origin), ok, np.geomspace(1.05, 3.0, 16))

    def separate(self, final: bool, rounds: int = 3) -> None:
        parted: dict[int, list[tuple[Placement, Placement]]] = {}  # id -> (before, after) of those parted from it
        for _ in range(rounds):
            pairs = []
            for p in self.objects.values():
                pairs += [(p.segment_id, other, depth) for other, depth in self.collisions(p) if p.segment_id < other]
            if not pairs:
                return
            for a, b, depth in sorted(pairs, key=lambda t: -t[2]):
                if a not in self.objects or b not in self.objects:
                    continue
                if not any(o == b for o, _ in self.collisions(self.objects[a])):
                    continue
                weaker, stronger = sorted((a, b), key=self.strength)
                movers = [(weaker, stronger)]
                if self.strength(stronger)[0] == self.strength(weaker)[0]:  # as sure as each other: either moves
                    movers.append((stronger, weaker))
                moves = [
                    (found, mover, other)
                    for mover, other in movers
                    if (found := self.free_place(self.objects[mover], other)) is not None
                ]
                if moves:  # the change that alters the picture least (the weaker's on a tie)
                    (moved, iou), mover, other = max(moves, key=lambda m: m[0][1])
                    before = self.objects[mover]
                    shift = float(np.linalg.norm(np.subtract(moved.position, before.position)))
                    how = f"moved {shift:.2f} m" if shift > 1e-6 else f"scaled {before.scale:.2f} -> {moved.scale:.2f}"
                    self.put(
                        moved, f"{how} out of {_name(self.objects[other])} (seen silhouette IoU {iou:.2f} with before)"
                    )
                    parted.setdefault(other, []).append((before, moved))
                elif final and weaker not in self.drawn:  # two objects a person drew stay: what is left is reported
                    gone = _name(self.objects[weaker])
                    self.drop(
                        weaker,
                        f"passes {depth:.2f} m through {_name(self.objects[stronger])}, with no "
                        f"free place within {self.params.max_shift:g} m for either",
                    )
                    self.restore(parted.pop(weaker, []), gone)

    def restore(self, changes: list[tuple[Placement, Placement]], gone: str) -> None:
        """Undo ``changes`` (before, after) made to part objects from ``gone``, now dropped: each object still
        as the change left it goes back where that passes no deeper through anything and reaches no farther
        beyond the room."""
        for before, after in changes:
            if self.objects.get(after.segment_id) is not after:
                continue  # changed again since
            through = dict(self.collisions(after))
            if self.reach(before) <= self.reach(after) + 1e-3 and all(
                depth <= through.get(k, 0.0) + 1e-3 for k, depth in self.collisions(before)
            ):
                self.put(before, f"back as it was before it made room for {gone}, dropped")


def settle(
    placements: list[Placement],
    *,
    room: RoomBox,
    camera: Camera,
    drawn: set[int],
    pixels: Mapping[int, int],
    params: PhysicalParams,
    final: bool = True,
    ids: np.ndarray | None = None,
    scores: Mapping[int, float] | None = None,
    seen_depths: Mapping[int, float] | None = None,
) -> Settled:
    """The objects made physically possible (module docstring), judged in ``camera``'s picture (a small one
    will do); ``drawn``: segment ids a person drew; ``pixels``: each segment's pixel count; ``final``: the last
    settling, which may grow the room box and drop what it cannot part; ``ids``: the segmentation's id map at
    ``camera``'s size, what each pixel shows (rule 5; None: not checked); ``scores``: the prompt scores of the
    segments guessed automatically (those under ``weak_score`` are weak guesses; None, or a segment missing:
    sure, score 1); ``seen_depths``: the near-face depth of each segment the segmenting network boxed in 3D (its
    scale: only their order counts, rule 5)."""
    scene = _Scene(placements, room, camera, drawn, scores or {}, pixels, params, ids, seen_depths or {})
    scene.keep_sizes()
    scene.remove_duplicates()
    scene.keep_inside(final)
    scene.unhide()
    scene.separate(final)
    kept = [scene.objects[p.segment_id] for p in placements if p.segment_id in scene.objects]
    return Settled(kept, scene.room, scene.dropped, scene.changed)


def interpenetrations(placements: list[Placement], threshold: float) -> list[tuple[int, int, float]]:
    """(segment, segment, metres) of every pair passing through each other by more than ``threshold``."""
    found = []
    for i, a in enumerate(placements):
        for b in placements[i + 1 :]:
            thickness = overlap(a, b).thickness
            if thickness > threshold:
                found.append((a.segment_id, b.segment_id, round(thickness, 3)))
    return found


def settle_logged(
    objects: list[Placement],
    *,
    room: RoomBox,
    camera: Camera,
    panoptic: Panoptic,
    physical: PhysicalParams,
    stage: str,
    final: bool,
) -> Settled:
    """:func:`settle` with its changes logged as ``stage``'s (segments with no
    score were drawn; the others' prompt scores weigh their evidence)."""
    drawn = {s.id for s in panoptic.segments if s.score is None}
    scores = prompt_scores(panoptic)
    counts = np.bincount(panoptic.ids.ravel())
    pixels = {s.id: int(counts[s.id]) for s in panoptic.segments if s.id < len(counts)}
    settled = settle(
        objects,
        room=room,
        camera=camera,
        drawn=drawn,
        pixels=pixels,
        params=physical,
        final=final,
        ids=panoptic.ids_at(camera.width, camera.height),
        scores=scores,
        seen_depths={s.id: near_face_depth(s.seen) for s in panoptic.segments if s.seen is not None},
    )
    for note in settled.changed:
        log.info("%s: %s", stage, note)
    if settled.dropped:
        log.info("%s: dropped %d object(s): %s", stage, len(settled.dropped), "; ".join(settled.dropped))
    return settled


def prompt_scores(panoptic: Panoptic) -> dict[int, float]:
    """Segment id → its prompt's score, for the segments guessed automatically (a drawn segment has none)."""
    return {s.id: s.score for s in panoptic.segments if s.score is not None}
