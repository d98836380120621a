"""Settings of ``segmentation=layout`` and ``depth=layout``, each declared once: the type, range and meaning of every
key (:mod:`psdr_room_core.engine.settings`), and the objects the implementations keep and hand to the functions that
use them. The values are in ``conf/segmentation/layout.yaml`` and ``conf/depth/layout.yaml``. Light on purpose:
loading the plugin imports this module, not the fit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psdr_room_core.engine.settings import setting
from psdr_room_core.libraries.vanishing_points import VanishingPointParams


@dataclass
class SearchRange:
    """Where box hypotheses are sampled, in camera heights (``search`` in the layout settings)."""

    wall_min: float = setting(gt=0, doc="Nearest a wall is sampled, camera heights.")
    wall_max: float = setting(gt=0, doc="Farthest a wall is sampled, camera heights.")
    ceiling_min: float = setting(gt=0, doc="Lowest the ceiling is sampled above the camera, camera heights.")
    ceiling_max: float = setting(gt=0, doc="Highest the ceiling is sampled above the camera, camera heights.")

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the log-parameters (log |x0|, log x1, log ceiling, log |z0|, log z1)."""
        w = (np.log(self.wall_min), np.log(self.wall_max))
        c = (np.log(self.ceiling_min), np.log(self.ceiling_max))
        lo, hi = zip(w, w, c, w, w)
        return np.array(lo), np.array(hi)


@dataclass
class LayoutParams:
    """Knobs of the box-layout fit (shared by ``segmentation=layout`` and ``depth=layout``)."""

    grid_side: int = setting(ge=16, doc="Hypotheses are scored on a grid with this long side, pixels.")
    family_tolerance_deg: float = setting(
        gt=0, le=45, doc="A line segment belongs to a vanishing point when it points at it within this angle, degrees."
    )
    sweep_fraction: float = setting(
        gt=0,
        le=1,
        doc="Orientation-map sweeps: segments are swept this fraction of the image diagonal towards and away from "
        "the other vanishing points.",
    )
    clutter_weight: float = setting(
        ge=0,
        doc="Weight of line evidence inside object boxes (furniture lines say little about the room) ...",
    )
    box_score: float = setting(
        ge=0,
        le=1,
        doc="... of the boxes scoring at least this (their bottoms are also floor evidence).",
    )
    label_weight: float = setting(
        ge=0,
        doc="Weight of agreement with given wall, floor and ceiling labels (the segmentation's for depth=layout, a "
        "network's for segmentation=layout_eyes) against 1 for line evidence.",
    )
    floor_band: float = setting(
        ge=0, le=1, doc="Bottom rows (this fraction of the height) below the horizon are likely floor ..."
    )
    floor_prior: float = setting(
        ge=0,
        doc="... with this orientation evidence per pixel; object box bottoms (objects stand on the floor) too ...",
    )
    floor_colour: float = setting(
        ge=0,
        doc="... and so do pixels below the horizon joined to that band by colours within this CIELAB distance of its "
        "median (lightness counted half): the floor running up to the far wall (a corridor's carpet has no lines). "
        "0: off.",
    )
    n_random: int = setting(ge=1, doc="Random box hypotheses scored before the local search ...")
    n_starts: int = setting(ge=1, doc="... then a pattern search from the best this many.")
    min_floor: float = setting(
        ge=0,
        le=1,
        doc="A fitted box showing less floor than this share of the photo is also fitted looking down ...",
    )
    look_down_deg: float = setting(
        ge=0,
        le=90,
        doc="... at a floor, when a room axis points at least this far (degrees) below the optical axis (90: never).",
    )
    search: SearchRange = setting(doc="Where hypotheses are sampled.")
    seed: int = setting(doc="Seed of the random hypotheses.")
    lines: VanishingPointParams = setting(
        doc="The photo's line segments, and its vanishing points where fov gave none (as fov=vanishing_points "
        "finds them)."
    )


@dataclass
class GrabCutParams:
    """Knobs of the box-prompted GrabCut (``segmentation.layout.grabcut``)."""

    iterations: int = setting(ge=1, doc="GrabCut iterations.")
    margin: float = setting(
        ge=0, doc="Context around each box (a fraction of its size) given to GrabCut as known background."
    )
    min_fill: float = setting(
        ge=0, le=1, doc="Masks covering less than this fraction of their box are dropped (GrabCut found no object)."
    )
    min_part: float = setting(
        ge=0,
        le=1,
        doc="Pieces of the mask at least this share of the largest are kept with it (a chair's back and seat, joined "
        "outside the mask by thin pieces); smaller ones are noise.",
    )


@dataclass
class DiscoveryParams:
    """Which prompts become objects: knobs of :func:`discover` (``segmentation.layout.discovery``)."""

    min_score: float = setting(ge=0, le=1, doc="Prompts scoring less are ignored.")
    trusted_score: float = setting(
        ge=0, le=1, doc="Prompts scoring less are weak: the room must not explain their mask ..."
    )
    max_explained: float = setting(
        ge=0,
        le=1,
        doc="... more than this share of it (:mod:`psdr_room_core.method.surface_colours`): a weak prompt on what "
        "looks like the floor is floor ...",
    )
    max_seen_surface: float = setting(
        ge=0,
        le=1,
        doc="... nor may the network (segmentation=layout_eyes) see a room surface in more than this share of it (a "
        "weak box on a sunlit patch of carpet whose colours the room does not explain).",
    )
    nms_iou: float = setting(
        ge=0, le=1, doc="Boxes overlapping more are one object (the better prompt kept), whatever their labels."
    )
    part_overlap: float = setting(
        ge=0, le=1, doc="A prompt with this share of its box inside a better prompt's box may be its part (parts) ..."
    )
    floor_line: float = setting(
        ge=0,
        le=1,
        doc="... or a second box on it: same category, bottoms this close (share of the better box's height).",
    )
    absorb_score: float = setting(
        ge=0,
        doc="A prompt takes a better-scoring kept object of its category or its parts inside its box as a piece of "
        "itself when it scores at least this share of it.",
    )
    group_score: float = setting(
        ge=0,
        doc="Prompts of a box's category scoring at least this share of it, two or more side by side inside it (not "
        "stacked in the same columns), make it a box round a group: dropped.",
    )
    max_covered: float = setting(
        ge=0,
        le=1,
        doc="A prompt whose box holds two or more kept objects, their masks covering more than this share of it, is a "
        "box round a group of them: dropped.",
    )
    min_visible: float = setting(
        ge=0, le=1, doc="An object showing less than this share of its mask once nearer objects are painted is dropped."
    )
    seen_iou: float = setting(
        ge=0,
        le=1,
        doc="A network's instance whose box overlaps a prompt's by this IoU or more is the one object there: its mask "
        "where GrabCut finds nothing, and the box is no box round a group (segmentation=layout_eyes only).",
    )
    leg_rarity: float = setting(
        ge=0,
        le=1,
        doc="Below a cut that stops above its box's bottom, pixels whose colour is rarer on their surface than on this "
        "share of its pixels, and that join the cut, are its thin legs (:func:`~.discovery.with_legs`).",
    )
    parts: dict[str, list[str]] = setting(
        doc="Database category → the categories a detector calls parts of it (a sofa's seat is a chair)."
    )
    heights: dict[str, list[float]] = setting(
        doc="Database category (object: unknown) → [lowest, highest] top height above the floor, metres ..."
    )
    size_slack: float = setting(
        ge=1,
        doc="... widened by this factor both ways (the camera height is assumed, the layout approximate).",
    )
    camera_height_m: float = setting(gt=0, doc="The camera height (metres) the size check assumes.")
    max_objects: int = setting(ge=0, doc="At most this many objects are kept (best prompts first).")


@dataclass
class ProposalParams:
    """Class-agnostic prompts round what the room's colours leave unexplained: knobs of :func:`clutter_proposals`
    (``segmentation.layout.proposals``)."""

    score: float = setting(
        ge=0, le=1, doc="The score a proposal carries: weak (below discovery.trusted_score), so every check applies."
    )
    open_px: int = setting(ge=0, doc="Side (pixels) of the square opening that cleans the unexplained pixels.")
    min_area: float = setting(ge=0, le=1, doc="Regions covering less of the photo are not proposed ...")
    max_area: float = setting(ge=0, le=1, doc="... nor those covering more (a surface the colour model missed).")
    min_fill: float = setting(
        ge=0, le=1, doc="Regions filling less of their box are not compact enough to be one object."
    )
    max_proposals: int = setting(ge=0, doc="The largest this many regions are proposed.")


@dataclass
class LayoutDepthSettings(LayoutParams):
    """``depth=layout``: the fit, and the camera height that turns its camera-height units into metres."""

    camera_height_m: float = setting(
        gt=0, doc="The camera is assumed this high (metres) above the floor (the room stage only needs the shape)."
    )
    relative_extent: float = setting(
        ge=0,
        doc="With a network's relative depth (depth=layout_eyes): how far behind its contact plane, times its width, "
        "an object on the floor may reach as that depth shapes it (0: the plane) ...",
    )
    relative_min_width: float = setting(
        ge=0,
        le=1,
        doc="... if at least this share of the photo wide (of a narrower one the network, 80 cells across, sees mostly "
        "the blur of its edges).",
    )


@dataclass
class LayoutSegmentationSettings(LayoutParams):
    """``segmentation=layout``: the fit, and how objects are found on it."""

    min_surface_fraction: float = setting(
        ge=0, le=1, doc="Visible room surfaces smaller than this fraction of the image are dropped."
    )
    grabcut: GrabCutParams = setting(doc="The box-prompted GrabCut that cuts each object out.")
    discovery: DiscoveryParams = setting(doc="Which prompts become objects (plugins/layout/discovery.py).")
    proposals: ProposalParams | None = setting(
        doc="Class-agnostic prompts round what the room's colours leave unexplained (plugins/layout/proposals.py); "
        "null: none."
    )
