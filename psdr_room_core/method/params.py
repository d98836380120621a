"""The settings schemas of the method's algorithms that several stages' settings nest (their values in
``conf/``): apart from the algorithms, so that a stage's settings, and its code fingerprint, do not take in the
code of every algorithm another stage's settings name."""

from __future__ import annotations

from dataclasses import dataclass

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.settings import setting


@dataclass
class GroupParams:
    """Knobs of :func:`group_segments`: the ``group_objects`` settings."""

    splittable: list[str] = setting(
        doc="Categories a segmentation cuts into parts, one resting on the other (a bed's headboard and mattress) ..."
    )
    parts: dict[str, list[str]] = setting(
        doc="... or whose parts it names otherwise: category → the categories of its parts (a sofa's seat: chair)."
    )
    edge_px: float = setting(
        ge=0, doc="A part rests on another whose mask is this close (working-image pixels) below its lowest pixels ..."
    )
    rests_share: float = setting(ge=0, le=1, doc="... along this share of its lowest pixels' columns ...")
    slack: float = setting(ge=1, doc="... and together they are no bigger than their category's largest size × this.")
    same_space: float = setting(
        gt=0,
        le=1,
        doc="Or: their floor footprints (each grown by margin) overlap this share of the smaller: the same space.",
    )
    margin: float = setting(ge=0, doc="Metres each footprint is grown by for same_space.")
    keep_score: float = setting(
        ge=0,
        doc="Merged only where one model of the whole scores this share of the better part's score alone.",
    )


@dataclass
class SupportParams:
    """Thresholds of §4.3's support rules: the ``support`` settings of place_objects."""

    floor_distance: float = setting(
        ge=0, doc="An object whose points' bottom is this close to the floor (room units) ..."
    )
    edge_px: float = setting(
        ge=0,
        doc="... and whose mask is this close (working-image pixels) to the floor mask stands on the floor; a floating "
        "object whose mask is this close to a floor object's mask (and above it), whose bottom is no lower than that "
        "object's top less floor_distance and whose points' centre is over that object's points, stands on it.",
    )
    wall_distance: float = setting(
        ge=0,
        doc="A floating object without a parent whose points lie this close (room units) to a wall is mounted on it.",
    )
    bottom_percentile: float = setting(
        ge=0, le=100, doc="The points' bottom is this percentile of their heights (robust to stray points)."
    )
    grounded: list[str] = setting(
        doc="Categories that stand on the floor when no parent holds them and their points' bottom is below the "
        "room's mid-height (it is hidden behind something); higher up they may hang on a wall."
    )
    floor_only: list[str] = setting(
        doc="Categories that never hang on a wall or float: on a parent, else on the floor."
    )


@dataclass
class PhysicalParams:
    """Knobs of :func:`settle`: the ``physical`` settings of place_objects and fit_objects."""

    size_tolerance: float = setting(
        ge=0,
        doc="Outside its category's sizes by more than this (log units: 0.15 is about 16%) a model is implausible and "
        "a guessed one dropped; by less, it is scaled in.",
    )
    duplicate_share: float = setting(
        gt=0, le=1, doc="Two objects sharing this share of the smaller one's volume are one thing found twice."
    )
    penetration: float = setting(
        ge=0,
        doc="Interpenetration allowed, metres (a resting contact measures about one voxel); more: the weaker object "
        "moves out ...",
    )
    max_shift: float = setting(
        ge=0,
        doc="... by at most this horizontal step (metres); farther, it is dropped (place_objects leaves the pair to "
        "fit_objects instead).",
    )
    directions: int = setting(ge=1, doc="Horizontal directions tried for a move.")
    keep_iou: float = setting(
        ge=0,
        le=1,
        doc="A move or scaling must keep this IoU of the object's seen silhouette with its silhouette before.",
    )
    max_growth: float = setting(
        ge=0,
        doc="fit_objects grows the room box by at most this (metres) beyond each side to hold an object; farther "
        "out, a guessed object is dropped.",
    )
    hidden_share: float = setting(
        ge=0,
        le=1,
        doc="An object showing less than this share of the pixels of its segment it covers alone is hidden: a blob "
        "of no named kind in front of it moves back behind it, else is dropped.",
    )
    seen_order: float = setting(
        ge=0,
        doc="A named object hiding another moves back behind it where the segmenting network's 3D boxes put the "
        "hidden one nearer by at least this share of its depth (0: never).",
    )
    weak_score: float = setting(
        ge=0,
        le=1,
        doc="A guessed object whose prompt scored below this is a weak guess and yields to any surer object "
        "(as segmentation.layout.discovery.trusted_score).",
    )


@dataclass
class SearchParams:
    """How hard :func:`fit_view` looks and what its error holds: the ``search`` settings of place_objects and of
    ``retrieval=silhouette``."""

    n_yaw: int = setting(ge=1, doc="Rotations about the vertical axis swept (init=radius too).")
    refine: int = setting(
        ge=0, doc="Moment-matching steps per rotation (area, 3D median across the view, depth where they overlap)."
    )
    coarse: int = setting(
        ge=0, doc="Pattern-search step levels (shift, depth, scale, yaw) every explored rotation gets (0: none)."
    )
    explore: int = setting(ge=0, doc="Rotations (the best after moment matching) that get the coarse search (0: all).")
    rounds: int = setting(ge=1, doc="Most pattern-search moves at one step size.")
    polish: int = setting(ge=0, doc="The best rotations then refined at finer steps ...")
    halvings: int = setting(ge=0, doc="... this many levels, each step half the last.")
    turns: list[float] = setting(
        doc="The polished best turned in place by each of these (degrees: front/back, sides) and refined at the fine "
        "levels (with polish > 0)."
    )
    depth_weight: float = setting(ge=0, doc="Weight of the mean relative depth error against the mask disagreement.")
    box_weight: float = setting(
        ge=0,
        doc="Weight of 1 - IoU of the visible model's box with a prompted segment's box (a detector's box spans the "
        "thin legs a box-prompted cut loses).",
    )
    hidden_margin: float = setting(
        ge=0, doc="A model pixel is hidden where the photo sees a surface this much (relative) nearer."
    )
    room_weight: float = setting(
        ge=0, doc="Error per metre the posed model's bounding box reaches beyond the room box (it stands inside)."
    )
    back_weight: float = setting(
        ge=0,
        doc="Error of a bed, cabinet, shelf or fridge posed with its back square on to the camera (they stand with their "
        "backs to a wall: psdr_room_core/method/backs.py).",
    )
    wall_weight: float = setting(
        ge=0,
        doc="Error per metre the wall behind such a model is farther than the wall nearest it (with the target's room "
        "box).",
    )
    seen_depth_weight: float = setting(
        ge=0,
        doc="Error per unit |log| of the ratio of the posed model's centre depth to the segmenting network's 3D box's "
        "(at the scene's scale), for an object the network boxed (segmentation=eyes or layout_eyes).",
    )
    seen_yaw_weight: float = setting(
        ge=0,
        doc="Error of a pose turned half round from the network's 3D box, times the network's confidence in its yaw "
        "((1 - cos) / 2 of the difference).",
    )


@dataclass
class PaintPrior:
    """The range of a painted room surface's fitted material (the sources are in :mod:`psdr_room_core.method.material_priors`)."""

    albedo: list[float] = setting(
        ge=0,
        le=1,
        length=2,
        doc="[lowest, highest] luminance of a homogeneous wall's or ceiling's linear base colour (real paints' light "
        "reflectance values; no channel above the highest); a procedural one's mean map luminance is pulled into it "
        "by the loss term weights.paint.",
    )
    max_specular: float = setting(
        gt=0,
        le=1,
        doc="Highest principled specular of any wall or ceiling (0.5: 4% reflectance at normal incidence, matte paint).",
    )
    hue_range: float = setting(
        ge=1,
        doc="Each channel of a homogeneous wall's or ceiling's chromaticity stays within this factor of the photo's.",
    )

    def __post_init__(self) -> None:
        low, high = self.albedo
        if not low < high:
            raise PsdrRoomError(
                f"fit_appearance.paint.albedo={list(self.albedo)}: the lowest must be below the highest"
            )


@dataclass
class SizePriorWeights:
    """The size prior on a pose at scale ``s`` (:class:`~psdr_room_core.method.sizes.SizePrior`; database models
    are real size): ``scale_weight |ln s| + range_weight ×`` how far (log units) it is outside its category's
    sizes."""

    scale_weight: float = setting(
        ge=0, doc="Cost per log unit of scale (|ln s|): higher keeps models nearer real size."
    )
    range_weight: float = setting(ge=0, doc="Cost per log unit the scaled model is outside its category's real sizes.")


@dataclass
class Priors:
    """The settings several stages share (the ``priors`` node of ``conf/config.yaml``; the stages' nodes take them by
    interpolation, so one value serves them all and a stage can be removed or swapped without the others)."""

    size: SizePriorWeights = setting(
        doc="The size prior of the view search: place_objects' poses and retrieval=silhouette's ranking."
    )
    physical: PhysicalParams = setting(
        doc="What makes a scene physically possible (psdr_room_core/method/physical.py): place_objects and fit_objects."
    )
