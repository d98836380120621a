"""Object discovery of segmentation=layout on a synthetic box room: footings, the prompt rules, proposals."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from psdr_room_core.engine import shipped
from psdr_room_core.method.artifacts import Camera, Detection, Detections, Image, Panoptic, SeenBox, Segment
from psdr_room_core.method.labels import alternates, meaning, primary_category
from psdr_room_core.method.surface_colours import SurfaceColours, unprompted
from psdr_room_plugins.layout import box
from psdr_room_plugins.layout.discovery import (
    Candidate,
    Footing,
    Selection,
    absorbs,
    discover,
    footing,
    group_size,
    implausible,
    part_of,
    vote_labels,
    with_legs,
)
from psdr_room_plugins.layout.manhattan import frame_from_vanishing_points
from psdr_room_plugins.layout.objects import SeenObjects
from psdr_room_plugins.layout.proposals import clutter_proposals
from psdr_room_plugins.layout.segmentation import LayoutSegmentation
from psdr_room_plugins.layout.settings import (
    DiscoveryParams,
    GrabCutParams,
    LayoutSegmentationSettings,
    ProposalParams,
)

PHOTO = Path("room.png")
DISCOVERY = shipped.settings(DiscoveryParams, "segmentation.layout.discovery")
PROPOSALS = shipped.settings(ProposalParams, "segmentation.layout.proposals")
GRABCUT = shipped.settings(GrabCutParams, "segmentation.layout.grabcut")
ROOM = np.array([-2.0, 1.6, 0.7, -3.0, 3.2])  # camera heights (psdr_room_plugins.layout.box)
WIDTH, HEIGHT = 320, 240


def _rotation(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    yaw = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    pitch = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    return pitch @ np.diag([-1.0, -1.0, 1.0]) @ yaw


@pytest.fixture(scope="module")
def room() -> dict:
    """A plain box room (one flat grey per surface, a little noise) seen by a known camera."""
    rotation = _rotation(25.0, 8.0)
    camera = Camera.from_vfov(WIDTH, HEIGHT, 55.0)
    vps = (camera.K @ rotation).T
    camera = Camera.from_vfov(
        WIDTH, HEIGHT, 55.0, vanishing_points=[tuple(v) for v in vps / np.linalg.norm(vps, axis=1, keepdims=True)]
    )
    frame = frame_from_vanishing_points(camera, camera.vanishing_points)
    rays = frame.rays(camera, WIDTH, HEIGHT)
    labels, t = box.trace(rays.reshape(-1, 3), ROOM[None])
    labels, t = labels[0].reshape(HEIGHT, WIDTH), t[0].reshape(HEIGHT, WIDTH)
    shade = np.array([0.55, 0.62, 0.35, 0.85, 0.6, 0.7])[labels]
    rgb = np.repeat(shade[..., None], 3, axis=2) * np.array([1.0, 0.97, 0.9])
    rgb = rgb + np.random.default_rng(0).normal(0, 0.01, rgb.shape)
    return {"camera": camera, "rays": rays, "labels": labels, "t": t, "rgb": np.clip(rgb, 0, 1).astype(np.float32)}


def _standing_box(
    room: dict, left: int, right: int, height_m: float, camera_height_m: float = 1.5, above_bottom: int = 20
) -> np.ndarray:
    """The mask of a front-facing panel standing on the floor: columns ``left:right``, bottom on the floor
    ``above_bottom`` rows above the photo's bottom edge, top ``height_m`` above the floor."""
    rays, labels, t = room["rays"], room["labels"], room["t"]
    col = (left + right) // 2
    bottom = HEIGHT - 1 - above_bottom
    assert labels[bottom, col] == box.FLOOR
    depth = t[bottom, col]
    contact = rays[bottom, col] * depth
    normal = np.array([contact[0], 0.0, contact[2]]) / np.hypot(contact[0], contact[2])
    top_y = height_m / camera_height_m - 1.0
    along = rays[:, col] @ normal
    y_on_plane = rays[:, col, 1] * (contact @ normal) / along
    top = int(np.flatnonzero(y_on_plane <= top_y)[0])
    mask = np.zeros(labels.shape, bool)
    mask[top : bottom + 1, left:right] = True
    return mask


def _painted(room: dict, *pieces: tuple[np.ndarray, list[float]]) -> tuple[np.ndarray, SurfaceColours]:
    """The room's photo (uint8) with each (mask, colour) painted in turn, and the colour models of its surfaces."""
    rgb = room["rgb"].copy()
    for mask, colour in pieces:
        rgb[mask] = colour
    rgb8 = (rgb * 255).astype(np.uint8)
    return rgb8, SurfaceColours(rgb8, room["labels"], unprompted(room["labels"].shape, []))


def _candidate(label: str, box_: tuple, score: float, seen: str = "floor") -> Candidate:
    category = primary_category(label) or "object"
    return Candidate(Detection(label, "object", box_, score), np.zeros((1, 1), bool), category, Footing(None, seen))


# ----------------------------------------------------------------------------------------------- footing
def test_footing_measures_where_an_object_stands_and_how_tall_it_is(room: dict) -> None:
    mask = _standing_box(room, 140, 180, height_m=0.8)
    found = footing(mask, room["rays"], np.zeros_like(mask), camera_height_m=1.5)
    bottom = np.flatnonzero(mask.any(axis=1))[-1]
    assert found.seen == "floor" and found.depth == pytest.approx(room["t"][bottom, 160], rel=0.02)
    assert found.top_m == pytest.approx(0.8, abs=0.04)
    cut = np.zeros_like(mask)
    cut[150:, 100:140] = True  # runs off the bottom of the photo
    assert footing(cut, room["rays"], np.zeros_like(mask), 1.5).seen == "cut"
    hidden = footing(mask, room["rays"], np.roll(mask, 20, axis=0) & ~mask, 1.5)  # a nearer object below it
    assert hidden.seen == "hidden" and hidden.top_m is None
    high = np.zeros_like(mask)
    high[5:30, 140:170] = True  # above the horizon: on a wall
    assert footing(high, room["rays"], np.zeros_like(mask), 1.5).floating


def test_a_cut_that_stops_at_the_seat_gets_the_legs_below_it() -> None:
    """GrabCut smooths a chair's thin legs away against the floor: the cut stops at the seat while the prompt box
    reaches the floor. The pixels below the cut, in its columns and inside the box, unlike the floor and joining
    the cut are its legs; the floor, an unlike patch that joins nothing, what stands beside the cut's columns and
    what lies below the box are not. A cut reaching its box's bottom is left as it is."""
    cut = np.zeros((80, 100), bool)
    cut[20:41, 30:71] = True  # back and seat
    unlike = cut.copy()
    unlike[41:60, 31:34] = unlike[41:60, 66:69] = True  # two legs down to the floor
    unlike[50:53, 48:52] = True  # a stain on the carpet, apart from the chair
    unlike[41:60, 80:83] = True  # the leg of the chair beside it
    unlike[60:75, 31:34] = True  # below the box: the next chair's back
    box = (28.0, 18.0, 72.0, 60.0)
    mask = with_legs(cut, box, unlike)
    legs = mask & ~cut
    assert legs.sum() == 2 * 19 * 3 and legs[41:60, 31:34].all() and legs[41:60, 66:69].all()
    assert not mask[50:53, 48:52].any() and not mask[:, 80:].any() and not mask[60:].any()
    assert (with_legs(cut, (28.0, 18.0, 72.0, 41.0), unlike) == cut).all()  # the cut reaches its box's bottom


def test_how_common_each_pixels_colour_is_on_its_surface(room: dict) -> None:
    """A floor with a patterned carpet (a tenth of it a second colour) and a chair's steel leg on it: the
    carpet's main colour is common, its pattern less so, the leg's colour the rarest of all."""
    floor = room["labels"] == box.FLOOR
    rows, cols = np.nonzero(floor)
    pattern = floor & (np.arange(WIDTH)[None, :] % 10 == 0)
    leg = np.zeros(floor.shape, bool)
    leg[rows.max() - 30 : rows.max() - 5, cols.mean().astype(int) : cols.mean().astype(int) + 2] = True
    rgb8, _ = _painted(room, (pattern, [0.3, 0.1, 0.1]), (leg, [0.8, 0.8, 0.85]))
    colours = SurfaceColours(rgb8, room["labels"], np.ones(floor.shape, bool))
    carpet = floor & ~pattern & ~leg
    assert np.median(colours.commonness[carpet]) > 0.2
    assert 0.0 < np.median(colours.commonness[pattern & ~leg]) < np.median(colours.commonness[carpet])
    assert (colours.commonness[leg] < DISCOVERY.leg_rarity).all()


def test_implausible_footings_and_heights() -> None:
    params = DISCOVERY
    chair = _candidate("chair", (0, 0, 10, 10), 0.5)
    assert implausible(chair, params) is None
    floating = Candidate(chair.detection, chair.mask, "chair", Footing(None, "floating"))
    assert "floating" in implausible(floating, params)
    assert implausible(Candidate(chair.detection, chair.mask, "frame", Footing(None, "floating")), params) is None
    tall = Candidate(chair.detection, chair.mask, "chair", Footing(3.0, "floor", top_m=4.5))
    assert "4.50 m tall for a chair" in implausible(tall, params)
    shelf = Candidate(chair.detection, chair.mask, "shelf", Footing(3.0, "floor", top_m=2.2))
    assert implausible(shelf, params) is None


# ----------------------------------------------------------------------------------------------- prompt rules
def test_a_sofa_keeps_its_seats_whichever_is_found_first() -> None:
    params = DISCOVERY
    sofa = _candidate("couch", (100, 100, 300, 180), 0.5)
    seat = _candidate("chair", (190, 110, 290, 180), 0.45)  # the right half, taken for a chair
    assert part_of(seat, sofa, params)  # the sofa first: the seat is its part
    assert absorbs(sofa, seat, params)  # the seat first: the sofa takes it back
    weak_sofa = _candidate("couch", (100, 100, 300, 180), 0.1)
    assert not absorbs(weak_sofa, seat, params)  # a far weaker "couch" does not swallow a confident chair


def test_chairs_behind_chairs_stay_apart_but_second_boxes_on_one_object_merge() -> None:
    params = DISCOVERY
    near = _candidate("chair", (100, 100, 220, 300), 0.7)
    behind = _candidate("chair", (130, 110, 200, 220), 0.4)  # inside its box, standing further back (higher)
    assert not part_of(behind, near, params)
    second = _candidate("chair", (105, 150, 215, 298), 0.3)  # a second box on the same chair
    assert part_of(second, near, params)
    top = _candidate("dining table", (100, 100, 400, 140), 0.5)  # a table's top boxed apart from the table
    whole = _candidate("dining table", (95, 95, 405, 260), 0.4)
    assert absorbs(whole, top, params) and not part_of(whole, top, params)


def test_a_box_round_two_chairs_is_a_group() -> None:
    params = DISCOVERY
    both = _candidate("chair", (100, 100, 400, 300), 0.3)
    left, right = _candidate("chair", (105, 110, 240, 300), 0.6), _candidate("chair", (260, 105, 395, 298), 0.5)
    assert group_size(both, [both, left, right], params) == 2
    assert group_size(both, [both, left], params) == 1
    faint = _candidate("chair", (260, 105, 395, 298), 0.1)
    assert group_size(both, [both, left, faint], params) == 1  # too faint to count
    back, seat = _candidate("chair", (110, 100, 300, 190), 0.5), _candidate("chair", (100, 200, 310, 298), 0.5)
    assert group_size(both, [both, back, seat], params) == 1  # stacked: one chair's back and seat


def test_weak_prompts_the_room_explains_are_dropped(room: dict) -> None:
    cabinet = _standing_box(room, 60, 120, height_m=0.9)
    rgb8, surfaces = _painted(room, (cabinet, [0.55, 0.25, 0.15]))
    rows, cols = np.nonzero(cabinet)
    around = (cols.min() - 3.0, rows.min() - 3.0, cols.max() + 4.0, rows.max() + 4.0)
    on_cabinet = Detection("oven", "object", around, 0.2)
    on_floor = Detection("bed", "object", (180.0, 200.0, 300.0, 238.0), 0.2)  # nothing there but floor
    found = discover(rgb8, room["rays"], surfaces, [on_cabinet, on_floor], DISCOVERY, None, GRABCUT)
    assert [f.detection.label for f in found] == ["oven"]
    assert (found[0].mask & cabinet).sum() / (found[0].mask | cabinet).sum() > 0.8


def test_nearer_objects_are_painted_over_farther_ones(room: dict) -> None:
    far, near = _standing_box(room, 120, 200, 1.0, above_bottom=50), _standing_box(room, 150, 230, 0.7, above_bottom=8)
    rgb8, surfaces = _painted(room, (far, [0.2, 0.3, 0.7]), (near, [0.7, 0.2, 0.2]))

    def around(mask: np.ndarray, label: str, score: float) -> Detection:
        rows, cols = np.nonzero(mask)
        return Detection(
            label, "object", (cols.min() - 2.0, rows.min() - 2.0, cols.max() + 3.0, rows.max() + 3.0), score
        )

    found = discover(
        rgb8,
        room["rays"],
        surfaces,
        [around(near, "chair", 0.8), around(far, "cabinet", 0.6)],
        DISCOVERY,
        None,
        GRABCUT,
    )
    assert [f.detection.label for f in found] == ["cabinet", "chair"]  # far first
    assert not (found[0].mask & found[1].mask).any()


# ----------------------------------------------------------------------------------------------- proposals
def test_what_the_room_cannot_explain_becomes_an_object(room: dict) -> None:
    """No prompt at all: a red cabinet against the plain room is found by its colour alone."""
    cabinet = _standing_box(room, 60, 120, height_m=0.9)
    rgb8, surfaces = _painted(room, (cabinet, [0.55, 0.25, 0.15]))
    proposals = clutter_proposals(surfaces, np.zeros_like(cabinet), PROPOSALS)
    assert len(proposals) == 1 and proposals[0].label == "object"
    assert proposals[0].score < DISCOVERY.trusted_score  # weak: every check applies
    image = Image(rgb=rgb8.astype(np.float32) / 255.0, source=str(PHOTO), original_size=(WIDTH, HEIGHT))
    layout = shipped.arguments(LayoutSegmentationSettings, "segmentation.layout")
    segmentation = LayoutSegmentation(**{**layout, "n_random": 1500})
    panoptic = segmentation.segment(image, room["camera"], Detections(items=[]), PHOTO)
    objects = [s for s in panoptic.segments if s.category == "object"]
    assert len(objects) == 1 and objects[0].label == "object" and objects[0].score == pytest.approx(0.2)
    mask = panoptic.ids == objects[0].id
    assert (mask & cabinet).sum() / (mask | cabinet).sum() > 0.8


def test_an_empty_room_gives_no_objects_and_no_error(room: dict) -> None:
    rgb8 = (room["rgb"] * 255).astype(np.uint8)
    surfaces = SurfaceColours(rgb8, room["labels"], np.ones(room["labels"].shape, bool))
    assert clutter_proposals(surfaces, np.zeros(room["labels"].shape, bool), PROPOSALS) == []
    assert discover(rgb8, room["rays"], surfaces, [], DISCOVERY, PROPOSALS, GRABCUT) == []
    selection = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT)
    selection.consider([Detection("chair", "object", (0.0, 0.0, 1.0, 1.0), 0.9)])  # a one-pixel box
    assert selection.kept == []


# ----------------------------------------------------------------------------------------------- categories
def test_overlapping_prompts_vote_for_the_label() -> None:
    tv = Detection("tv", "object", (100.0, 100.0, 200.0, 220.0), 0.3)
    chairs = [
        Detection("chair", "object", (102.0, 98.0, 198.0, 222.0), 0.2),
        Detection("chair", "object", (98.0, 104.0, 204.0, 218.0), 0.18),
    ]
    far = Detection("tv", "object", (400.0, 100.0, 450.0, 150.0), 0.3)
    voted = vote_labels([tv, *chairs, far], iou=0.6)
    assert [d.label for d in voted] == ["chair", "chair", "chair", "tv"]
    assert voted[0].score == 0.3 and voted[0].box == tv.box


def test_a_proposal_inside_a_known_object_joins_it(room: dict) -> None:
    """A chair whose cut kept its back but not its seat (lit brighter): the seat, which the room cannot explain,
    is proposed and joined to the chair instead of becoming an object of its own."""
    back, seat = _standing_box(room, 60, 120, height_m=0.9), _standing_box(room, 60, 120, height_m=0.45)
    back &= ~seat
    rgb8, surfaces = _painted(room, (back, [0.55, 0.1, 0.35]), (seat, [0.95, 0.7, 0.2]))
    whole = back | seat
    rows, cols = np.nonzero(whole)
    box = (cols.min() - 2.0, rows.min() - 2.0, cols.max() + 3.0, rows.max() + 3.0)
    selection = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT)
    selection.kept = [Candidate(Detection("chair", "object", box, 0.8), back.copy(), "chair", Footing(None, "cut"))]
    selection.consider(clutter_proposals(surfaces, selection.occupied, PROPOSALS))
    assert len(selection.kept) == 1 and "joined to a chair" in selection.dropped
    assert (selection.kept[0].mask & whole).sum() / whole.sum() > 0.9


# ----------------------------------------------------------------------------------------------- a network's masks
def test_what_a_network_sees_in_a_box() -> None:
    """The one instance filling the box, never pixels taken; nothing where no instance fills it, or too little
    of the box is left."""
    ids = np.zeros((100, 100), np.int32)
    ids[20:60, 10:40] = 1  # a chair
    ids[20:60, 45:80] = 2  # the chair beside it
    ids[70:90, 10:90] = 3  # a wall segment is no object
    panoptic = Panoptic(ids, [Segment(1, "object", "chair"), Segment(2, "object", "chair"), Segment(3, "wall", "wall")])
    seen = SeenObjects.of(panoptic)
    assert len(seen.instances) == 2
    first = (8.0, 18.0, 47.0, 62.0)
    assert seen.instance(first, 0.5) is seen.instances[0]
    free = np.zeros(ids.shape, bool)
    mask = seen.mask(first, free, min_fill=0.08, same_iou=0.5)
    assert mask is not None and mask.sum() == 40 * 30 and not mask[:, 45:].any()
    both = (0.0, 0.0, 100.0, 65.0)
    assert seen.instance(both, 0.5) is None and seen.mask(both, free, 0.08, 0.5) is None  # neither is the one
    assert seen.apart(first, both, 0.5) and not seen.apart(first, first, 0.5)  # the first chair, apart from both
    assert not seen.apart(both, first, 0.5)  # no one instance fills the box round both
    taken = np.zeros(ids.shape, bool)
    taken[20:60, 10:38] = True  # a nearer object holds most of the first chair
    assert seen.mask(first, taken, min_fill=0.3, same_iou=0.5) is None
    assert seen.mask(first, taken, min_fill=0.01, same_iou=0.5).sum() == 40 * 2
    assert seen.mask((10.0, 70.0, 90.0, 90.0), free, min_fill=0.08, same_iou=0.5) is None  # on the wall: nothing


def test_a_networks_instance_is_a_second_opinion_on_the_label() -> None:
    """COCO calls desks "bed", so a "bed" label is second-guessed (desk and table are searched too); a network
    that knows desks and names the instance filling the box a bed confirms it; one that names it anything else
    changes nothing; a box no one instance fills gets no second opinion."""
    ids = np.zeros((100, 100), np.int32)
    ids[30:90, 10:60] = 1
    ids[30:90, 65:95] = 2
    panoptic = Panoptic(ids, [Segment(1, "object", "bed"), Segment(2, "object", "cabinet")])
    seen = SeenObjects.of(panoptic)
    bed_box, cabinet_box = (8.0, 28.0, 62.0, 92.0), (63.0, 28.0, 96.0, 92.0)
    assert seen.label(bed_box, 0.5) == "bed" and seen.label(cabinet_box, 0.5) == "cabinet"
    assert seen.label((0.0, 0.0, 100.0, 100.0), 0.5) is None
    bed = meaning("bed")
    assert bed is not None and alternates(bed) == ("desk", "table")
    assert alternates(bed, seen.label(bed_box, 0.5)) == ()  # confirmed
    assert alternates(bed, seen.label(cabinet_box, 0.5)) == ("desk", "table")
    assert alternates(bed, "desk") == ("desk", "table")  # one of its alternates: still weighed by the shape


def test_a_networks_instance_gives_the_segment_it_fills_its_3d_box() -> None:
    """The 3D box of the instance filling a prompt's box goes to the segment (``layout_eyes``); a box no one
    instance fills, or an instance without a 3D box, gives none."""
    ids = np.zeros((100, 100), np.int32)
    ids[30:90, 10:60] = 1
    ids[30:90, 65:95] = 2
    box_3d = SeenBox((-0.4, 0.3, 2.5), (1.9, 0.6, 1.0), 3.0, 0.4)
    seen = SeenObjects.of(Panoptic(ids, [Segment(1, "object", "bed", seen=box_3d), Segment(2, "object", "cabinet")]))
    assert seen.box_3d((8.0, 28.0, 62.0, 92.0), 0.5) == box_3d
    assert seen.box_3d((63.0, 28.0, 96.0, 92.0), 0.5) is None
    assert seen.box_3d((0.0, 0.0, 100.0, 100.0), 0.5) is None


def test_where_grabcut_finds_nothing_the_networks_instance_is_the_mask(room: dict) -> None:
    """A chair in a row of alike ones: its box's margin holds its own colour, so GrabCut, which takes the margin
    for background, finds nothing there. Dropped on its own; given a network's instance of it, that is its
    mask (what ``segmentation=layout_eyes`` gives discovery)."""
    row = _standing_box(room, 40, 280, height_m=0.9)
    chair = _standing_box(room, 140, 180, height_m=0.9)
    rgb8, surfaces = _painted(room, (row, [0.6, 0.15, 0.2]))
    rows, cols = np.nonzero(chair)
    prompt = Detection("chair", "object", (cols.min() - 1.0, rows.min() - 1.0, cols.max() + 2.0, rows.max() + 2.0), 0.5)
    alone = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT)
    alone.consider([prompt])
    assert alone.kept == [] and "GrabCut found no object" in alone.dropped
    ids = np.zeros(chair.shape, np.int32)
    ids[row] = 2
    ids[chair] = 1  # the network tells this chair from its neighbours
    panoptic = Panoptic(ids, [Segment(1, "object", "chair"), Segment(2, "object", "chair")])
    found = discover(rgb8, room["rays"], surfaces, [prompt], DISCOVERY, None, GRABCUT, seen=SeenObjects.of(panoptic))
    assert [f.detection.label for f in found] == ["chair"]
    assert (found[0].mask & chair).sum() / (found[0].mask | chair).sum() > 0.95


def test_a_box_the_network_sees_as_one_object_is_no_group(room: dict) -> None:
    """A sofa-wide "chair" box holding two weaker chair boxes side by side is taken for a box round two chairs;
    where the network sees one object filling that box, it is one (a chair seen whole, the two boxes its
    pieces or the chairs behind it)."""
    chair = _standing_box(room, 100, 220, height_m=0.9)
    rgb8, surfaces = _painted(room, (chair, [0.2, 0.3, 0.7]))
    rows, cols = np.nonzero(chair)
    top, bottom = float(rows.min()), float(rows.max() + 1)
    whole = Detection("chair", "object", (99.0, top - 1, 221.0, bottom + 1), 0.6)
    halves = [
        Detection("chair", "object", (x0, top + 5, x1, bottom), 0.4) for x0, x1 in ((102.0, 158.0), (162.0, 218.0))
    ]
    alone = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT)
    alone.consider([whole, *halves])
    assert "a box round 2 objects" in alone.dropped
    ids = chair.astype(np.int32)
    seen = SeenObjects.of(Panoptic(ids, [Segment(1, "object", "chair")]))
    helped = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT, seen=seen)
    helped.consider([whole, *halves])
    assert "a box round 2 objects" not in helped.dropped
    assert helped.kept[0].detection == whole


def test_a_weak_box_the_network_sees_as_floor_is_no_object(room: dict) -> None:
    """A sunlit patch of carpet under a weak "bed" box, where a trusted box kept the floor's colour model from
    learning it: the room's colours do not explain it, so on its own it becomes a bed. Where the network sees
    floor there, it is dropped; a trusted box, or a network seeing an object there, keeps it."""
    patch = np.zeros((HEIGHT, WIDTH), bool)
    patch[190:, 200:300] = True
    patch &= room["labels"] == box.FLOOR
    assert patch.sum() > 0.9 * 50 * 100
    rgb = room["rgb"].copy()
    rgb[patch] = [0.97, 0.95, 0.9]
    rgb8 = (rgb * 255).astype(np.uint8)
    surfaces = SurfaceColours(rgb8, room["labels"], unprompted(room["labels"].shape, [(150.0, 150.0, 320.0, 240.0)]))
    prompt = Detection("bed", "object", (198.0, 188.0, 302.0, 240.0), 0.2)
    alone = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT)
    alone.consider([prompt])
    assert [k.detection for k in alone.kept] == [prompt]
    floor = Panoptic(
        np.where(room["labels"] == box.FLOOR, 1, 2).astype(np.int32),
        [Segment(1, "floor", "floor"), Segment(2, "wall", "wall")],
    )
    assert SeenObjects.of(floor).surface_share(patch) == 1.0
    seeing_floor = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT, seen=SeenObjects.of(floor))
    seeing_floor.consider([prompt])
    assert seeing_floor.kept == [] and "weak, and the network sees a room surface there" in seeing_floor.dropped
    trusted = replace(prompt, score=0.5)
    seeing_floor.consider([trusted])
    assert [k.detection for k in seeing_floor.kept] == [trusted]
    ids = floor.ids.copy()
    ids[patch] = 3
    seeing_bed = Panoptic(ids, [*floor.segments, Segment(3, "object", "bed")])
    assert SeenObjects.of(seeing_bed).surface_share(patch) == 0.0
    helped = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT, seen=SeenObjects.of(seeing_bed))
    helped.consider([prompt])
    assert [k.detection for k in helped.kept] == [prompt]


def test_a_chair_the_network_sees_in_front_of_others_is_no_piece_of_a_box_round_them(room: dict) -> None:
    """A weak "chair" box round a near chair and the two chairs behind it (one box for the three) would absorb
    the near chair as a piece of it (as a whole chair absorbs its back, boxed apart). Where the network sees the
    near chair as an instance of its own, standing on the box's floor line, it stays an object; a chair's back
    the network sees apart is still absorbed, as its bottom ends above the whole's floor line."""
    near = _standing_box(room, 100, 220, height_m=0.5)
    behind = [_standing_box(room, x0, x1, height_m=1.1, above_bottom=70) for x0, x1 in ((104, 158), (162, 216))]
    rgb8, surfaces = _painted(room, (behind[0], [0.7, 0.6, 0.2]), (behind[1], [0.7, 0.6, 0.2]), (near, [0.2, 0.3, 0.7]))
    rows, cols = np.nonzero(near)
    near_box = (cols.min() - 1.0, rows.min() - 1.0, cols.max() + 2.0, rows.max() + 2.0)
    top = float(np.nonzero(behind[0] | behind[1])[0].min())
    three = Detection("chair", "object", (98.0, top - 1, 222.0, near_box[3] + 1), 0.3)
    prompts = [Detection("chair", "object", near_box, 0.6), three]
    alone = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT)
    alone.consider(prompts)
    assert "part of a chair" in alone.dropped and [k.detection for k in alone.kept] == [three]
    ids = np.zeros(near.shape, np.int32)
    ids[behind[0]], ids[behind[1]], ids[near] = 2, 3, 1
    segments = [Segment(i, "object", "chair") for i in (1, 2, 3)]
    helped = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT, seen=SeenObjects.of(Panoptic(ids, segments)))
    helped.consider(prompts)
    assert "part of a chair" not in helped.dropped and helped.kept[0].detection == prompts[0]
    back = np.zeros(near.shape, bool)
    back[rows.min() : rows.min() + 20, 100:220] = True  # the network sees only the near chair's back
    back_box = (99.0, rows.min() - 1.0, 221.0, rows.min() + 21.0)
    ids = back.astype(np.int32)
    seen_back = SeenObjects.of(Panoptic(ids, [Segment(1, "object", "chair")]))
    whole = Detection("chair", "object", near_box, 0.3)
    pieces = Selection(rgb8, room["rays"], surfaces, DISCOVERY, GRABCUT, seen=seen_back)
    pieces.consider([Detection("chair", "object", back_box, 0.6), whole])
    assert "part of a chair" in pieces.dropped and [k.detection for k in pieces.kept] == [whole]
