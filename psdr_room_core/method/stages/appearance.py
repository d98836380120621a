"""Joint material and lighting optimisation under global illumination (paper §4.4, eq. 4)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from functools import partial
from typing import Any

import cv2
import numpy as np
import torch

from psdr_room_core.engine.dag import StageContext

from .. import lpips
from ..artifacts import (
    Camera,
    Image,
    Lights,
    MaterialAssignment,
    OptimizationLog,
    PartAppearance,
    Placements,
    RoomBox,
    SceneAppearance,
    vec3,
)
from ..capabilities import Denoiser, MaterialGraph, Optimizer, Renderer, TextureDescriptor
from ..convergence import untimed
from ..image_metrics import downsampled, flip, rmse, ssim, ssim_map
from ..material_priors import LUMINANCE, painted, within_paint
from ..params import PaintPrior
from ..rgb_scene import build_scene, finished_render, graph_maps, initial_parts, part_meshes, render_part_ids
from ..shading import linear_to_srgb, srgb_to_linear
from ..visualize import crop_pairs, plot_curves, to_uint8
from .settings import FitAppearance

log = logging.getLogger("psdr_room")


def _logit(x: float) -> torch.Tensor:
    x = min(max(float(x), 1e-3), 1 - 1e-3)
    return torch.tensor([np.log(x / (1 - x))], dtype=torch.float32)


def paint_colour(shift: torch.Tensor, lightness: torch.Tensor, chroma: torch.Tensor, prior: PaintPrior) -> torch.Tensor:
    """A base colour whose luminance lies in ``prior.albedo`` and no channel above its top: the chromaticity
    ``chroma`` (the initial colour over its brightest channel) with each channel moved by at most a factor
    ``prior.hue_range`` (``tanh(shift)``), at the luminance ``sigmoid(lightness)`` places in the range, or as
    bright as the hue goes with its brightest channel at the top (a saturated hue stays darker)."""
    low, high = prior.albedo
    colour = chroma * torch.exp(float(np.log(prior.hue_range)) * torch.tanh(shift))
    colour = colour / colour.max()  # its luminance is then at least the smallest weight, 0.0722
    target = low + (high - low) * torch.sigmoid(lightness)
    return colour * torch.clamp(target / (colour @ torch.tensor(LUMINANCE)), max=high)


class AppearanceModel:
    """The optimised parameters of eq. 4: per optimised homogeneous part a base colour, roughness and specular
    (each through a sigmoid); per optimised procedural part its graph's free unconstrained parameters and a
    specular; per light an intensity within a factor ``radiance_range`` of its initial radiance either way,
    and one colour all lights share, each channel within a factor ``colour_range`` of the initial colour
    (``r0_l · exp(ln(range) · tanh(u_l)) · exp(ln(colour_range) · tanh(v))``, ``v`` of zero mean). A colour per
    light would let each ceiling panel tint the surfaces under it (green on one chair, yellow on the next):
    the photo's lights share one white balance, and the surfaces carry the colour. Parts not in ``free`` keep
    their initial material. Procedural parts in ``plain`` are drawn with their maps' mean colour and roughness
    and written as homogeneous (see :func:`plain_parts`).

    The walls and the ceiling are paint (:mod:`..material_priors`, ``paint``): a homogeneous one's base colour
    keeps its luminance in ``paint.albedo`` and the photo's hue within ``paint.hue_range`` (:func:`paint_colour`), a
    procedural one's mean map luminance is pulled into it by a loss term (:meth:`paint_penalty`; made plain, it is
    brought into it), and every wall's and the ceiling's specular stays at most ``paint.max_specular``. Without
    this the fit may match the photo with black walls that mirror the lights, a scene that falls apart once a
    light moves."""

    def __init__(
        self,
        parts: list[PartAppearance],
        lights: Lights,
        library: Any,
        *,
        map_size: int,
        radiance_range: float,
        colour_range: float,
        paint: PaintPrior,
        free: set[str] | None = None,
    ) -> None:
        self.parts = parts
        self.lights = lights
        self.library = library
        self.map_size = map_size
        self.free = {p.part for p in parts} if free is None else set(free)
        self.plain: set[str] = set()
        self.log_range = float(np.log(max(radiance_range, 1.0 + 1e-6)))
        self.log_colour_range = float(np.log(max(colour_range, 1.0 + 1e-6)))
        self.paint = paint
        self.theta: dict[str, torch.Tensor] = {}
        self.chroma: dict[str, torch.Tensor] = {}
        """Initial chromaticity of each optimised homogeneous wall and the ceiling (see :func:`paint_colour`)."""
        self.group: dict[str, str] = {}
        for p in self.optimised():
            if p.kind == "procedural":
                material = library.material(p.material)
                graph = {k: v for k, v in p.params.items() if not material.bounds[k].fixed}
                for key, value in (material.unconstrained(graph) if graph else {}).items():
                    self._add(f"{p.part}/graph/{key}", value.detach().clone().float(), "graph")
            elif painted(p.part):
                low, high = self.paint.albedo
                start = float(np.clip(np.dot(p.base_color, LUMINANCE), low, high))
                colour = np.maximum(np.asarray(p.base_color, np.float64), 1e-6)
                self.chroma[p.part] = torch.tensor(colour / colour.max(), dtype=torch.float32)
                self._add(f"{p.part}/base_color", torch.zeros(3), "base_color")
                self._add(f"{p.part}/lightness", _logit((start - low) / (high - low)), "base_color")
                self._add(f"{p.part}/roughness", _logit(p.roughness), "roughness")
            else:
                self._add(f"{p.part}/base_color", torch.cat([_logit(c) for c in p.base_color]), "base_color")
                self._add(f"{p.part}/roughness", _logit(p.roughness), "roughness")
            self._add(f"{p.part}/specular", _logit(p.specular / self._max_specular(p.part)), "specular")
        for light in lights.lights:
            self._add(f"{light.name}/radiance", torch.zeros(1), "radiance")
        if lights.lights:
            self._add("lights/colour", torch.zeros(3), "light_colour")

    def optimised(self) -> list[PartAppearance]:
        return [p for p in self.parts if p.part in self.free]

    def _max_specular(self, part: str) -> float:
        return self.paint.max_specular if painted(part) else 1.0

    def paint_penalty(self, inputs: dict[str, dict[str, torch.Tensor]]) -> torch.Tensor | None:
        """The paint prior on procedural walls and ceilings (their graphs' colours are bounded per graph, not by
        luminance): the squared relative distance of each one's mean map luminance outside ``paint.albedo``,
        summed; ``None`` when no such part is optimised."""
        low, high = self.paint.albedo
        terms = []
        for p in self.optimised():
            if p.kind == "procedural" and painted(p.part):
                luminance = (inputs["base_color"][p.part] @ torch.tensor(LUMINANCE)).mean()
                terms.append(
                    (torch.relu(low - luminance) / max(low, 1e-6)) ** 2
                    + (torch.relu(luminance - high) / max(1 - high, 1e-6)) ** 2
                )
        return torch.stack(terms).sum() if terms else None

    def _add(self, name: str, value: torch.Tensor, group: str) -> None:
        self.theta[name] = value.requires_grad_(True)
        self.group[name] = group

    def _graph(self, part: str) -> dict[str, torch.Tensor]:
        prefix = f"{part}/graph/"
        return {k[len(prefix) :]: v for k, v in self.theta.items() if k.startswith(prefix)}

    def inputs(self) -> dict[str, dict[str, torch.Tensor]]:
        """Keyword arguments of ``render_rgb`` for the current parameters (the optimised parts and the lights)."""
        base, rough, spec = {}, {}, {}
        for p in self.optimised():
            spec[p.part] = self._max_specular(p.part) * torch.sigmoid(self.theta[f"{p.part}/specular"])
            if p.kind == "procedural":
                base[p.part], rough[p.part] = graph_maps(self.library, p, self.map_size, self._graph(p.part))
                if p.part in self.plain:
                    base[p.part], rough[p.part] = (
                        m.mean((0, 1), keepdim=True).expand_as(m).contiguous() for m in (base[p.part], rough[p.part])
                    )
            elif painted(p.part):
                base[p.part] = paint_colour(
                    self.theta[f"{p.part}/base_color"],
                    self.theta[f"{p.part}/lightness"],
                    self.chroma[p.part],
                    self.paint,
                )
                rough[p.part] = torch.sigmoid(self.theta[f"{p.part}/roughness"])
            else:
                base[p.part] = torch.sigmoid(self.theta[f"{p.part}/base_color"])
                rough[p.part] = torch.sigmoid(self.theta[f"{p.part}/roughness"])
        radiance = {}
        if self.lights.lights:
            v = torch.tanh(self.theta["lights/colour"])
            colour = torch.exp(self.log_colour_range * (v - v.mean()))  # a tint, not a brightness
            radiance = {
                l.name: torch.tensor(l.radiance, dtype=torch.float32)
                * colour
                * torch.exp(self.log_range * torch.tanh(self.theta[f"{l.name}/radiance"]))
                for l in self.lights.lights
            }
        return {"base_color": base, "roughness": rough, "specular": spec, "radiance": radiance}

    def result(self) -> tuple[list[PartAppearance], dict[str, tuple[float, float, float]]]:
        """The parts and radiances at the current parameters."""
        with torch.no_grad():
            values = self.inputs()
            parts = []
            for p in self.parts:
                if p.part not in self.free:
                    parts.append(p)
                    continue
                base = values["base_color"][p.part]
                mean_base = tuple(float(v) for v in base.reshape(-1, 3).mean(0))
                common: dict[str, Any] = dict(
                    base_color=mean_base,
                    roughness=float(values["roughness"][p.part].mean()),
                    specular=float(values["specular"][p.part]),
                )
                if p.part in self.plain:
                    parts.append(within_paint(PartAppearance(p.part, "homogeneous", **common), self.paint))
                    continue
                if p.kind == "procedural":
                    constrained = self.library.material(p.material).values(self._graph(p.part))
                    common["params"] = {k: v.tolist() for k, v in constrained.items()}
                parts.append(replace(p, **common))
            radiance = {name: vec3(v) for name, v in values["radiance"].items()}
        return parts, radiance


def fit_appearance(
    ctx: StageContext,
    image: Image,
    camera: Camera,
    room: RoomBox,
    placements: Placements,
    materials: MaterialAssignment,
    lights: Lights,
) -> dict[str, Any]:
    """Optimise all materials and light radiances jointly (§4.4, eq. 4) by path tracing (``renderer``, its
    ``max_depth`` bounces) at ``render_width``:

    ``w_image · L1(R↓, I↓) + w_colour · mean_i L1(μ(R on M_i), μ(I on M_i))
    + w_texture · mean_crops d(T(R crop), T(I crop)) + w_paint · P``

    with ↓ an area down-sampling by ``downsample``, ``M_i`` part i's sampled mask: the rendered part's pixels
    that ``assign_materials`` measured its colour on (the assignment's ``samples``; the whole rendered mask
    when that leaves fewer than ``min_region_px``): the paper's mean over the whole mask also averages the
    clutter in front of a wall and pulls the wall towards a colour it does not have. The paper's ``C_i`` is the
    part's median photo colour; here it is the photo's mean over the same pixels as the render's mean
    (:func:`eq4_targets`), so the photo itself scores zero on every term. ``T`` is the ``texture`` descriptor
    on the crop pairs, and ``P`` the paint prior on procedural walls and ceilings
    (:meth:`AppearanceModel.paint_penalty`). All terms compare sRGB values; the down-sampled images and the
    means are averaged in linear light first. The ``optimizer`` moves the parameters of :class:`AppearanceModel`
    of the parts with a colour term (:func:`eq4_targets`), at ``learning_rates`` per group.

    The init and final renders (``final_spp``) are pictures, not loss terms: the ``denoiser`` cleans them with
    the scene's albedo and normal. The log's summary has their RMSE (1/8 size), SSIM and ꟻLIP against the photo
    (``*_noisy``: the same before denoising; ``denoiser``: what ran), and LPIPS when its weights are installed
    (:mod:`psdr_room_core.method.lpips`).
    """
    settings = ctx.settings(FitAppearance)
    library, descriptor, renderer = (
        ctx.impl("material_graph", MaterialGraph),
        ctx.impl("texture", TextureDescriptor),
        ctx.impl("renderer", Renderer),
    )
    # setup: the scene to render, what each term compares against, and the parameters
    c2w = np.asarray(room.camera_to_world)
    width = min(settings.render_width, camera.width)
    emitting = {light.part for light in lights.lights if light.part}  # lamp parts are lights now
    parts = [within_paint(p, settings.paint) for p in initial_parts(materials, library) if p.part not in emitting]
    meshes = part_meshes(room, placements)
    scene = build_scene(meshes, parts, lights.lights, lights.fixtures, library, settings.map_size)
    geometry = scene.renderer(renderer, camera, c2w, width)
    targets = eq4_targets(image, camera, c2w, materials, meshes, scene.meshes, renderer, descriptor, settings, width)
    # Parts the camera does not see keep their initial material: only indirect light shows them, and it
    # trades off freely against the lights' radiance.
    ranges = {"radiance_range": settings.radiance_range, "colour_range": settings.colour_range}
    model = AppearanceModel(
        parts, lights, library, map_size=settings.map_size, free=targets.seen, paint=settings.paint, **ranges
    )
    # optimise eq. 4
    loss = eq4_loss(model, geometry, targets, descriptor, settings)
    rates = {name: getattr(settings.learning_rates, group) for name, group in model.group.items()}
    optimizer, progress = ctx.impl("optimizer", Optimizer), partial(ctx.progress, total=settings.iterations)
    history = untimed(
        optimizer.minimize(model.theta, rates, loss, settings.iterations, progress, stop=settings.convergence),
        ctx.timings,
    )
    # decide: the final pictures, and which patterned parts read better plain
    final_spp, denoiser = settings.final_spp, ctx.impl("denoiser", Denoiser)
    with torch.no_grad():
        initial = AppearanceModel(
            parts, lights, library, map_size=model.map_size, free=targets.seen, paint=settings.paint, **ranges
        ).inputs()
        start = picture(geometry, denoiser, initial, final_spp, 10**6)
        final = picture(geometry, denoiser, model.inputs(), final_spp, 10**6 + 1)
        if settings.plain_check:
            masks = {name: targets.ids == k for k, name in enumerate(targets.names)}
            final = plain_parts(model, geometry, denoiser, final_spp, targets.photo, final, masks)
    # report
    return appearance_report(model, history, targets, start, final, denoiser)


@dataclass
class Eq4Targets:
    """What eq. 4's terms compare the render against, at the fit's resolution."""

    photo: np.ndarray
    """The photo, sRGB [H, W, 3] in 0..1."""
    target: torch.Tensor
    target_small: torch.Tensor
    """The photo area-downsampled by ``downsample`` (averaged in linear light)."""
    regions: list[tuple[torch.Tensor, torch.Tensor]]
    """(sampled mask M_i, the photo's colour on it: its linear mean, sRGB-encoded) of each seen part large enough
    for the colour term."""
    crops: list[tuple[list[int], torch.Tensor]]
    """(rectangle, texture descriptor of the photo's crop)."""
    ids: np.ndarray
    """The rendered part index of each pixel."""
    names: list[str]
    """Part names in the order of ``ids``."""
    seen: set[str]
    """Parts the fit may change: those the camera sees enough of."""


def eq4_targets(
    image: Image,
    camera: Camera,
    c2w: np.ndarray,
    materials: MaterialAssignment,
    meshes: dict[str, Any],
    scene_meshes: dict[str, Any],
    renderer: Renderer,
    descriptor: TextureDescriptor,
    settings: FitAppearance,
    width: int,
) -> Eq4Targets:
    """The photo at the render's size, the parts' colour regions (the rendered part's pixels that
    ``assign_materials`` measured its colour on; the whole rendered mask when that leaves fewer than
    ``min_region_px``) with the photo's colour there, and the crop pairs' photo descriptors.

    The colour is the photo's mean over the region, averaged in linear light and encoded, the statistic the
    colour term takes of the render, not the assignment's median: a median of a lit wall (bright near a lamp,
    darker below) is not the mean of the same pixels, so the paper's ``C_i`` asks the render for a mean the photo
    does not have, and the fit buys it by re-weighting the lights against the image term (on the shared photos
    the fit then lost RMSE on two and SSIM on one)."""
    ids, _ = render_part_ids(renderer, camera.resized(width), c2w, meshes, width)
    height = ids.shape[0]
    photo = cv2.resize(np.asarray(image.rgb, np.float32), (width, height), interpolation=cv2.INTER_AREA)
    target = torch.from_numpy(photo)
    linear = srgb_to_linear(target)
    names = list(meshes)
    samples = (
        cv2.resize(materials.samples, (width, height), interpolation=cv2.INTER_NEAREST)
        if materials.samples is not None
        else np.full(ids.shape, -1, np.int16)
    )
    regions, seen = [], set()
    min_px = settings.min_region_px
    for k, p in enumerate(materials.parts):
        if p.part in names and p.part in scene_meshes:
            rendered = ids == names.index(p.part)
            if int(rendered.sum()) >= min_px:
                sampled = rendered & (samples == k)  # where the part's colour was measured: not the clutter in front
                mask = torch.from_numpy(sampled if int(sampled.sum()) >= min_px else rendered)
                regions.append((mask, mean_colour(linear, mask)))
                seen.add(p.part)
    scale = width / camera.width
    crops = []
    for p in materials.parts:
        for rect in p.crops[: settings.crops_per_part]:
            r = squarish([int(round(v * scale)) for v in rect], settings.max_crop_aspect)
            if r[2] - r[0] >= 8 and r[3] - r[1] >= 8:
                with torch.no_grad():
                    crops.append((r, descriptor.describe(target[r[1] : r[3], r[0] : r[2]].permute(2, 0, 1))))
    target_small = linear_to_srgb(downsampled(linear, settings.downsample))
    return Eq4Targets(photo, target, target_small, regions, crops, ids, names, seen)


def eq4_loss(
    model: AppearanceModel, geometry: Any, targets: Eq4Targets, descriptor: TextureDescriptor, settings: FitAppearance
) -> Callable[[int], tuple[torch.Tensor, dict[str, float]]]:
    """Eq. 4 for the optimizer: the weighted image, colour, texture and paint terms of a render of the model's
    current parameters (``spp`` primal and ``grad_spp`` gradient samples per pixel)."""
    weights = asdict(settings.weights)
    spp, grad_spp = settings.spp, settings.grad_spp

    def loss(iteration: int) -> tuple[torch.Tensor, dict[str, float]]:
        inputs = model.inputs()
        render = geometry.render_rgb(**inputs, iteration=iteration, spp=spp, grad_spp=grad_spp)
        parts = eq4_terms(render, targets, descriptor, settings.downsample)
        paint_term = model.paint_penalty(inputs)
        if paint_term is not None:
            parts["paint"] = paint_term
        total = sum(weights[k] * v for k, v in parts.items())
        return total, {k: float(v.detach()) for k, v in parts.items()}

    return loss


def eq4_terms(
    linear: torch.Tensor, targets: Eq4Targets, descriptor: TextureDescriptor, factor: int
) -> dict[str, torch.Tensor]:
    """Eq. 4's image, colour and texture terms (unweighted) of a linear render [H, W, 3] at the fit's size
    (``factor``: the image term's down-sampling). Averages (the 1/8 image, a part's mean) are taken on linear
    radiance, then encoded: the sRGB curve is concave, so averaging encoded noisy samples reads darker than the
    light is, and the fit brightens the scene to make up for its own Monte-Carlo noise."""
    srgb = linear_to_srgb(linear)
    out = {"image": (linear_to_srgb(downsampled(linear, factor)) - targets.target_small).abs().mean()}
    if targets.regions:
        out["colour"] = torch.stack([(mean_colour(linear, m) - c).abs().mean() for m, c in targets.regions]).mean()
    if targets.crops:
        out["texture"] = torch.stack(
            [
                descriptor.distance(descriptor.describe(srgb[y0:y1, x0:x1].permute(2, 0, 1)), d).reshape(())
                for (x0, y0, x1, y1), d in targets.crops
            ]
        ).mean()
    return out


def mean_colour(linear: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """The colour term's statistic of an image [H, W, 3] on a mask [H, W]: the linear mean, sRGB-encoded (taken
    alike of the render and of the photo, so the photo scores zero on it)."""
    return linear_to_srgb(linear[mask].mean(0))


def appearance_report(
    model: AppearanceModel,
    history: list[dict[str, float]],
    targets: Eq4Targets,
    start: tuple[np.ndarray, np.ndarray],
    final: tuple[np.ndarray, np.ndarray],
    denoiser: Denoiser,
) -> dict[str, Any]:
    """The stage's outputs: the fitted appearance, and a log whose summary compares the (noisy, denoised) initial
    and final renders with the photo, with the photo | init | final strip, the crop pairs and the loss curves."""
    photo = targets.photo
    (start_noisy, start_clean), (final_noisy, final_clean) = start, final
    parts, radiance = model.result()
    metrics = {
        **_agreement(start_clean, final_clean, photo),
        **_agreement(start_noisy, final_noisy, photo, "_noisy"),
        "denoiser": denoiser.describe(),
        "iterations": len(history),
        "fitted_parts": sorted(targets.seen),
        "plain_parts": sorted(model.plain),
    }
    scorer = lpips.installed()
    if scorer is not None:  # the paper's perceptual metric, only with its real weights
        metrics.update(lpips_init=scorer(start_clean, photo), lpips=scorer(final_clean, photo))
    log.info(
        "fit_appearance: RMSE %.4f -> %.4f, SSIM %.3f -> %.3f, FLIP %.3f -> %.3f (denoiser: %s)",
        metrics["rmse_init"],
        metrics["rmse"],
        metrics["ssim_init"],
        metrics["ssim"],
        metrics["flip_init"],
        metrics["flip"],
        metrics["denoiser"],
    )
    curves: dict[str, list[float]] = {
        k: [h[k] for h in history]
        for k in ("loss", "image", "colour", "texture", "paint")
        if history and k in history[0]
    }
    images = {"photo_init_final": np.hstack([to_uint8(photo), to_uint8(start_clean), to_uint8(final_clean)])}
    if targets.crops:
        images["crop_pairs"] = crop_pairs(photo, start_clean, final_clean, [c[0] for c in targets.crops])
    if curves:
        images["loss"] = plot_curves(curves, title="fit_appearance (eq. 4)")
    appearance = SceneAppearance(parts=parts, radiance=radiance, images={"render": to_uint8(final_clean)})
    return {"appearance": appearance, "log": OptimizationLog(history=history, images=images, summary=metrics)}


def plain_parts(
    model: AppearanceModel,
    geometry: Any,
    denoiser: Any,
    spp: int,
    photo: np.ndarray,
    final: tuple[np.ndarray, np.ndarray],
    masks: dict[str, np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """Plain stays plain, judged after the fit: each fitted procedural part is drawn once more with its maps'
    mean colour and roughness, and becomes homogeneous (``model.plain``) where that render's SSIM against the
    photo, averaged over the part's own pixels, is higher than the patterned one's. A pattern the photo does not
    show (a stone graph on a blurred wall, a weave fitted to clutter) costs structure that no colour term sees.
    Returns the (noisy, denoised) sRGB final render of the chosen materials."""
    candidates = {p.part for p in model.optimised() if p.kind == "procedural" and masks.get(p.part, np.zeros(1)).any()}
    if not candidates:
        return final
    model.plain = set(candidates)
    plain = picture(geometry, denoiser, model.inputs(), spp, 10**6 + 2)
    patterned_ssim, plain_ssim = ssim_map(final[1], photo), ssim_map(plain[1], photo)
    scores = {
        part: (float(patterned_ssim[masks[part]].mean()), float(plain_ssim[masks[part]].mean()))
        for part in sorted(candidates)
    }
    chosen = {part for part, (patterned, flat) in scores.items() if flat > patterned}
    for part, (patterned, flat) in scores.items():
        log.info(
            "fit_appearance: %s %s (SSIM on its pixels: pattern %.3f, plain %.3f)",
            part,
            "made plain" if part in chosen else "keeps its pattern",
            patterned,
            flat,
        )
    model.plain = chosen
    if chosen == candidates:
        return plain
    if not chosen:
        return final
    return picture(geometry, denoiser, model.inputs(), spp, 10**6 + 3)


def picture(geometry: Any, denoiser: Any, inputs: dict[str, Any], spp: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(noisy, denoised) sRGB [H, W, 3] of :func:`~psdr_room_core.method.rgb_scene.finished_render` (``seed``: its
    sample stream, as ``iteration``)."""
    noisy, clean = finished_render(geometry, denoiser, inputs, spp, seed)
    return linear_to_srgb(noisy), linear_to_srgb(clean)


def _agreement(start: np.ndarray, final: np.ndarray, photo: np.ndarray, suffix: str = "") -> dict[str, float]:
    """RMSE (1/8 size), SSIM and FLIP of the initial and final sRGB renders against the photo."""
    out = {}
    for name, metric in (("rmse", rmse), ("ssim", ssim), ("flip", flip)):
        out[f"{name}_init{suffix}"], out[f"{name}{suffix}"] = metric(start, photo), metric(final, photo)
    return out


def squarish(rect: list[int], max_aspect: float) -> list[int]:
    """The centred part of a crop window whose long side is at most ``max_aspect`` times its short side (the
    descriptor resizes the short side to a fixed size, so long thin crops cost in proportion to their aspect)."""
    x0, y0, x1, y1 = rect
    w, h = x1 - x0, y1 - y0
    if w > max_aspect * h:
        cut = int(round(max_aspect * h))
        x0 += (w - cut) // 2
        x1 = x0 + cut
    elif h > max_aspect * w:
        cut = int(round(max_aspect * w))
        y0 += (h - cut) // 2
        y1 = y0 + cut
    return [x0, y0, x1, y1]
