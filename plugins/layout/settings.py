"""Settings of ``segmentation=layout`` and ``depth=layout``: types and ranges (:mod:`psdr_room_core.engine.settings`);
the values and what they mean are in ``conf/segmentation/layout.yaml`` and ``conf/depth/layout.yaml``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from psdr_room_core.engine.settings import setting


@dataclass
class SearchRange:
    wall_min: float = setting(gt=0)
    wall_max: float = setting(gt=0)
    ceiling_min: float = setting(gt=0)
    ceiling_max: float = setting(gt=0)


@dataclass
class LayoutFit:
    """The box-layout fit both implementations run."""

    grid_side: int = setting(ge=16)
    family_tolerance_deg: float = setting(gt=0, le=45)
    sweep_fraction: float = setting(gt=0, le=1)
    floor_band: float = setting(ge=0, le=1)
    floor_prior: float = setting(ge=0)
    floor_colour: float = setting(ge=0)
    n_random: int = setting(ge=1)
    n_starts: int = setting(ge=1)
    min_floor: float = setting(ge=0, le=1)
    look_down_deg: float = setting(ge=0, le=90)
    search: SearchRange = setting()
    seed: int = setting()


@dataclass
class LayoutDepthSettings(LayoutFit):
    camera_height_m: float = setting(gt=0)
    label_weight: float = setting(ge=0)


@dataclass
class GrabCut:
    iterations: int = setting(ge=1)
    margin: float = setting(ge=0)
    min_fill: float = setting(ge=0, le=1)
    min_part: float = setting(ge=0, le=1)


@dataclass
class Discovery:
    min_score: float = setting(ge=0, le=1)
    trusted_score: float = setting(ge=0, le=1)
    max_explained: float = setting(ge=0, le=1)
    nms_iou: float = setting(ge=0, le=1)
    part_overlap: float = setting(ge=0, le=1)
    floor_line: float = setting(ge=0, le=1)
    absorb_score: float = setting(ge=0)
    group_score: float = setting(ge=0)
    max_covered: float = setting(ge=0, le=1)
    min_visible: float = setting(ge=0, le=1)
    parts: dict[str, list[str]] = setting()
    heights: dict[str, list[Any]] = setting()
    size_slack: float = setting(ge=1)
    camera_height_m: float = setting(gt=0)
    max_objects: int = setting(ge=0)


@dataclass
class Proposals:
    score: float = setting(ge=0, le=1)
    open_px: int = setting(ge=0)
    min_area: float = setting(ge=0, le=1)
    max_area: float = setting(ge=0, le=1)
    min_fill: float = setting(ge=0, le=1)
    max_proposals: int = setting(ge=0)


@dataclass
class LayoutSegmentationSettings(LayoutFit):
    clutter_weight: float = setting(ge=0)
    box_score: float = setting(ge=0, le=1)
    min_surface_fraction: float = setting(ge=0, le=1)
    grabcut: GrabCut = setting()
    discovery: Discovery = setting()
    proposals: Proposals | None = setting()
