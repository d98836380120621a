"""Material initialisation (paper §4.4, first half): crop pairs per scene part, homogeneous colours, procedural
material retrieval with voting across crops, and the texture-transform search."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from functools import cached_property
from typing import Any

import cv2
import numpy as np
import torch

from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError

from ..artifacts import Camera, Image, MaterialAssignment, Panoptic, PartMaterial, Placements, Rect, RoomBox, vec3
from ..capabilities import MaterialGraph, Renderer, TextureDescriptor
from ..crops import crop_windows, crops_file, read_crops
from ..geometry import TriangleMesh
from ..material_search import MaterialIndex, TransformFit, flat_image, search_transform, surface_coordinates, vote
from ..rgb_scene import object_parts, render_part_ids, room_quads
from ..surface_colours import clean_pixels, dominant_colour, texture_energy
from ..visualize import crop_overlay, crop_sheet
from .settings import AssignMaterials

Colour = tuple[float, float, float]
CropView = tuple[torch.Tensor, Any, tuple[torch.Tensor, torch.Tensor]]
"""A crop window of the photo: its pixels as a [3, h, w] tensor and as an (h, w, 3) array (a descriptor once
described), and the surface coordinates of its pixels."""
SheetRow = tuple[str, torch.Tensor, torch.Tensor, Colour, PartMaterial]
"""A row of the crop sheet: part, photo crop, the chosen material's view of it, flat colour, chosen material."""


@dataclass
class ScenePart:
    """A part the materials are assigned to, with what the photo shows of it."""

    name: str
    mesh: TriangleMesh
    """World-space, welded."""
    target: np.ndarray
    """(H, W) bool: the segment the part should cover (its object's, or the room category's)."""
    fallback: tuple[float, float, float]
    """sRGB colour when the photo shows nothing of it (the model's own, or the room default)."""
    region: np.ndarray | None = None
    """(H, W) bool: rendered part ∩ target."""
    clean: np.ndarray | None = None
    """(H, W) bool: the region's pixels that show the surface itself (no clutter, no strong edge)."""
    crops: tuple[Rect, ...] = ()


def scene_parts(
    room: RoomBox, placements: Placements, panoptic: Panoptic, room_colours: dict[str, list[float]]
) -> list[ScenePart]:
    """The room's six sides and every object's material groups, as exported."""
    parts = []
    for name, quad in room_quads(room).items():
        category = name.split("_")[0]
        parts.append(
            ScenePart(
                name,
                TriangleMesh(quad, np.array([[0, 1, 2], [0, 2, 3]])),
                panoptic.mask(category),
                vec3(room_colours[category]),
            )
        )
    for p in placements.objects:
        target = panoptic.ids == p.segment_id
        for name, (mesh, colour) in object_parts(p).items():
            parts.append(ScenePart(name, mesh, target, vec3(colour)))
    return parts


def assign_materials(
    ctx: StageContext, image: Image, panoptic: Panoptic, camera: Camera, room: RoomBox, placements: Placements
) -> MaterialAssignment:
    """Initial material of every scene part (§4.4).

    A part's *region* is its rendered mask ∩ its target segment; its *clean* pixels are those of the region
    its own colour model explains and no strong edge crosses (:func:`~..surface_colours.clean_pixels` with
    ``clean``: ``coverage``, ``edge_ratio``, ``edge_floor``, ``open_px``), so clutter the segmentation left
    on a wall is neither cropped nor averaged. Crop pairs are the largest rectangles inside the clean pixels
    eroded by ``erode_px`` (up to ``max_crops``, none with a side under ``min_crop_px``), unless the user's
    ``<photo>.crops.yaml`` gives them (:mod:`..crops`). The albedo is the median colour of the clean pixels
    (else of the region, else of the segment); a wall or the ceiling the photo does not show takes the
    colour most clean wall pixels share (:func:`walls_colour`), and only with no wall in view the
    ``room_colours`` default. The assignment's ``samples`` map keeps which pixels each median was taken over:
    ``fit_appearance`` compares the render with it there.

    A part is homogeneous (roughness ``roughness``) when it has no crop, when its crops are plain (median
    :func:`~..surface_colours.texture_energy` under ``flat_energy``), when its best retrieved graph's
    similarity is under ``min_similarity``, or when a flat colour matches its crops better than the
    retrieved graph at its best transform. Otherwise each crop ranks the ``material_graph`` library by
    ``texture`` descriptor distance (``top_k`` kept), the ranks are voted across crops, and the winner's
    texture transform is searched over ``scales`` × ``rotations`` (:class:`Retrieval`). A room side ranks only
    the graphs of its ``room_categories`` (a floor is never leather, a wall never brass; homogeneous when the
    library has none); an object's parts rank them all.
    """
    settings = ctx.settings(AssignMaterials)
    # set up: the parts, what the photo shows of each and where to crop it, and the visible walls' colour
    parts = scene_parts(room, placements, panoptic, asdict(settings.room_colours))
    meshes = {p.name: p.mesh for p in parts}
    ids, depth = render_part_ids(
        ctx.impl("renderer", Renderer), camera, room.camera_to_world, meshes, settings.render_width
    )
    rgb8 = image.to_uint8()
    labels, clean = surface_regions(parts, ids, rgb8, settings=settings)
    _apply_user_crops(ctx, image, parts, ids)
    rgb = rgb8.astype(np.float32) / 255.0
    photo = torch.from_numpy(rgb).permute(2, 0, 1).contiguous()
    library, descriptor = ctx.impl("material_graph", MaterialGraph), ctx.impl("texture", TextureDescriptor)
    retrieval = Retrieval(library, descriptor, settings, set(room_quads(room)))
    c2w = np.asarray(room.camera_to_world)
    height = heights(camera, c2w, depth)
    walls = walls_colour(rgb8, parts, height, clear_height=settings.clear_height, min_px=settings.min_crop_px**2)
    # search: each part's colour on its pixels, its material on its crops
    assigned, sheet_rows = [], []
    samples = np.full(labels.shape, -1, np.int16)
    for k, part in enumerate(ctx.progress(parts, total=len(parts))):
        unseen_side = part.name.startswith(("wall", "ceiling")) and not part.region.any()
        source = next((m for m in (part.clean, part.region) if m is not None and m.any()), None)
        if source is not None:
            samples[source] = k  # regions are disjoint
        albedo = walls if unseen_side and walls else median_colour(rgb, [source, part.target], part.fallback)
        crops = crop_views(part.crops, photo, rgb, camera=camera, camera_to_world=c2w, depth=depth)
        material, rows = choose_material(part, albedo, crops, retrieval, from_walls=bool(unseen_side and walls))
        assigned.append(material)
        sheet_rows += rows
    # report: the crop windows over the photo, and the crop pairs with what each part was given
    unclean = (labels >= 0) & ~clean
    images = {"crops": crop_overlay(rgb8, unclean=unclean, crops=[(p.name, p.crops) for p in parts if p.crops])}
    if sheet_rows:
        images["crop_pairs"] = crop_sheet(sheet_rows)
    return MaterialAssignment(parts=assigned, images=images, samples=samples)


def surface_regions(
    parts: list[ScenePart], ids: np.ndarray, rgb8: np.ndarray, *, settings: AssignMaterials
) -> tuple[np.ndarray, np.ndarray]:
    """Set each part's region (rendered part ``ids`` ∩ target), its clean pixels and its crop windows (the
    largest rectangles in its clean pixels eroded by ``erode_px``). Returns the part index of each region pixel
    (-1 elsewhere) and the clean-pixel mask."""
    labels = np.full(ids.shape, -1, np.int64)
    for k, part in enumerate(parts):
        part.region = (ids == k) & part.target
        labels[part.region] = k
    knobs = settings.clean
    clean = clean_pixels(rgb8, labels, knobs.coverage, knobs.edge_ratio, knobs.edge_floor, knobs.open_px)
    kernel = np.ones((2 * settings.erode_px + 1,) * 2, np.uint8)
    side = settings.min_crop_px
    for part in parts:
        part.clean = part.region & clean
        eroded = cv2.erode(part.clean.astype(np.uint8), kernel) > 0
        part.crops = tuple(crop_windows(eroded, settings.max_crops, side, side * side))
    return labels, clean


def walls_colour(
    rgb8: np.ndarray, parts: list[ScenePart], height: np.ndarray, *, clear_height: float, min_px: int
) -> Colour | None:
    """The colour most clean wall pixels share (:func:`~..surface_colours.dominant_colour`), of those higher than
    ``clear_height`` above the floor when at least ``min_px`` are (furniture stands lower); None when no clean
    pixel of a wall is seen."""
    walls_clean = np.zeros(height.shape, bool)
    for part in parts:
        if part.name.startswith("wall"):
            walls_clean |= part.clean
    upper = walls_clean & (height > clear_height)
    return dominant_colour(rgb8, upper if upper.sum() >= min_px else walls_clean) if walls_clean.any() else None


def crop_views(
    rects: tuple[Rect, ...],
    photo: torch.Tensor,
    rgb: np.ndarray,
    *,
    camera: Camera,
    camera_to_world: np.ndarray,
    depth: np.ndarray,
) -> list[CropView]:
    """The crop windows with rendered depth, each with its pixels of the photo ([3, H, W] ``photo`` and
    (H, W, 3) ``rgb``) and their surface coordinates (:func:`~..material_search.surface_coordinates`)."""
    crops = []
    for rect in rects:
        coords = surface_coordinates(camera, camera_to_world, depth, rect)
        if coords is not None:
            x0, y0, x1, y1 = rect
            crops.append((photo[:, y0:y1, x0:x1], rgb[y0:y1, x0:x1], coords))
    return crops


def choose_material(
    part: ScenePart, albedo: Colour, crops: list[CropView], retrieval: Retrieval, *, from_walls: bool
) -> tuple[PartMaterial, list[SheetRow]]:
    """A part's material (its colour ``albedo``, taken ``from_walls`` or from its own pixels) and its rows of the
    crop sheet: homogeneous without crops, with plain crops, without a library material of its categories or one
    similar enough, or when a flat colour matches its crops better than the best material at its best
    transform; else that material, procedural."""
    settings = retrieval.settings
    if not crops:
        reason = (
            "no rendered depth in its crops"
            if part.crops
            else "unseen: the visible walls' colour"
            if from_walls
            else "no crop: the photo shows too little of it"
        )
        return PartMaterial(part.name, "homogeneous", albedo, settings.roughness, reason=reason), []
    energy = float(np.median([texture_energy(c) for _, c, _ in crops]))
    common: dict[str, Any] = dict(part=part.name, albedo=albedo, roughness=settings.roughness, crops=tuple(part.crops))
    if energy < settings.flat_energy:
        reason = f"plain: texture energy {energy:.3f} < flat_energy"
        return PartMaterial(kind="homogeneous", scores={"texture_energy": energy}, reason=reason, **common), []
    allowed = retrieval.allowed(part.name)
    if not allowed.any():
        reason = f"no library material of the categories {sorted(retrieval.categories(part.name) or ())}"
        return PartMaterial(kind="homogeneous", scores={"texture_energy": energy}, reason=reason, **common), []
    described, ranked, homogeneous_loss = retrieval.rank(crops, albedo, allowed)
    name, best_similarity = ranked[0]
    common["candidates"] = tuple((n, round(s, 4)) for n, s in ranked[:5])
    scores = {"texture_energy": energy, "similarity": best_similarity, "homogeneous_loss": homogeneous_loss}
    if best_similarity < settings.min_similarity:
        reason = f"best similarity {best_similarity:.3f} < min_similarity"
        return PartMaterial(kind="homogeneous", scores=scores, reason=reason, **common), []
    fit = retrieval.transform(name, described)
    scores["texture_loss"] = fit.loss
    if fit.loss >= homogeneous_loss:
        reason = f"a flat colour matches better than {name}"
        chosen = PartMaterial(kind="homogeneous", scores=scores, reason=reason, **common)
    else:
        common.update(material=name, scale=fit.scale, rotation=fit.rotation)
        chosen = PartMaterial(kind="procedural", scores=scores, reason="retrieved", **common)
    return chosen, [(part.name, crop, view, albedo, chosen) for (crop, _, _), view in zip(described, fit.views)]


@dataclass
class Retrieval:
    """The ``material_graph`` library searched by ``texture`` descriptor for a part's crops (§4.4): its index is
    built at the first textured part."""

    library: MaterialGraph
    descriptor: TextureDescriptor
    settings: AssignMaterials
    room_sides: set[str]

    @cached_property
    def index(self) -> MaterialIndex:
        return MaterialIndex.build(self.library, self.descriptor, self.settings.map_size)

    def categories(self, part: str) -> set[str] | None:
        """The library categories a room side may take (``room_categories``); None (all) for an object's part."""
        if part not in self.room_sides:
            return None
        return set(asdict(self.settings.room_categories)[part.split("_")[0]])

    def allowed(self, part: str) -> torch.Tensor:
        """[M] bool: which of the index's materials the part may take."""
        wanted = self.categories(part)
        names = self.index.names
        return torch.tensor(
            [wanted is None or self.library.material(n).category in wanted for n in names], dtype=torch.bool
        )

    def rank(
        self, crops: list[CropView], albedo: Colour, allowed: torch.Tensor
    ) -> tuple[list[CropView], list[tuple[str, float]], float]:
        """The crops with their descriptors, the ``allowed`` materials voted across the crops (each crop's
        ``top_k`` nearest), and the flat colour's mean descriptor distance to the crops."""
        descriptor, index = self.descriptor, self.index
        with torch.no_grad():
            described = [(crop, descriptor.describe(crop), coords) for crop, _, coords in crops]
            flats = [
                float(descriptor.distance(descriptor.describe(flat_image(albedo, (c.shape[1], c.shape[2]))), d))
                for c, d, _ in described
            ]
            per_crop = []
            for _, target, _ in described:
                distances = torch.where(allowed, index.distances(descriptor, target), torch.inf)
                order = torch.argsort(distances)[: min(self.settings.top_k, int(allowed.sum()))].tolist()
                per_crop.append([(index.names[i], index.similarity(float(distances[i]))) for i in order])
        return described, vote(per_crop), float(np.mean(flats))

    def transform(self, name: str, described: list[CropView]) -> TransformFit:
        """Material ``name``'s best texture transform on the described crops, of ``scales`` × ``rotations``."""
        library, settings = self.library, self.settings
        tile = float(library.material(name).tile_size)
        look = library.appearance(name, settings.map_size)
        return search_transform(library, self.descriptor, look, tile, described, settings.scales, settings.rotations)


def heights(camera: Camera, camera_to_world: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(H, W) height above the floor (world y, metres) of the surface seen in each pixel from the rendered
    z-depth; NaN where nothing is rendered."""
    y = (camera.pixel_rays() @ camera_to_world[1, :3]) * depth + camera_to_world[1, 3]
    return np.where(depth > 0, y, np.nan)


def median_colour(
    rgb: np.ndarray, masks: list[np.ndarray | None], fallback: tuple[float, float, float]
) -> tuple[float, float, float]:
    """The median colour of the first non-empty mask, else ``fallback``."""
    for mask in masks:
        if mask is not None and mask.any():
            return tuple(float(c) for c in np.median(rgb[mask], axis=0))  # type: ignore[return-value]
    return fallback


def _apply_user_crops(ctx: StageContext, image: Image, parts: list[ScenePart], ids: np.ndarray) -> None:
    """Replace the automatic crops by the user's file beside the photo, when there is one."""
    path = crops_file(ctx.photo)
    if not path.is_file():
        return
    names = [p.name for p in parts]
    chosen: dict[str, list[Rect]] = {}
    for crop in read_crops(path, image.photo_size, (image.width, image.height)):
        if crop.part is not None:
            if crop.part not in names:
                raise PsdrRoomError(f"{path}: part '{crop.part}' is not in the scene; parts: {', '.join(names)}")
            name = crop.part
        else:
            x0, y0, x1, y1 = crop.render  # type: ignore[misc]
            seen = ids[y0:y1, x0:x1]
            seen = seen[seen >= 0]
            if not seen.size:
                raise PsdrRoomError(f"{path}: render window {list(crop.render)} shows no scene part; move it")  # type: ignore[arg-type]
            name = names[int(np.bincount(seen).argmax())]
        chosen.setdefault(name, []).append(crop.image)
    for part in parts:
        part.crops = tuple(chosen.get(part.name, ()))
