"""Light initialisation (paper §4.4): the light layout, lamps made emissive, and the uniform initial radiance
chosen by one render at unit radiance (light transport is linear in it)."""

from __future__ import annotations

import logging

import numpy as np
import torch
import torch.nn.functional as F

from psdr_room_core.engine.dag import StageContext

from ..artifacts import Camera, Image, Light, Lights, MaterialAssignment, Panoptic, Placements, RoomBox
from ..capabilities import Denoiser, MaterialGraph, Renderer
from ..geometry import TriangleMesh, quad_mesh
from ..image_metrics import downsampled, luminance
from ..lighting import behind_camera_light, ceiling_lights, wall_window_light, window_panel
from ..rgb_scene import GUIDE_SPP, build_scene, initial_parts, part_meshes, render_part_ids, room_quads, to_srgb8
from ..shading import linear_to_srgb, srgb_to_linear
from ..visualize import plot_curves, to_uint8
from .settings import InitLights

log = logging.getLogger("psdr_room")


def init_lights(
    ctx: StageContext,
    image: Image,
    panoptic: Panoptic,
    camera: Camera,
    room: RoomBox,
    placements: Placements,
    materials: MaterialAssignment,
) -> Lights:
    """The initial lights of §4.4: the layout of :func:`light_layout`, all at one uniform radiance. The scene is
    rendered once at unit radiance (``render_width``, ``spp``), and of the ``sweep`` values {min, max, count}
    (geometric) the one whose scaled render has the least L1 to the photo's luminance at 1/``downsample`` size is
    kept (:func:`radiance_sweep`). The lights' colour then matches the photo's white balance: :func:`white_balance`
    of the unit render against the photo (each channel within ``max_balance`` of grey)."""
    settings = ctx.settings(InitLights)
    # set up: the layout, and the scene rendered once at unit radiance beside the photo at its size
    c2w = np.asarray(room.camera_to_world)
    meshes = part_meshes(room, placements)
    ids, _ = render_part_ids(ctx.impl("renderer", Renderer), camera, c2w, meshes, settings.render_width)
    layout, fixtures = light_layout(room, camera, panoptic, placements, meshes, ids, settings=settings)
    library = ctx.impl("material_graph", MaterialGraph)
    scene = build_scene(meshes, initial_parts(materials, library), layout, fixtures, library, 64)
    width = min(settings.render_width, camera.width)
    geometry = scene.renderer(ctx.impl("renderer", Renderer), camera, c2w, width)
    with torch.no_grad():
        unit = geometry.render_rgb(spp=settings.spp)
    photo = torch.from_numpy(np.asarray(image.rgb, np.float32))
    photo = F.interpolate(photo.permute(2, 0, 1)[None], size=unit.shape[:2], mode="area")[0].permute(1, 2, 0)
    # search: the uniform radiance
    low, high, count = settings.sweep.min, settings.sweep.max, settings.sweep.count
    sweep = radiance_sweep(unit, photo, np.geomspace(low, high, count), factor=settings.downsample)
    # decide: the closest radiance, in the photo's colour
    best = min(sweep, key=lambda s: s[1])[0]
    balance = white_balance(unit, photo, settings.max_balance)
    radiance = tuple(best * float(b) for b in balance)
    lights = [Light(l.name, l.kind, l.mesh, radiance, l.part) for l in layout]  # type: ignore[arg-type]
    # report: the lit scene beside the photo, and the sweep
    picture = ctx.impl("denoiser", Denoiser).denoise(
        unit.numpy() * np.asarray(radiance, np.float32), *geometry.render_guides(spp=GUIDE_SPP)
    )
    curve = plot_curves(
        {"L1 luminance vs log radiance": [s[1] for s in sweep]},
        title=f"initial radiance sweep: {best:.3g} chosen of {low:g}..{high:g}",
    )
    log.info(
        "%d lights (%s); initial radiance %.3g, colour (%.2f, %.2f, %.2f)",
        len(lights),
        ", ".join(f"{k} {sum(l.kind == k for l in lights)}" for k in dict.fromkeys(l.kind for l in lights)),
        best,
        *balance,
    )
    images = {"initial_render": np.hstack([to_srgb8(picture), to_uint8(photo.numpy())]), "radiance_sweep": curve}
    return Lights(lights=lights, fixtures=fixtures, sweep=sweep, images=images)


def light_layout(
    room: RoomBox,
    camera: Camera,
    panoptic: Panoptic,
    placements: Placements,
    meshes: dict[str, TriangleMesh],
    ids: np.ndarray,
    *,
    settings: InitLights,
) -> tuple[list[Light], dict[str, TriangleMesh]]:
    """The lights of §4.4 (no radiance yet) and the window frames, ``drop`` metres off their surfaces
    (``ids``: the rendered part of each pixel). The ceiling is split into a ``ceiling_grid`` of panels, each
    scaled by ``cell_ratio``, and those in the camera's view or wholly behind it are removed; a panel
    ``behind_ratio`` of the wall behind the camera is added, and a window panel (``window_ratio`` of the wall)
    on every wall showing under ``hidden_wall_px`` pixels. Visible ``window`` segments become emissive panels on
    their wall with a frame (``frame_width`` metres); the largest visible part of each ``lamp`` object emits."""
    c2w = np.asarray(room.camera_to_world)
    quads = room_quads(room)
    names = list(meshes)
    seen = np.bincount(ids[ids >= 0].ravel(), minlength=len(names))
    drop = settings.drop
    rows, cols = settings.ceiling_grid
    lights = ceiling_lights(quads["ceiling"], camera, c2w, rows, cols, settings.cell_ratio, drop)
    lights.append(behind_camera_light(room, quads, settings.behind_ratio))
    for name, quad in quads.items():
        if name.startswith("wall") and seen[names.index(name)] < settings.hidden_wall_px:
            lights.append(wall_window_light(name, quad, settings.window_ratio, drop))
    fixtures: dict[str, TriangleMesh] = {}
    walls = [n for n in names if n.startswith("wall")]
    for segment in (s for s in panoptic.segments if s.category == "window"):
        mask = panoptic.ids == segment.id
        on = [int(np.sum(ids[mask] == names.index(w))) for w in walls]
        if not max(on, default=0):
            continue
        panel = window_panel(mask, quads[walls[int(np.argmax(on))]], camera, c2w, drop, settings.frame_width)
        if panel is not None:
            quad, bars = panel
            lights.append(Light(f"light_window_{segment.id}", "window", quad_mesh(quad)))
            fixtures.update({f"window_{segment.id}_frame_{k}": bar for k, bar in enumerate(bars)})
    lamps = {
        p.segment_id
        for p in placements.objects
        if any(s.id == p.segment_id and s.category == "lamp" for s in panoptic.segments)
    }
    for segment_id in sorted(lamps):
        prefix = f"object_{segment_id}_"
        own = [(int(seen[i]), n) for i, n in enumerate(names) if n.startswith(prefix)]
        if own and max(own)[0] > 0:
            part = max(own)[1]
            lights.append(Light(f"light_lamp_{segment_id}", "lamp", meshes[part], part=part))
    return lights, fixtures


def radiance_sweep(
    unit: torch.Tensor, photo: torch.Tensor, values: np.ndarray, *, factor: int
) -> list[tuple[float, float]]:
    """(radiance, L1 to the photo's luminance) of the linear ``unit`` render (at unit radiance; light transport is
    linear in it) scaled by each of ``values``, compared in sRGB at 1/``factor`` size."""
    target = luminance(downsampled(photo, factor))
    sweep = []
    for value in values:
        render = luminance(downsampled(linear_to_srgb(unit * float(value)), factor))
        sweep.append((float(value), float((render - target).abs().mean())))
    return sweep


def white_balance(render: torch.Tensor, photo: torch.Tensor, max_gain: float) -> np.ndarray:
    """The light colour (RGB, unit luminance) that gives an (H, W, 3) linear ``render`` the colour cast of the
    sRGB ``photo``: per channel, the ratio of the photo's linear mean to the render's over the pixels the
    render covers, divided by its luminance; each gain is clamped to [1/``max_gain``, ``max_gain``]. A warm
    photo gives warm lights, and colour the albedos already carry (they are the photo's own medians) or that
    interreflection adds is not counted twice."""
    covered = render.sum(-1) > 0
    if not bool(covered.any()):
        return np.ones(3)
    target = srgb_to_linear(photo[covered]).mean(0).double().numpy()
    rendered = render[covered].mean(0).double().numpy()
    gains = target / np.maximum(rendered, 1e-8)
    gains = gains / max(float(luminance(torch.from_numpy(gains))), 1e-8)
    return np.clip(gains, 1.0 / max_gain, max_gain)
