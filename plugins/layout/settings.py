"""Settings of ``segmentation=layout`` and ``depth=layout``, each declared once: the type, range and default of
every knob (:mod:`psdr_room_core.engine.settings`), and the objects the implementations keep and hand to the
functions that use them. The values and what they mean are in ``conf/segmentation/layout.yaml`` and
``conf/depth/layout.yaml``. Light on purpose: loading the plugin imports this module, not the fit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psdr_room_core.engine.settings import setting


@dataclass
class SearchRange:
    """Where hypotheses are sampled, in camera heights (``search`` in the layout settings)."""

    wall_min: float = setting(0.5, gt=0)
    wall_max: float = setting(12.0, gt=0)
    ceiling_min: float = setting(0.15, gt=0)
    ceiling_max: float = setting(3.0, gt=0)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the log-parameters (log |x0|, log x1, log ceiling, log |z0|, log z1)."""
        w = (np.log(self.wall_min), np.log(self.wall_max))
        c = (np.log(self.ceiling_min), np.log(self.ceiling_max))
        lo, hi = zip(w, w, c, w, w)
        return np.array(lo), np.array(hi)


@dataclass
class LayoutParams:
    """Knobs of the box-layout fit (shared by ``segmentation=layout`` and ``depth=layout``)."""

    grid_side: int = setting(160, ge=16)
    """Hypotheses are scored on a grid with this long side."""
    family_tolerance_deg: float = setting(4.0, gt=0, le=45)
    """A segment belongs to a vanishing point when it points at it within this angle."""
    sweep_fraction: float = setting(0.12, gt=0, le=1)
    """Segments are swept this fraction of the image diagonal towards/away from the other vanishing points."""
    clutter_weight: float = setting(0.25, ge=0)
    """Weight of orientation evidence inside object boxes (furniture lines say little about the room)."""
    box_score: float = setting(0.3, ge=0, le=1)
    """Object boxes scoring at least this inform the fit (clutter weights, floor prior at their bottoms)."""
    label_weight: float = setting(1.0, ge=0)
    """Weight of agreement with given wall/floor/ceiling labels: the segmentation's (depth=layout), or a
    network's (segmentation=layout_eyes)."""
    floor_band: float = setting(0.08, ge=0, le=1)
    """Rows at the bottom of the photo (this fraction of its height) below the horizon that are likely floor ..."""
    floor_prior: float = setting(0.5, ge=0)
    """... with this orientation evidence per pixel; box bottoms (objects stand on the floor) get it too."""
    floor_colour: float = setting(14.0, ge=0)
    """Pixels below the horizon joined to that bottom band by colours within this CIELAB distance of the band's
    median (lightness counted half) get the floor prior too: the floor's material running up to the far wall
    (a corridor's carpet has no lines to say so). 0: off."""
    n_random: int = setting(3000, ge=1)
    """Random hypotheses scored before the local search."""
    n_starts: int = setting(8, ge=1)
    """Best random hypotheses refined by pattern search."""
    min_floor: float = setting(0.02, ge=0, le=1)
    """A fitted box showing less floor than this fraction of the photo is fitted again looking down ..."""
    look_down_deg: float = setting(30.0, ge=0, le=90)
    """... when an axis points at least this far below the optical axis (90: never)."""
    search: SearchRange = setting(SearchRange())
    """Where hypotheses are sampled."""
    seed: int = setting(0)


@dataclass
class GrabCutParams:
    """Knobs of the box-prompted GrabCut (``segmentation.layout.grabcut`` in the config)."""

    iterations: int = setting(5, ge=1)
    margin: float = setting(0.15, ge=0)
    """Context around the box (fraction of its size) given to GrabCut as known background."""
    min_fill: float = setting(0.08, ge=0, le=1)
    """Masks covering less than this fraction of their box are dropped (GrabCut found no object)."""
    min_part: float = setting(0.2, ge=0, le=1)
    """Connected pieces of the mask at least this share of the largest are kept with it (an object's parts
    that its thin pieces join outside the mask, as a chair's back and seat); smaller ones are noise."""


@dataclass
class DiscoveryParams:
    """Knobs of :func:`discover` (``segmentation.layout.discovery`` in the config)."""

    min_score: float = setting(0.15, ge=0, le=1)
    """Prompts scoring less are ignored."""
    trusted_score: float = setting(0.3, ge=0, le=1)
    """Prompts scoring less are weak: the room must not explain their mask ..."""
    max_explained: float = setting(0.6, ge=0, le=1)
    """... more than this share of it (:mod:`psdr_room_core.method.surface_colours`): a weak prompt on what looks like the floor is floor."""
    max_seen_surface: float = setting(0.75, ge=0, le=1)
    """Nor may the network (``segmentation=layout_eyes``) see more than this share of a weak prompt's mask as
    wall, floor or ceiling: a weak box on a sunlit patch of carpet whose colours the room does not explain."""
    nms_iou: float = setting(0.6, ge=0, le=1)
    """Boxes overlapping more than this are one object (the better prompt is kept), whatever their labels."""
    part_overlap: float = setting(0.85, ge=0, le=1)
    """A prompt with this share of its box inside a better prompt's box may be a part of it (``parts``)."""
    floor_line: float = setting(0.05, ge=0, le=1)
    """... or a second box on it: same category, bottoms this close (share of the better box's height)."""
    absorb_score: float = setting(0.3, ge=0)
    """A prompt takes a better-scoring kept object of its category or its ``parts`` inside its box as a piece of
    itself when it scores at least this share of it."""
    group_score: float = setting(0.5, ge=0)
    """Prompts of a box's category scoring at least this share of it that lie inside it, two or more of them
    side by side (not stacked in the same columns), make it a box round a group: dropped."""
    max_covered: float = setting(0.5, ge=0, le=1)
    """A prompt whose box holds two or more kept objects, their masks covering more than this share of it, is
    a box round a group of them: dropped."""
    min_visible: float = setting(0.2, ge=0, le=1)
    """An object showing less than this share of its mask once nearer objects are painted is dropped."""
    seen_iou: float = setting(0.5, ge=0, le=1)
    """A network's instance whose box overlaps a prompt's by this IoU or more is the one object there: its mask
    where GrabCut finds nothing, and the box is no box round a group; only where a network is given
    (``segmentation=layout_eyes``)."""
    leg_rarity: float = setting(0.05, ge=0, le=1)
    """Below a cut that stops above its box's bottom, pixels whose colour is rarer on their surface than on this
    share of its own pixels, and that join the cut, are its thin legs (:func:`~.discovery.with_legs`)."""
    parts: dict[str, list[str]] = setting(
        {
            "sofa": ["chair", "pillow", "ottoman"],
            "bed": ["pillow", "sofa", "chair", "table"],
            "shelf": ["tv", "box", "frame"],
            "cabinet": ["tv", "appliance", "refrigerator", "box", "frame"],
        }
    )
    """Database category → categories a detector calls parts of it (a sofa's seat is a "chair")."""
    heights: dict[str, list[float]] = setting(
        {
            "chair": [0.45, 1.3],
            "sofa": [0.5, 1.2],
            "ottoman": [0.25, 0.6],
            "bed": [0.3, 1.7],
            "table": [0.35, 1.15],
            "desk": [0.6, 1.5],
            "cabinet": [0.3, 2.6],
            "shelf": [0.5, 2.6],
            "refrigerator": [0.7, 2.1],
            "appliance": [0.2, 1.3],
            "tv": [0.25, 1.8],
            "lamp": [0.25, 2.1],
            "plant": [0.2, 2.6],
            "box": [0.08, 1.2],
            "pillow": [0.2, 0.7],
            "object": [0.1, 2.8],
        }
    )
    """Database category (``object``: unknown) → (lowest, highest) top height above the floor, metres."""
    size_slack: float = setting(1.8, ge=1)
    """Height ranges are widened by this factor both ways (the camera height is assumed, the layout approximate)."""
    camera_height_m: float = setting(1.5, gt=0)
    max_objects: int = setting(40, ge=0)
    """At most this many objects are kept (best prompts first)."""


@dataclass
class ProposalParams:
    """Knobs of :func:`clutter_proposals` (``segmentation.layout.proposals`` in the config)."""

    score: float = setting(0.2, ge=0, le=1)
    """The score a proposal carries: weak (below ``discovery.trusted_score``), so every check applies."""
    open_px: int = setting(7, ge=0)
    """Side of the square opening that cleans the unexplained pixels."""
    min_area: float = setting(0.004, ge=0, le=1)
    """Regions covering less than this share of the photo are not proposed ..."""
    max_area: float = setting(0.3, ge=0, le=1)
    """... nor those covering more (a surface the colour model missed)."""
    min_fill: float = setting(0.3, ge=0, le=1)
    """Regions filling less than this share of their box are not compact enough to be one object."""
    max_proposals: int = setting(8, ge=0)
    """The largest this many regions are proposed."""


@dataclass
class LayoutDepthSettings(LayoutParams):
    """``depth=layout``: the fit, and the camera height that turns its camera-height units into metres."""

    camera_height_m: float = setting(1.5, gt=0)
    relative_extent: float = setting(0.5, ge=0)
    """Where a network's relative depth is given (``depth=layout_eyes``): how far behind its contact plane
    (times its width there) an object standing on the floor may reach as that depth shapes it; 0: the plane."""
    relative_min_width: float = setting(0.1, ge=0, le=1)
    """The narrowest object (share of the photo's width) that depth shapes: of a narrower one, the network (80
    cells across) sees mostly the blur of its edges."""


@dataclass
class LayoutSegmentationSettings(LayoutParams):
    """``segmentation=layout``: the fit, and how objects are found on it."""

    min_surface_fraction: float = setting(0.002, ge=0, le=1)
    grabcut: GrabCutParams = setting(GrabCutParams())
    discovery: DiscoveryParams = setting(DiscoveryParams())
    proposals: ProposalParams | None = setting(None)
    """Class-agnostic proposals round what the room cannot explain; None: none."""
