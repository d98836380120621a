"""The built-in stages' settings: the type, range and meaning of every key (:mod:`psdr_room_core.engine.settings`).
The values are in ``conf/stage/<stage>.yaml``; ``room_init``'s schema is
:class:`~psdr_room_core.method.room_box.RoomInitParams`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from psdr_room_core.engine.settings import setting

from ..convergence import Plateau
from ..params import GroupParams, PaintPrior, PhysicalParams, SearchParams, SizePriorWeights, SupportParams


@dataclass
class LoadImage:
    """``load_image``: the photo at the working resolution."""

    max_side: int = setting(
        ge=64, doc="Long side of the working image, pixels; a larger photo is downscaled (lower: every stage faster)."
    )
    max_pixels: int = setting(ge=1, doc="Photos with more pixels than this are refused.")


@dataclass
class PointCloud:
    """``point_cloud``: the segmented point cloud (camera frame) from depth, camera and segmentation."""

    erode_px: int = setting(
        ge=0,
        doc="Erosion (pixels) of the wall, floor and ceiling masks before back-projection (they bleed into objects).",
    )
    max_points_per_segment: int = setting(ge=1, doc="Each segment keeps at most this many points (a fixed stride).")
    outlier_neighbours: int = setting(ge=1, doc="Statistical outlier removal per segment: neighbours compared.")
    outlier_std_ratio: float = setting(
        gt=0, doc="... a point this many standard deviations farther than its neighbours is dropped (lower: more)."
    )


@dataclass
class RoomFitRates:
    """``room_fit``'s learning rates, per parameter."""

    yaw: float = setting(ge=0, doc="Radians.")
    translation: float = setting(ge=0, doc="In units of the box's mean half-size.")
    log_scale: float = setting(ge=0, doc="Per axis.")
    tilt: float = setting(ge=0, doc="Radians: corrects room_init's floor normal (a rotation about the camera centre).")
    log_focal: float = setting(
        ge=0, doc="Above 0 also refines the focal length (0: keep estimate_fov's, as the paper)."
    )


@dataclass
class RoomFit:
    """``room_fit`` (§4.2, eq. 2): -Σ IoU(wall, floor, ceiling) + depth L1, by differentiable rendering."""

    iterations: int = setting(ge=1, doc="Optimisation steps.")
    render_width: int = setting(
        ge=16, doc="Masks and depth are rendered (and the targets area-filtered) at this width, pixels."
    )
    depth_weight: float = setting(ge=0, doc="Weight of the normalised depth L1 against the summed IoUs.")
    keep_floor: bool = setting(
        doc="True: the box stays on room_init's floor plane (the scale then comes from the floor fit alone)."
    )
    learning_rates: RoomFitRates = setting(doc="Learning rate of each parameter.")


@dataclass
class GroupObjects(GroupParams):
    """``group_objects``: guessed segments that are parts of one object merged (:mod:`~..grouping`)."""

    enabled: bool = setting(doc="False: the segmentation passes through as it is.")


@dataclass
class RetrieveObjects:
    """``retrieve_objects`` (§4.3 model search): the best database models per object segment."""

    top_k: int = setting(ge=1, doc="Models ranked per object segment.")
    alternate_margin: float = setting(
        ge=0,
        doc="A guessed label's alternates (a detector's bed may be a desk) win only by this share of its own best.",
    )
    min_points: int = setting(ge=0, doc="Segments with fewer depth points are left out ...")
    min_pixels: int = setting(ge=0, doc="... and so are those with fewer pixels.")


@dataclass
class Prune:
    """Which guessed objects (segments with a score) the fit cannot explain and drops."""

    min_iou: float = setting(
        ge=0,
        le=1,
        doc="A guessed object whose posed model's visible silhouette overlaps its mask less is dropped (init=silhouette).",
    )


@dataclass
class PlaceObjects:
    """``place_objects`` (§4.3 initialisation): a pose per object from the point cloud and the mask, the support
    relations, then a physically possible scene."""

    pick: Any = setting(
        doc="Segment id → rank (0: the best) or model id: another candidate for that segment (+place_objects.pick.7=2)."
    )
    init: str = setting(
        choices=("silhouette", "radius"),
        doc="silhouette: the occlusion-aware view search at the apparent size and depth; radius: the paper's small "
        "start from the points' radius.",
    )
    radius_factor: float = setting(
        gt=0,
        doc="init=radius: model radius = this × the points' radius (the paper starts small and lets objects grow).",
    )
    render_width: int = setting(ge=16, doc="Silhouettes are compared at this width, pixels.")
    search: SearchParams = setting(doc="The view search (:mod:`psdr_room_core.method.view_search`).")
    size_prior: SizePriorWeights = setting(doc="Each pose's size prior (in the view search's error units).")
    prune: Prune = setting(doc="Guessed objects the fit cannot explain are dropped.")
    physical: PhysicalParams = setting(
        doc="Then the scene is made possible (:mod:`psdr_room_core.method.physical`; fit_objects uses these too)."
    )
    min_points: int = setting(ge=0, doc="Segments with fewer depth points are left out (as retrieve_objects') ...")
    min_pixels: int = setting(ge=0, doc="... and so are those with fewer pixels.")
    support: SupportParams = setting(doc="The support rules (§4.3: on the floor, on an object, on a wall).")


@dataclass
class YawTest:
    """Front/back ambiguity of masks and depth: each object turned in place, kept turned where the loss drops."""

    at: float = setting(ge=0, le=1, doc="After this share of the iterations the objects are turned ...")
    angles: list[float] = setting(doc="... by each of these angles, degrees ...")
    min_gain: float = setting(
        ge=0,
        doc="... and kept turned where the joint loss drops and that object's own term by this share (not render noise).",
    )


@dataclass
class FitObjectsRates:
    """``fit_objects``' learning rates, per parameter."""

    translation: float = setting(ge=0, doc="In units of the room box's mean half-size.")
    log_scale: float = setting(ge=0, doc="Of each object's uniform scale.")
    yaw: float = setting(ge=0, doc="Degrees (the public reference's rotation rate).")


@dataclass
class FitObjects:
    """``fit_objects`` (§4.3 refinement, eq. 3): all objects' poses at once, by differentiable rendering of their
    masks and depth."""

    iterations: int = setting(
        ge=1,
        doc="At most: the fit stops earlier on a plateau of its loss (after the yaw test only where an object turned).",
    )
    convergence: Plateau = setting(doc="When the loss has flattened.")
    render_width: int = setting(
        ge=16, doc="Masks and depth are rendered (and the targets area-filtered) at this width, pixels."
    )
    blur_sigmas: list[float] = setting(
        gt=0, doc="Gaussian pyramid of the blurred-mask term: sigmas in pixels at render_width."
    )
    blur_weight: float = setting(ge=0, doc="Weight of the blurred-mask term against the masked depth term.")
    size_prior: SizePriorWeights = setting(doc="Each object's size prior (as place_objects', in this loss's units).")
    room_weight: float = setting(ge=0, doc="Cost per metre an object reaches beyond the room box.")
    collision_weight: float = setting(
        ge=0, doc="Cost per metre two objects pass through each other (the mean depth of their shared volume)."
    )
    back_weight: float = setting(
        ge=0,
        doc="Cost of a bed, cabinet, shelf or fridge showing the camera its back square on (as place_objects.search's).",
    )
    wall_weight: float = setting(
        ge=0,
        doc="Cost per metre the wall behind such an object is farther than the wall nearest it (as place_objects.search's).",
    )
    yaw_test: YawTest = setting(doc="Objects turned in place partway through the fit.")
    keep_share: float = setting(
        ge=0,
        le=1,
        doc="An object the fit leaves explaining less than this share of what it explained when placed (render IoU "
        "with its segment) goes back to its placed pose ...",
    )
    same_box: float = setting(
        ge=0,
        le=1,
        doc="... and so does one whose render's box matched its prompt box by this IoU when placed and no longer does "
        "(the fit shrank a chair whose cut lost its legs to the cut's size).",
    )
    learning_rates: FitObjectsRates = setting(doc="Learning rate of each parameter.")
    physical: PhysicalParams = setting(
        doc="Then the scene is made possible as place_objects does, the room box grown where an object the photo shows "
        "cannot be brought inside it (room_box_objects)."
    )


@dataclass
class CleanPixels:
    """Which of a part's pixels show the surface itself (:func:`~psdr_room_core.method.surface_colours.clean_pixels`)."""

    coverage: float = setting(
        gt=0, le=1, doc="The part's colour model explains its commonest colours holding this share of its pixels."
    )
    edge_ratio: float = setting(gt=0, doc="A pixel whose local edge energy is this many times its part's median ...")
    edge_floor: float = setting(ge=0, doc="... and above this (L* 0..255 per pixel) is an edge of something in front.")
    open_px: int = setting(
        ge=0, doc="Unexplained specks thinner than this (pixels) stay clean; dirt grows by half of it."
    )


@dataclass
class RoomColours:
    """Albedo (sRGB, 0..1) of a room side the photo does not show, when no wall shows either."""

    floor: list[float] = setting(ge=0, le=1, length=3, doc="Of the floor.")
    ceiling: list[float] = setting(ge=0, le=1, length=3, doc="Of the ceiling.")
    wall: list[float] = setting(ge=0, le=1, length=3, doc="Of a wall.")


@dataclass
class RoomCategories:
    """Library categories (``psdr-room-materials list``) a room side's material is retrieved from (objects take
    any)."""

    floor: list[str] = setting(doc="Of the floor.")
    ceiling: list[str] = setting(doc="Of the ceiling.")
    wall: list[str] = setting(doc="Of the walls.")


@dataclass
class AssignMaterials:
    """``assign_materials`` (§4.4, first half): crop pairs, homogeneous colours, procedural material retrieval and
    the texture-transform search."""

    render_width: int = setting(
        ge=16, doc="Part masks and depth are rendered at this width (pixels), then scaled to the working image."
    )
    erode_px: int = setting(ge=0, doc="Crops keep this far (pixels) inside the part's clean pixels.")
    clean: CleanPixels = setting(doc="Which of a part's pixels show the surface itself.")
    flat_energy: float = setting(
        ge=0,
        doc="Crops with a median texture energy under this are plain: homogeneous (calibration: benchmarks/materials.py).",
    )
    max_crops: int = setting(ge=0, doc="Crop windows per part (largest first).")
    min_crop_px: int = setting(
        ge=1,
        doc="A crop's shorter side, working-image pixels; smaller parts stay homogeneous (and the walls' colour is "
        "taken from the clear wall pixels where there are at least this squared).",
    )
    top_k: int = setting(ge=1, doc="Graphs kept per crop before voting (the paper's 10).")
    min_similarity: float = setting(
        le=1,
        doc="1 - d(best graph) / d(typical pair of library graphs) a procedural part needs (lower: more procedural); "
        "0.33 passes 90% of library crops under random light (benchmarks/materials.py, p10).",
    )
    scales: list[float] = setting(gt=0, doc="Texture-transform search: scales tried (the paper's 0.5-8.0) ...")
    rotations: list[float] = setting(doc="... and rotations, degrees.")
    map_size: int = setting(ge=8, doc="Side (pixels) of the texture maps evaluated for retrieval and the search.")
    roughness: float = setting(ge=0, le=1, doc="Roughness of homogeneous parts.")
    clear_height: float = setting(
        ge=0, doc="Metres: unseen walls and the ceiling take the colour of the visible walls above this height."
    )
    room_colours: RoomColours = setting(doc="Albedo of room sides the photo does not show, when no wall shows either.")
    room_categories: RoomCategories = setting(doc="Library categories a room side is retrieved from.")


@dataclass
class Sweep:
    """Uniform radiance values tried, geometrically spaced."""

    min: float = setting(gt=0, doc="The lowest.")
    max: float = setting(gt=0, doc="The highest.")
    count: int = setting(ge=1, doc="How many.")


@dataclass
class InitLights:
    """``init_lights`` (§4.4 light initialisation): ceiling panels out of view, a panel behind the camera, windows
    on hidden walls, visible windows and lamps made emissive; one uniform radiance from a sweep, its colour the
    photo's white balance."""

    ceiling_grid: list[int] = setting(ge=1, length=2, doc="Rows × columns of ceiling panels.")
    cell_ratio: float = setting(gt=0, le=1, doc="Each panel scaled by this about its cell's centre (the paper's 0.8).")
    behind_ratio: float = setting(gt=0, le=1, doc="The panel behind the camera: this share of the wall behind it.")
    window_ratio: float = setting(gt=0, le=1, doc="A hidden wall's window panel: this share of the wall.")
    hidden_wall_px: int = setting(ge=0, doc="Walls showing fewer pixels than this get a window panel.")
    frame_width: float = setting(ge=0, doc="Window frame bars, metres.")
    drop: float = setting(ge=0, doc="Lights sit this far (metres) off their ceiling or wall.")
    render_width: int = setting(ge=16, doc="Width (pixels) of the unit-radiance render.")
    spp: int = setting(ge=1, doc="Samples per pixel of the unit-radiance render.")
    downsample: int = setting(ge=1, doc="The sweep compares luminance at 1/this size.")
    sweep: Sweep = setting(doc="Uniform radiance values tried.")
    max_balance: float = setting(
        ge=1, doc="The lights' colour matches the photo's cast, each channel within this factor of grey."
    )


@dataclass
class AppearanceWeights:
    """Weights of eq. 4's terms."""

    image: float = setting(ge=0, doc="The down-sampled image term.")
    colour: float = setting(ge=0, doc="Each part's mean-colour term.")
    texture: float = setting(ge=0, doc="The crop pairs' texture-descriptor term.")
    paint: float = setting(ge=0, doc="The prior pulling a procedural wall's mean map luminance into paint.albedo.")


@dataclass
class AppearanceRates:
    """``fit_appearance``'s learning rates, per parameter group."""

    graph: float = setting(ge=0, doc="Procedural graphs' parameters.")
    base_color: float = setting(ge=0, doc="Homogeneous parts' base colour.")
    roughness: float = setting(ge=0, doc="Roughness.")
    specular: float = setting(ge=0, doc="Specular.")
    radiance: float = setting(ge=0, doc="Each light's intensity.")
    light_colour: float = setting(ge=0, doc="The lights' shared colour.")


@dataclass
class FitAppearance:
    """``fit_appearance`` (§4.4, eq. 4): procedural-graph parameters, homogeneous materials and light radiances
    at once, under global illumination (``renderer.mitsuba.max_depth``; 2: direct light only). Its node's
    ``_uses_`` describes textures at 128 px: the render crops are about 10-25 px at render_width 160, and the
    finest filters of assign_materials' 256 px would see only the upsampling (4x cheaper)."""

    iterations: int = setting(ge=1, doc="Optimisation steps (at most, with a plateau stop).")
    convergence: Plateau = setting(
        doc="When the loss has flattened. Window 0 (no plateau stop) ships: the loss is noisy (spp 8) and still falls "
        "past 100 iterations; window 20 stopped the synthetic rooms early, 5% worse median RMSE (benchmarks/pipeline.py)."
    )
    render_width: int = setting(
        ge=16,
        doc="Renders (and the photo, area-filtered) at this width, pixels; 160: about 0.3 s an iteration on 2 cores "
        "(benchmarks/speed.py: other widths).",
    )
    spp: int = setting(ge=1, doc="Primal samples per pixel per iteration (the public reference: 8).")
    grad_spp: int = setting(ge=1, doc="Samples per pixel of the gradient pass.")
    final_spp: int = setting(
        ge=1, doc="Samples per pixel of the initial and final renders the metrics measure (low noise)."
    )
    map_size: int = setting(
        ge=8,
        doc="Procedural maps are evaluated at this side while optimising (a tile spans fewer pixels at render_width).",
    )
    downsample: int = setting(ge=1, doc="The image term compares 1/this-size images (the paper's R_1/8, I_1/8).")
    min_region_px: int = setting(
        ge=0, doc="Parts covering fewer rendered pixels get no mean-colour term and keep their initial material."
    )
    weights: AppearanceWeights = setting(doc="Weights of the loss terms.")
    learning_rates: AppearanceRates = setting(doc="Learning rate of each parameter group.")
    crops_per_part: int = setting(
        ge=0, doc="Crop pairs of each part in the texture term (largest first; each costs about 0.03 s an iteration)."
    )
    max_crop_aspect: float = setting(
        ge=1, doc="Long thin crops are cut to their centred window of this aspect (descriptor cost grows with it)."
    )
    radiance_range: float = setting(
        ge=1, doc="Each light's intensity stays within this factor of its initial value, either way."
    )
    colour_range: float = setting(
        ge=1, doc="The lights share one colour; each channel stays within this factor of the initial one."
    )
    plain_check: bool = setting(
        doc="After the fit, a procedural part whose mean colour matches the photo's structure better (SSIM on its "
        "pixels) becomes homogeneous."
    )
    paint: PaintPrior = setting(
        doc="Walls and the ceiling are paint (:mod:`psdr_room_core.method.material_priors`, with the sources); "
        "albedo [0, 1], max_specular 1.0 and weights.paint 0 turn the prior off."
    )


@dataclass
class ExportScene:
    """``export_scene``: Mitsuba 3 scene, glTF binary, OpenUSD, the editable appearance and the point cloud."""

    spp: int = setting(ge=1, doc="The scene XML's default samples per pixel ($spp).")
    max_depth: int = setting(ge=1, doc="The scene XML's path length ($max_depth): the one the fit used.")
    texture_size: int = setting(ge=8, doc="Procedural maps are baked at this side, pixels (textures/*.png).")
    glb: bool = setting(doc="Also write scene.glb.")
    usd: bool = setting(
        doc="Also write scene.usda (OpenUSD: camera, meshes, UsdPreviewSurface materials, UsdLux lights)."
    )
