"""Object discovery for ``segmentation=layout``: which box prompts become object segments, and in what order.

A bare photo's prompts are many and weak: the detector run at a low threshold on the photo and its mirror
image (an object is found whether or not its COCO class is right; a dresser comes back as "oven" or "tv"),
and the class-agnostic proposals of :mod:`.proposals` (what the fitted room cannot explain). Each prompt is
cut out by GrabCut (where it finds nothing, as among rows of alike chairs whose colours fill the box's margin
too, a network's instance filling the box stands in when one is given: :class:`~.objects.SeenObjects`; where
the cut stops above the box's bottom, the thin legs it smoothed away are added back: :func:`with_legs`), then
judged against the fitted box room (camera heights, floor ``y = -1``):

* **where it stands**: the mask's lowest pixels are its floor contact, unless the frame cuts them or they sit
  on a nearer object's mask; a sofa, chair, table, bed, desk, ottoman or refrigerator whose contact is above
  the horizon floats and is dropped;
* **how tall it is**: the top of the mask on the vertical plane through the contact, in metres for a camera
  ``camera_height_m`` above the floor, against its category's height range (``heights``, widened by
  ``size_slack`` both ways);
* **whether it is the room**: a weak prompt whose mask the room's colours explain (``max_explained``), or the
  network sees as wall, floor or ceiling (``max_seen_surface``: a sunlit patch of carpet), is dropped;
* **what it is**: each prompt takes the label that the prompts overlapping it score most in sum (the class
  is a weak prior: several weak "chair" boxes outvote one "tv");
* **whose part it is**: a prompt lying inside a better one's box (``part_overlap`` of its area) is a part of
  it when their categories say so (``parts``: a sofa's seat detected as a chair, a bed's pillow) or when
  both have the same category (a second box on one object); boxes overlapping more than ``nms_iou`` are one
  object whatever their labels; a class-agnostic proposal inside a known object's box is joined to its mask
  (a part its own cut missed); a box holding two or more weaker boxes of its category side by side is a box
  round a group (:func:`group_size`), unless a network sees one object filling it; nor does a weaker box take
  in a kept object the network sees as one of its own on the box's floor line (a chair in front of those behind
  it: :meth:`Selection.seen_apart`).

Kept prompts are painted far to near (by floor contact), so nearer objects occlude farther ones. Every
dropped prompt is logged with its reason.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np

from psdr_room_core.method.artifacts import Detection
from psdr_room_core.method.image_boxes import box_iou
from psdr_room_core.method.labels import primary_category
from psdr_room_core.method.surface_colours import SurfaceColours

from .objects import SeenObjects, grabcut_mask
from .proposals import clutter_proposals
from .settings import DiscoveryParams, GrabCutParams, ProposalParams

log = logging.getLogger("psdr_room")

FLOOR_STANDING = ("chair", "sofa", "ottoman", "bed", "table", "desk", "refrigerator", "object")
"""Database categories that cannot float: their contact must be on the floor (below the horizon). ``object``
(no known class: a class-agnostic proposal) too: a region the room does not explain above the horizon is more
often a window, a poster or a shadow than a thing the database holds."""


@dataclass(frozen=True)
class Footing:
    """Where an object's mask meets the floor of the fitted room."""

    depth: float | None
    """z-depth of the contact in camera heights; None when it is not seen (see ``seen``)."""
    seen: str
    """``floor`` (the contact is seen), ``cut`` (the frame cuts the bottom off: the object is near),
    ``hidden`` (a nearer object covers the bottom) or ``floating`` (the bottom is above the horizon)."""
    top_m: float | None = None
    """Height of the mask's top above the floor, metres, where the contact is seen."""

    @property
    def floating(self) -> bool:
        return self.seen == "floating"

    @property
    def distance(self) -> float:
        """For painting far to near: the contact's depth; objects cut by the frame are nearest, hidden and
        floating ones farthest."""
        if self.depth is not None:
            return self.depth
        return 0.0 if self.seen == "cut" else np.inf


@dataclass
class Candidate:
    """A prompt being judged: its detection, mask, database category and footing."""

    detection: Detection
    mask: np.ndarray
    category: str
    footing: Footing

    @property
    def box(self) -> np.ndarray:
        return np.asarray(self.detection.box, np.float64)


@dataclass(frozen=True)
class Discovered:
    """A kept object, in painting order."""

    detection: Detection
    mask: np.ndarray


def footing(
    mask: np.ndarray,
    rays: np.ndarray,
    occluders: np.ndarray,
    camera_height_m: float,
    box: tuple[float, float, float, float] | None = None,
    band: int = 3,
) -> Footing:
    """The floor contact of ``mask`` in the fitted room: ``rays`` (H, W, 3) are frame-coordinate pixel rays with
    unit camera z (floor ``y = -1``); ``occluders`` marks pixels of nearer objects. The contact is the median
    column of the mask's lowest ``band`` rows, on the prompt ``box``'s bottom row where that is lower (the
    cut loses thin legs, the box reaches the floor); the top is the highest mask pixel of the columns near it,
    on the vertical plane through the contact facing the camera."""
    height = mask.shape[0]
    rows = np.flatnonzero(mask.any(axis=1))
    low = mask[max(0, int(rows[-1]) - band + 1) : int(rows[-1]) + 1].any(axis=0)
    bottom = int(rows[-1]) if box is None else min(height - 1, max(int(rows[-1]), int(np.ceil(box[3])) - 1))
    col = int(np.median(np.flatnonzero(low)))
    below = occluders[min(height - 1, bottom + 1) : min(height, bottom + 1 + band), np.flatnonzero(low)]
    if bottom >= height - 2:
        return Footing(depth=None, seen="cut")
    if below.size and below.mean() > 0.5:
        return Footing(depth=None, seen="hidden")
    ray = rays[bottom, col]
    if ray[1] >= -1e-6:
        return Footing(depth=None, seen="floating")
    depth = -1.0 / float(ray[1])  # rays have unit camera z: the ray parameter is the z-depth
    contact = ray * depth
    normal = np.array([ray[0], 0.0, ray[2]]) / max(float(np.hypot(ray[0], ray[2])), 1e-9)
    columns = np.flatnonzero(mask.any(axis=0))
    near = columns[np.abs(columns - col) <= max(2, len(columns) // 4)]
    top_ray = rays[int(np.flatnonzero(mask[:, near].any(axis=1))[0]), col]
    along = float(top_ray @ normal)
    top = (float(contact @ normal) / along * float(top_ray[1]) + 1.0) * camera_height_m if along > 1e-6 else None
    return Footing(depth=depth, seen="floor", top_m=top)


def _inside(inner: np.ndarray, outer: np.ndarray) -> float:
    """Share of box ``inner``'s area inside box ``outer``."""
    w = max(0.0, min(inner[2], outer[2]) - max(inner[0], outer[0]))
    h = max(0.0, min(inner[3], outer[3]) - max(inner[1], outer[1]))
    return w * h / max((inner[2] - inner[0]) * (inner[3] - inner[1]), 1e-9)


def with_legs(mask: np.ndarray, box: tuple[float, float, float, float], unlike: np.ndarray) -> np.ndarray:
    """``mask`` with what stands below it in ``box``: the pixels from its ragged lowest rows down to the box's
    bottom, in its columns, unlike the room surface they lie on (``unlike``: colours rare on it) that join it:
    the thin legs GrabCut smooths away against the floor, where the detector's box reaches the floor and the cut
    does not."""
    x0, x1 = max(0, int(box[0])), min(mask.shape[1], int(np.ceil(box[2])))
    y1 = min(mask.shape[0], int(np.ceil(box[3])))
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    bottom = int(rows[-1])
    if bottom + 1 >= y1:
        return mask
    below = np.zeros(mask.shape, bool)
    below[bottom - 2 : y1, max(x0, int(cols[0])) : min(x1, int(cols[-1]) + 1)] = True
    _, components = cv2.connectedComponents(((unlike & below) | mask).astype(np.uint8), connectivity=8)
    joined = np.unique(components[mask])
    return np.isin(components, joined[joined > 0])


def implausible(candidate: Candidate, params: DiscoveryParams) -> str | None:
    """Why a prompt cannot be the object its category says, from where it stands and how tall it is."""
    name = candidate.category
    if candidate.footing.floating and name in FLOOR_STANDING:
        return f"a {name} floating above the horizon"
    top = candidate.footing.top_m
    if top is not None:
        lo, hi = params.heights.get(name, params.heights["object"])
        if not lo / params.size_slack <= top <= hi * params.size_slack:
            return f"{top:.2f} m tall for a {name} ({lo:g}-{hi:g} m)"
    return None


def part_of(candidate: Candidate, kept: Candidate, params: DiscoveryParams) -> bool:
    """Whether ``candidate`` is the same object as ``kept`` (boxes overlapping more than ``nms_iou``, or a box
    of the same category inside it and on the same floor line) or a part of it (``parts``)."""
    if box_iou(candidate.box, kept.box[None])[0] > params.nms_iou:
        return True
    if _inside(candidate.box, kept.box) < params.part_overlap:
        return False
    if candidate.category in params.parts.get(kept.category, ()) or candidate.category == "object":
        return True  # a named part, or a thing of no known class inside a known object
    tall = kept.box[3] - kept.box[1]
    return candidate.category == kept.category and abs(candidate.box[3] - kept.box[3]) <= params.floor_line * tall


def absorbs(candidate: Candidate, kept: Candidate, params: DiscoveryParams) -> bool:
    """Whether ``candidate`` is the whole of which the better-scoring ``kept`` is a part or a piece: ``kept``
    lies inside it, is one of its ``parts`` or of its category (a table's top boxed apart from the table; a
    sofa found after its seat was taken for a chair), and ``candidate`` scores at least ``absorb_score`` of
    ``kept``'s score. (A box holding several objects of its category is a group, not a whole: see
    :func:`group_size`.)"""
    return (
        (kept.category == candidate.category or kept.category in params.parts.get(candidate.category, ()))
        and _inside(kept.box, candidate.box) >= params.part_overlap
        and candidate.detection.score >= params.absorb_score * kept.detection.score
    )


def _side_by_side(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two boxes stand side by side: their columns overlap by less than half the narrower one's."""
    overlap = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    return overlap < 0.5 * min(a[2] - a[0], b[2] - b[0])


def group_size(candidate: Candidate, others: Sequence[Candidate], params: DiscoveryParams) -> int:
    """How many prompts of ``candidate``'s category, scoring at least ``group_score`` of it and standing side
    by side, lie inside its box: two or more make it a box round a group (two chairs in one "chair" box).
    Prompts stacked in the same columns are pieces of one object (a chair's back boxed apart from its seat)."""
    inside = [
        o
        for o in others
        if o is not candidate
        and o.category == candidate.category
        and o.detection.score >= params.group_score * candidate.detection.score
        and _inside(o.box, candidate.box) >= params.part_overlap
        and box_iou(o.box, candidate.box[None])[0] <= params.nms_iou
    ]
    chosen: list[Candidate] = []
    for o in inside:
        if all(_side_by_side(o.box, c.box) for c in chosen):
            chosen.append(o)
    return len(chosen)


def covers_kept(box: np.ndarray, kept: Sequence[Candidate], occupied: np.ndarray, params: DiscoveryParams) -> bool:
    """Whether ``box`` is a box round kept objects: it holds most of two or more of their masks, and they cover
    more than ``max_covered`` of it."""
    x0, y0, x1, y1 = np.clip(np.round(box).astype(int), 0, [occupied.shape[1], occupied.shape[0]] * 2)
    if x1 <= x0 or y1 <= y0 or occupied[y0:y1, x0:x1].mean() <= params.max_covered:
        return False
    held = [k for k in kept if k.mask[y0:y1, x0:x1].sum() >= 0.7 * k.mask.sum()]
    return len(held) >= 2


def vote_labels(prompts: Sequence[Detection], iou: float) -> list[Detection]:
    """Each prompt relabelled with the label whose prompts overlapping it (box IoU above ``iou``, itself
    included) score most in sum: the detector's class is a weak prior, and several weak "chair" boxes on an
    object outvote the one "tv" box that happened to score highest."""
    boxes = np.array([p.box for p in prompts], np.float64).reshape(-1, 4)
    voted = []
    for p, b in zip(prompts, boxes):
        votes: dict[str, float] = {}
        for q, overlapping in zip(prompts, box_iou(b, boxes) > iou):
            if q is p or overlapping:
                votes[q.label] = votes.get(q.label, 0.0) + q.score
        best = max(votes, key=lambda label: (votes[label], label == p.label))
        voted.append(p if best == p.label else replace(p, label=best))
    return voted


class Selection:
    """The objects kept so far and why others were dropped, as prompts are considered one by one."""

    def __init__(
        self,
        rgb8: np.ndarray,
        rays: np.ndarray,
        surfaces: SurfaceColours,
        params: DiscoveryParams,
        grabcut: GrabCutParams,
        seen: SeenObjects | None = None,
    ) -> None:
        self.rgb8, self.rays, self.surfaces, self.params = rgb8, rays, surfaces, params
        self.grabcut = grabcut
        self.seen = seen
        self.rare = surfaces.commonness < params.leg_rarity
        """(H, W) pixels whose colour is rare on the room surface they lie on: what legs below a cut may be."""
        self.kept: list[Candidate] = []
        self.dropped: dict[str, list[str]] = {}
        self.as_seen: list[str] = []

    @property
    def occupied(self) -> np.ndarray:
        """(H, W) the pixels kept objects hold."""
        return np.any([k.mask for k in self.kept], axis=0) if self.kept else np.zeros(self.rgb8.shape[:2], bool)

    def drop(self, reason: str, candidate: Candidate) -> None:
        self.dropped.setdefault(reason, []).append(candidate.detection.label)

    def consider(self, prompts: Sequence[Detection]) -> None:
        """Judge ``prompts``, best first, against the kept objects (see the module docstring)."""
        params, unseen = self.params, Footing(None, "hidden")
        strong = vote_labels([p for p in prompts if p.score >= params.min_score], params.nms_iou)
        probes = []
        for p in sorted(strong, key=lambda p: -p.score):
            category = primary_category(p.label, p.category)
            probe = Candidate(p, np.zeros(0, bool), category or "object", unseen)
            if category is None:
                self.drop("not furniture the object database holds", probe)
            else:
                probes.append(probe)
        for probe in probes:
            whole = next((k for k in self.kept if part_of(probe, k, params)), None)
            if whole is not None and probe.category == "object" and whole.category != "object":
                self.join(probe, whole)
                continue
            if whole is not None:
                self.drop(f"part of a {whole.detection.label}", probe)
                continue
            members = group_size(probe, probes, params)
            if members >= 2 and (self.seen is None or self.seen.instance(probe.detection.box, params.seen_iou) is None):
                self.drop(f"a box round {members} objects", probe)
                continue
            absorbed = [k for k in self.kept if absorbs(probe, k, params) and not self.seen_apart(k, probe)]
            rest = [k for k in self.kept if k not in absorbed]
            occupied = np.any([k.mask for k in rest], axis=0) if rest else np.zeros(self.rgb8.shape[:2], bool)
            if covers_kept(probe.box, rest, occupied, params):
                self.drop("a box round kept objects", probe)
                continue
            if len(rest) >= params.max_objects:
                self.drop("over max_objects", probe)
                continue
            mask = self.cut(probe, occupied)
            if mask is None:
                self.drop("GrabCut found no object", probe)
                continue
            weak = probe.detection.score < params.trusted_score
            if weak and self.surfaces.share_explained(mask) > params.max_explained:
                self.drop("weak, and the room's colours explain it", probe)
                continue
            if weak and self.seen is not None and self.seen.surface_share(mask) > params.max_seen_surface:
                self.drop("weak, and the network sees a room surface there", probe)
                continue
            candidate = Candidate(
                probe.detection,
                mask,
                probe.category,
                footing(mask, self.rays, occupied & ~mask, params.camera_height_m, probe.detection.box),
            )
            reason = implausible(candidate, params)
            if reason is not None:
                self.drop(reason, candidate)
                continue
            for part in absorbed:
                self.drop(f"part of a {probe.detection.label}", part)
            self.kept = [*rest, candidate]

    def seen_apart(self, piece: Candidate, whole: Candidate) -> bool:
        """Whether ``piece`` is an object of its own in front of what else ``whole`` boxes: its bottom is on
        ``whole``'s floor line (``floor_line``; a chair's back or a table's top, boxed apart, ends above it) and
        the network sees it apart (:meth:`~.objects.SeenObjects.apart`). Then ``whole`` is a weak box round it
        and the objects behind it (a chair in front of two more), and may not absorb it."""
        tall = whole.box[3] - whole.box[1]
        return (
            self.seen is not None
            and abs(piece.box[3] - whole.box[3]) <= self.params.floor_line * tall
            and self.seen.apart(tuple(piece.box), tuple(whole.box), self.params.seen_iou)
        )

    def cut(self, probe: Candidate, taken: np.ndarray) -> np.ndarray | None:
        """The prompt's mask: GrabCut's (with the legs below it of what stands on the floor: :func:`with_legs`),
        else the network's instance filling its box (:meth:`~.objects.SeenObjects.mask`), neither taking pixels
        ``taken`` by kept objects."""
        box = probe.detection.box
        mask = grabcut_mask(self.rgb8, box, self.grabcut, taken=taken)
        if mask is not None and probe.category in FLOOR_STANDING:
            mask = with_legs(mask, box, self.rare & ~taken)
        if mask is None and self.seen is not None:
            mask = self.seen.mask(box, taken, self.grabcut.min_fill, self.params.seen_iou)
            if mask is not None:
                self.as_seen.append(probe.detection.label)
        return mask

    def join(self, piece: Candidate, whole: Candidate) -> None:
        """Add what GrabCut finds in ``piece``'s box (pixels no other object holds) to ``whole``'s mask: an
        unexplained region inside a known object's box is a part the object's own cut missed (a chair's seat
        lit differently from its back)."""
        others = [k.mask for k in self.kept if k is not whole]
        taken = np.any(others, axis=0) if others else np.zeros(self.rgb8.shape[:2], bool)
        mask = grabcut_mask(self.rgb8, tuple(piece.box), self.grabcut, taken=taken | whole.mask)
        if mask is None:
            self.drop("GrabCut found no object", piece)
            return
        whole.mask = whole.mask | (mask & ~taken)
        self.drop(f"joined to a {whole.detection.label}", piece)

    def painted(self) -> list[Discovered]:
        """The kept objects far to near, each with the pixels nearer ones leave it; those showing less than
        ``min_visible`` of their mask are dropped."""
        far = sorted(self.kept, key=lambda c: -c.footing.distance)
        found = []
        for i, candidate in enumerate(far):
            nearer = [c.mask for c in far[i + 1 :]]
            shown = candidate.mask & ~np.any(nearer, axis=0) if nearer else candidate.mask
            if shown.sum() < self.params.min_visible * candidate.mask.sum():
                self.drop("hidden by nearer objects", candidate)
            else:
                found.append(Discovered(candidate.detection, shown))
        return found

    def log(self) -> None:
        if self.as_seen:
            log.info(
                "discovery: %d prompt(s) GrabCut found nothing in took the network's mask: %s",
                len(self.as_seen),
                ", ".join(sorted(set(self.as_seen))),
            )
        for reason, labels in self.dropped.items():
            log.info("discovery: dropped %d prompt(s) (%s): %s", len(labels), reason, ", ".join(sorted(set(labels))))


def discover(
    rgb8: np.ndarray,
    rays: np.ndarray,
    surfaces: SurfaceColours,
    prompts: Sequence[Detection],
    params: DiscoveryParams,
    proposals: ProposalParams | None,
    grabcut: GrabCutParams,
    seen: SeenObjects | None = None,
) -> list[Discovered]:
    """The objects among ``prompts`` and then among the class-agnostic proposals round what they leave
    unexplained (:func:`~.proposals.clutter_proposals`, unless ``proposals`` is None), far to near (see the
    module docstring); ``rays`` as :func:`footing`'s, ``surfaces`` the colour models of the fitted room; each
    prompt's mask cut by GrabCut with ``grabcut``, or, where GrabCut finds nothing,
    the instance a network ``seen`` sees filling its box (which is then no box round a group either)."""
    selection = Selection(rgb8, rays, surfaces, params, grabcut, seen)
    selection.consider(prompts)
    if proposals is not None:
        selection.consider(clutter_proposals(surfaces, selection.occupied, proposals))
    found = selection.painted()
    selection.log()
    return found
