"""Material initialisation (paper §4.4, first half): crop pairs per scene part, homogeneous colours, procedural
material retrieval with voting across crops, and the texture-transform search."""

from __future__ import annotations

from dataclasses import asdict, dataclass
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
from ..rgb_scene import object_parts, render_part_ids, room_quads
from ..surface_colours import clean_pixels, dominant_colour, texture_energy
from .settings import AssignMaterials


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
    colour most clean wall pixels share (:func:`~..surface_colours.dominant_colour`), and only with no wall
    in view the ``room_colours`` default. The assignment's ``samples`` map keeps which pixels each median was
    taken over: ``fit_appearance`` compares the render with it there.

    A part is homogeneous (roughness ``roughness``) when it has no crop, when its crops are plain (median
    :func:`~..surface_colours.texture_energy` under ``flat_energy``), when its best retrieved graph's
    similarity is under ``min_similarity``, or when a flat colour matches its crops better than the
    retrieved graph at its best transform. Otherwise each crop ranks the ``material_graph`` library by
    ``texture`` descriptor distance (``top_k`` kept), the ranks are voted across crops, and the winner's
    texture transform is searched over ``scales`` × ``rotations``. A room side ranks only the graphs of its
    ``room_categories`` (a floor is never leather, a wall never brass; homogeneous when the library has none);
    an object's parts rank them all. Params also: ``render_width``, ``map_size`` (texture side evaluated for
    the search).
    """
    from ..material_search import MaterialIndex, flat_image, search_transform, surface_coordinates, vote

    settings = ctx.settings(AssignMaterials)
    parts = scene_parts(room, placements, panoptic, asdict(settings.room_colours))
    ids, depth = render_part_ids(
        ctx.impl("renderer", Renderer),
        camera,
        room.camera_to_world,
        {p.name: p.mesh for p in parts},
        settings.render_width,
    )
    rgb8 = image.to_uint8()
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
    _apply_user_crops(ctx, image, parts, ids)

    rgb = rgb8.astype(np.float32) / 255.0
    photo = torch.from_numpy(rgb).permute(2, 0, 1).contiguous()
    library, descriptor = ctx.impl("material_graph", MaterialGraph), ctx.impl("texture", TextureDescriptor)
    map_size = settings.map_size
    index = None
    c2w = np.asarray(room.camera_to_world)
    walls_clean = np.zeros(labels.shape, bool)
    for part in parts:
        if part.name.startswith("wall"):
            walls_clean |= part.clean
    upper = walls_clean & (heights(camera, c2w, depth) > settings.clear_height)
    walls = dominant_colour(rgb8, upper if upper.sum() >= side * side else walls_clean) if walls_clean.any() else None
    roughness = settings.roughness
    categories = {side: set(names) for side, names in asdict(settings.room_categories).items()}
    room_sides = set(room_quads(room))
    assigned, sheet_rows = [], []
    samples = np.full(labels.shape, -1, np.int16)
    for k, part in enumerate(ctx.progress(parts, total=len(parts))):
        unseen_side = part.name.startswith(("wall", "ceiling")) and not part.region.any()
        source = next((m for m in (part.clean, part.region) if m is not None and m.any()), None)
        if source is not None:
            samples[source] = k  # regions are disjoint
        albedo = walls if unseen_side and walls else median_colour(rgb, [source, part.target], part.fallback)
        crops = []
        for rect in part.crops:
            coords = surface_coordinates(camera, c2w, depth, rect)
            if coords is not None:
                x0, y0, x1, y1 = rect
                crops.append((photo[:, y0:y1, x0:x1], rgb[y0:y1, x0:x1], coords))
        if not crops:
            reason = (
                "no rendered depth in its crops"
                if part.crops
                else "unseen: the visible walls' colour"
                if unseen_side and walls
                else "no crop: the photo shows too little of it"
            )
            assigned.append(PartMaterial(part.name, "homogeneous", albedo, roughness, reason=reason))
            continue
        energy = float(np.median([texture_energy(c) for _, c, _ in crops]))
        common = dict(part=part.name, albedo=albedo, roughness=roughness, crops=tuple(part.crops))
        if energy < settings.flat_energy:
            assigned.append(
                PartMaterial(
                    kind="homogeneous",
                    scores={"texture_energy": energy},
                    reason=f"plain: texture energy {energy:.3f} < flat_energy",
                    **common,
                )
            )
            continue
        if index is None:
            index = MaterialIndex.build(library, descriptor, map_size)
        wanted = categories[part.name.split("_")[0]] if part.name in room_sides else None
        allowed = torch.tensor(
            [wanted is None or library.material(n).category in wanted for n in index.names], dtype=torch.bool
        )
        if not allowed.any():
            assigned.append(
                PartMaterial(
                    kind="homogeneous",
                    scores={"texture_energy": energy},
                    reason=f"no library material of the categories {sorted(wanted or ())}",
                    **common,
                )
            )
            continue
        with torch.no_grad():
            described = [(crop, descriptor.describe(crop), coords) for crop, _, coords in crops]
            flats = [
                float(descriptor.distance(descriptor.describe(flat_image(albedo, (c.shape[1], c.shape[2]))), d))
                for c, d, _ in described
            ]
            per_crop = []
            for _, target, _ in described:
                distances = torch.where(allowed, index.distances(descriptor, target), torch.inf)
                order = torch.argsort(distances)[: min(settings.top_k, int(allowed.sum()))].tolist()
                per_crop.append([(index.names[i], index.similarity(float(distances[i]))) for i in order])
        ranked = vote(per_crop)
        name, best_similarity = ranked[0]
        homogeneous_loss = float(np.mean(flats))
        common["candidates"] = tuple((n, round(s, 4)) for n, s in ranked[:5])
        scores = {"texture_energy": energy, "similarity": best_similarity, "homogeneous_loss": homogeneous_loss}
        if best_similarity < settings.min_similarity:
            assigned.append(
                PartMaterial(
                    kind="homogeneous",
                    scores=scores,
                    reason=f"best similarity {best_similarity:.3f} < min_similarity",
                    **common,
                )
            )
            continue
        material = library.material(name)
        fit = search_transform(
            library,
            descriptor,
            library.appearance(name, map_size),
            float(material.tile_size),
            described,
            settings.scales,
            settings.rotations,
        )
        scores["texture_loss"] = fit.loss
        if fit.loss >= homogeneous_loss:
            assigned.append(
                PartMaterial(
                    kind="homogeneous", scores=scores, reason=f"a flat colour matches better than {name}", **common
                )
            )
        else:
            assigned.append(
                PartMaterial(
                    kind="procedural",
                    material=name,
                    scale=fit.scale,
                    rotation=fit.rotation,
                    scores=scores,
                    reason="retrieved",
                    **common,
                )
            )
        sheet_rows += [
            (part.name, crop, view, albedo, assigned[-1]) for (crop, _, _), view in zip(described, fit.views)
        ]
    return MaterialAssignment(
        parts=assigned,
        images={"crops": crop_overlay(rgb8, parts), **({"crop_pairs": crop_sheet(sheet_rows)} if sheet_rows else {})},
        samples=samples,
    )


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


# ------------------------------------------------------------------------------------------ pictures
def crop_overlay(rgb8: np.ndarray, parts: list[ScenePart]) -> np.ndarray:
    """The photo with every crop window outlined and named, and the pixels of the parts' regions that are
    not clean (clutter, strong edges) tinted red."""
    out = rgb8.copy()
    for part in parts:
        if part.region is not None and part.clean is not None:
            dirty = part.region & ~part.clean
            out[dirty] = (0.5 * out[dirty] + [127, 0, 0]).astype(np.uint8)
    for k, part in enumerate(p for p in parts if p.crops):
        colour = tuple(
            int(c) for c in cv2.applyColorMap(np.array([[53 * k % 255]], np.uint8), cv2.COLORMAP_HSV)[0, 0][::-1]
        )
        for x0, y0, x1, y1 in part.crops:
            cv2.rectangle(out, (x0, y0), (x1 - 1, y1 - 1), colour, 2)
            cv2.putText(out, part.name, (x0 + 3, y0 + 12), cv2.FONT_HERSHEY_SIMPLEX, 0.38, colour, 1, cv2.LINE_AA)
    return out


def crop_sheet(
    rows: list[tuple[str, Any, Any, tuple[float, float, float], PartMaterial]], cell: int = 96
) -> np.ndarray:
    """One row per crop pair: the photo crop, the retrieved material in it at the chosen transform, the flat
    median colour, and what was chosen."""
    lines = []
    for name, crop, view, albedo, chosen in rows:
        tiles = [
            _fit(_to_uint8(crop), cell),
            _fit(_to_uint8(view), cell),
            np.full((cell, cell, 3), np.round(np.asarray(albedo) * 255), np.uint8),
        ]
        caption = np.full((cell, 3 * cell, 3), 255, np.uint8)
        text = [
            name[:30],
            f"-> {chosen.material or 'homogeneous'}",
            f"scale {chosen.scale:g} rot {chosen.rotation:g}",
            f"tex {chosen.scores.get('texture_loss', float('nan')):.3f} flat {chosen.scores.get('homogeneous_loss', float('nan')):.3f}",
            f"sim {chosen.scores.get('similarity', float('nan')):.3f}",
        ]
        for i, line in enumerate(text):
            cv2.putText(caption, line, (4, 16 + 17 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (0, 0, 0), 1, cv2.LINE_AA)
        lines.append(np.hstack(tiles + [caption]))
    return np.vstack(lines)


def _to_uint8(image: torch.Tensor) -> np.ndarray:
    return (image.clamp(0, 1).permute(1, 2, 0).numpy() * 255 + 0.5).astype(np.uint8)


def _fit(rgb8: np.ndarray, cell: int) -> np.ndarray:
    scale = cell / max(rgb8.shape[:2])
    small = cv2.resize(
        rgb8,
        (max(1, round(rgb8.shape[1] * scale)), max(1, round(rgb8.shape[0] * scale))),
        interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_NEAREST,
    )
    tile = np.full((cell, cell, 3), 255, np.uint8)
    y0, x0 = (cell - small.shape[0]) // 2, (cell - small.shape[1]) // 2
    tile[y0 : y0 + small.shape[0], x0 : x0 + small.shape[1]] = small
    return tile
