"""The built-in stages' settings: types and ranges (:mod:`psdr_room_core.engine.settings`). The values, with what
each one means, are in ``conf/stage/<stage>.yaml``; ``room_init``'s schema is
:class:`~psdr_room_core.method.room_box.RoomInitParams`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from psdr_room_core.engine.settings import setting

from ..convergence import Plateau
from ..grouping import GroupParams
from ..material_priors import PaintPrior
from ..objects import SupportParams
from ..physical import PhysicalParams
from ..view_search import SearchParams


@dataclass
class LoadImage:
    max_side: int = setting(ge=64)
    max_pixels: int = setting(ge=1)


@dataclass
class PointCloud:
    erode_px: int = setting(ge=0)
    max_points_per_segment: int = setting(ge=1)
    outlier_neighbours: int = setting(ge=1)
    outlier_std_ratio: float = setting(gt=0)


@dataclass
class RoomFitRates:
    yaw: float = setting(ge=0)
    translation: float = setting(ge=0)
    log_scale: float = setting(ge=0)
    tilt: float = setting(ge=0)
    log_focal: float = setting(ge=0)


@dataclass
class RoomFit:
    iterations: int = setting(ge=1)
    render_width: int = setting(ge=16)
    depth_weight: float = setting(ge=0)
    keep_floor: bool = setting()
    learning_rates: RoomFitRates = setting()


@dataclass
class GroupObjects(GroupParams):
    enabled: bool = setting(True)


@dataclass
class RetrieveObjects:
    top_k: int = setting(ge=1)
    alternate_margin: float = setting(ge=0)
    min_points: int = setting(ge=0)
    min_pixels: int = setting(ge=0)


@dataclass
class Prune:
    min_iou: float = setting(ge=0, le=1)


@dataclass
class SizePriorWeights:
    scale_weight: float = setting(ge=0)
    range_weight: float = setting(ge=0)


@dataclass
class PlaceObjects:
    pick: Any = setting()
    init: str = setting(choices=("silhouette", "radius"))
    radius_factor: float = setting(gt=0)
    render_width: int = setting(ge=16)
    search: SearchParams = setting()
    size_prior: SizePriorWeights = setting()
    prune: Prune = setting()
    physical: PhysicalParams = setting()
    min_points: int = setting(ge=0)
    min_pixels: int = setting(ge=0)
    support: SupportParams = setting()


@dataclass
class YawTest:
    at: float = setting(ge=0, le=1)
    angles: list[float] = setting()
    min_gain: float = setting(ge=0)


@dataclass
class FitObjectsRates:
    translation: float = setting(ge=0)
    log_scale: float = setting(ge=0)
    yaw: float = setting(ge=0)


@dataclass
class FitObjects:
    iterations: int = setting(ge=1)
    convergence: Plateau = setting()
    render_width: int = setting(ge=16)
    blur_sigmas: list[float] = setting(gt=0)
    blur_weight: float = setting(ge=0)
    size_prior: SizePriorWeights = setting()
    room_weight: float = setting(ge=0)
    collision_weight: float = setting(ge=0)
    back_weight: float = setting(ge=0)
    wall_weight: float = setting(ge=0)
    yaw_test: YawTest = setting()
    keep_share: float = setting(ge=0, le=1)
    same_box: float = setting(ge=0, le=1)
    learning_rates: FitObjectsRates = setting()
    physical: PhysicalParams = setting()


@dataclass
class CleanPixels:
    coverage: float = setting(gt=0, le=1)
    edge_ratio: float = setting(gt=0)
    edge_floor: float = setting(ge=0)
    open_px: int = setting(ge=0)


@dataclass
class RoomColours:
    floor: list[float] = setting(ge=0, le=1, length=3)
    ceiling: list[float] = setting(ge=0, le=1, length=3)
    wall: list[float] = setting(ge=0, le=1, length=3)


@dataclass
class RoomCategories:
    floor: list[str] = setting()
    ceiling: list[str] = setting()
    wall: list[str] = setting()


@dataclass
class AssignMaterials:
    render_width: int = setting(ge=16)
    erode_px: int = setting(ge=0)
    clean: CleanPixels = setting()
    flat_energy: float = setting(ge=0)
    max_crops: int = setting(ge=0)
    min_crop_px: int = setting(ge=1)
    top_k: int = setting(ge=1)
    min_similarity: float = setting(le=1)
    scales: list[float] = setting(gt=0)
    rotations: list[float] = setting()
    map_size: int = setting(ge=8)
    roughness: float = setting(ge=0, le=1)
    clear_height: float = setting(ge=0)
    room_colours: RoomColours = setting()
    room_categories: RoomCategories = setting()


@dataclass
class Sweep:
    min: float = setting(gt=0)
    max: float = setting(gt=0)
    count: int = setting(ge=1)


@dataclass
class InitLights:
    ceiling_grid: list[int] = setting(ge=1, length=2)
    cell_ratio: float = setting(gt=0, le=1)
    behind_ratio: float = setting(gt=0, le=1)
    window_ratio: float = setting(gt=0, le=1)
    hidden_wall_px: int = setting(ge=0)
    frame_width: float = setting(ge=0)
    drop: float = setting(ge=0)
    render_width: int = setting(ge=16)
    spp: int = setting(ge=1)
    downsample: int = setting(ge=1)
    sweep: Sweep = setting()
    max_balance: float = setting(ge=1)


@dataclass
class AppearanceWeights:
    image: float = setting(ge=0)
    colour: float = setting(ge=0)
    texture: float = setting(ge=0)
    paint: float = setting(ge=0)


@dataclass
class AppearanceRates:
    graph: float = setting(ge=0)
    base_color: float = setting(ge=0)
    roughness: float = setting(ge=0)
    specular: float = setting(ge=0)
    radiance: float = setting(ge=0)
    light_colour: float = setting(ge=0)


@dataclass
class FitAppearance:
    iterations: int = setting(ge=1)
    convergence: Plateau = setting()
    render_width: int = setting(ge=16)
    spp: int = setting(ge=1)
    grad_spp: int = setting(ge=1)
    final_spp: int = setting(ge=1)
    map_size: int = setting(ge=8)
    downsample: int = setting(ge=1)
    min_region_px: int = setting(ge=0)
    weights: AppearanceWeights = setting()
    learning_rates: AppearanceRates = setting()
    crops_per_part: int = setting(ge=0)
    max_crop_aspect: float = setting(ge=1)
    radiance_range: float = setting(ge=1)
    colour_range: float = setting(ge=1)
    plain_check: bool = setting()
    paint: PaintPrior = setting()


@dataclass
class ExportScene:
    spp: int = setting(ge=1)
    max_depth: int = setting(ge=1)
    texture_size: int = setting(ge=8)
    glb: bool = setting()
    usd: bool = setting()
