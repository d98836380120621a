"""Room stage (paper §4.2): a room box initialised from the segmented point cloud, then refined by
differentiable rendering of its wall/floor/ceiling masks and depth.

Initialisation fits the floor plane by RANSAC, takes the height from the highest ceiling point (or 1.2×
the highest point when no ceiling is visible), and aligns the box's yaw and extent with RANSAC wall
planes (:mod:`psdr_room_core.method.room_box`). Refinement minimises eq. 2 (:func:`room_fit`).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import torch

from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError

from ..artifacts import (
    ROOM_CATEGORIES,
    Camera,
    DepthMap,
    Image,
    OptimizationLog,
    Panoptic,
    PointCloud,
    RoomBox,
    rotation_y,
)
from ..capabilities import Optimizer, Renderer
from ..convergence import untimed
from ..geometry import quad_mesh
from ..guesses import FLOOR_GUESSES
from ..rgb_scene import room_quad_indices, room_quads
from ..room_box import RoomInitParams, box_iou_3d, init_room_box
from ..visualize import plot_curves, room_edges_overlay, segment_overlay
from .settings import RoomFit

log = logging.getLogger("psdr_room")


def room_init(ctx: StageContext, cloud: PointCloud) -> RoomBox:
    """Fit the initial room box and the camera pose in the room's frame (its settings:
    :class:`~psdr_room_core.method.room_box.RoomInitParams`)."""
    params = ctx.settings(RoomInitParams)
    points = {c: cloud.category_points(c).astype(np.float64) for c in ROOM_CATEGORIES}
    others = [s.id for s in cloud.segments if s.category not in ROOM_CATEGORIES]
    points["objects"] = cloud.points[np.isin(cloud.segment, others)].astype(np.float64)
    try:
        fit = init_room_box(points, params, seed=ctx.seed)
    except ValueError as exc:
        raise PsdrRoomError(str(exc)) from None
    if fit.floor_source != "floor":
        log.warning(
            "room_init: no floor in view; guessed: the floor plane from %s (camera %.2f above it)",
            FLOOR_GUESSES[fit.floor_source],
            fit.camera_height,
        )
    return RoomBox(
        camera_to_world=fit.camera_to_world,
        center=fit.center,
        half_size=fit.half_size,
        yaw=fit.yaw,
        ceiling_visible=fit.ceiling_visible,
        extra={
            "camera_height": float(fit.camera_height),
            "floor_source": fit.floor_source,
            "floor_plane_camera": np.asarray(fit.floor_plane).tolist(),
            "wall_planes_camera": [np.asarray(p).tolist() for p in fit.wall_planes],
        },
    )


ROOM_PARTS = {"wall": 0, "floor": 1, "ceiling": 2}
"""Rendered part index of each room surface (the four walls share one mask, as in eq. 2)."""
MASK_CATEGORIES = {"wall": ("wall", "door", "window"), "floor": ("floor",), "ceiling": ("ceiling",)}
"""Target categories of each part's mask: doors and windows are openings in a wall's plane."""
DEPTH_CATEGORIES = ("wall", "floor", "ceiling")
"""Categories whose depth is the box's depth (not what is seen through a door or window)."""


@dataclass(frozen=True)
class RoomTargets:
    """The target maps of eq. 2 at render resolution (area-filtered, so edges are fractional)."""

    masks: np.ndarray
    """[3,h,w] coverage of wall / floor / ceiling in the segmentation."""
    visible: np.ndarray
    """[h,w] fraction of the pixel where the photo shows a room surface: the IoU is computed there only,
    since objects hide parts of the box's sides (the target masks are smaller than the rendered sides)."""
    depth: np.ndarray
    """[h,w] mean depth of the room-surface pixels with valid depth."""
    depth_weight: np.ndarray
    """[h,w] fraction of the pixel with such depth."""


def room_targets(panoptic: Panoptic, depth: DepthMap, size: tuple[int, int]) -> RoomTargets:
    """Downsample the segmentation and depth to the render size ``(width, height)``."""

    def area(x: np.ndarray) -> np.ndarray:
        return cv2.resize(x.astype(np.float32), size, interpolation=cv2.INTER_AREA)

    masks = np.stack(
        [
            area(np.isin(panoptic.ids, [s.id for s in panoptic.segments if s.category in cats]))
            for cats in MASK_CATEGORIES.values()
        ]
    )
    surface = np.zeros(panoptic.ids.shape, bool)
    for category in DEPTH_CATEGORIES:
        surface |= panoptic.mask(category)
    surface &= depth.valid
    weight = area(surface)
    mean_depth = np.where(weight > 0, area(np.where(surface, depth.depth, 0.0)) / np.maximum(weight, 1e-6), 0.0)
    return RoomTargets(
        masks=masks, visible=np.clip(masks.sum(0), 0, 1), depth=mean_depth.astype(np.float32), depth_weight=weight
    )


def box_vertices(
    room: RoomBox, theta: dict[str, torch.Tensor], scale: float, keep_floor: bool
) -> dict[str, torch.Tensor]:
    """World quads of the box moved by ``theta``: yaw offset, translation in units of ``scale``, per-axis
    log-scale, and a tilt of the whole box about the camera centre (the floor normal from ``room_init``
    may be off by a few degrees; tilting about the camera keeps the camera's height above the floor).

    With ``keep_floor`` the box's bottom stays on the floor plane (y = 0) found by ``room_init``: the height
    scales upward and the vertical translation is unused. Masks are unchanged by scaling the whole room about
    the camera; a fixed floor (the camera's height above it comes from many depth points) removes that
    ambiguity, which the depth term alone pins down only weakly.
    """
    signs = torch.tensor([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=torch.float32) * 2 - 1
    half = torch.as_tensor(room.half_size, dtype=torch.float32) * torch.exp(theta["log_scale"])
    yaw = float(room.yaw) + theta["yaw"]
    c, s = torch.cos(yaw), torch.sin(yaw)
    zero, one = torch.zeros_like(c), torch.ones_like(c)
    rotation = torch.stack([torch.stack([c, zero, s]), torch.stack([zero, one, zero]), torch.stack([-s, zero, c])])
    center = torch.as_tensor(room.center, dtype=torch.float32) + scale * theta["translation"]
    if keep_floor:
        center = torch.stack([center[0], half[1], center[2]])
    pivot = torch.as_tensor(np.asarray(room.camera_to_world)[:3, 3], dtype=torch.float32)
    corners = pivot + (center + (signs * half) @ rotation.T - pivot) @ tilt_rotation(theta["tilt"]).T
    return {name: corners[torch.as_tensor(index.copy())] for name, index in room_quad_indices(room).items()}


def with_focal_scale(corners: torch.Tensor, camera_to_world: np.ndarray, log_focal: torch.Tensor) -> torch.Tensor:
    """Scale camera-frame x and y of world points by exp(``log_focal``): rendering them with focal f is
    rendering the unscaled points with focal f·exp(log_focal) (u = f·x/z + c), so the field of view is
    refined without rebuilding the renderer."""
    rotation = torch.as_tensor(camera_to_world[:3, :3], dtype=torch.float32)
    origin = torch.as_tensor(camera_to_world[:3, 3], dtype=torch.float32)
    factor = torch.exp(log_focal)
    local = (corners - origin) @ rotation * torch.stack([factor, factor, torch.ones_like(factor)])
    return origin + local @ rotation.T


def tilt_rotation(tilt: torch.Tensor) -> torch.Tensor:
    """Rotation about world X then Z by the two ``tilt`` angles (radians): corrects the floor normal."""
    (cx, cz), (sx, sz) = torch.cos(tilt), torch.sin(tilt)
    zero, one = torch.zeros_like(cx), torch.ones_like(cx)
    rx = torch.stack([torch.stack([one, zero, zero]), torch.stack([zero, cx, -sx]), torch.stack([zero, sx, cx])])
    rz = torch.stack([torch.stack([cz, -sz, zero]), torch.stack([sz, cz, zero]), torch.stack([zero, zero, one])])
    return rz @ rx


def soft_iou(rendered: torch.Tensor, target: torch.Tensor, visible: torch.Tensor) -> torch.Tensor:
    """IoU of fractional masks over the visible region: Σ v·r·t / Σ v·(r + t − r·t)."""
    intersection = (visible * rendered * target).sum()
    union = (visible * (rendered + target - rendered * target)).sum()
    return intersection / union.clamp_min(1e-6)


def room_fit(
    ctx: StageContext, room: RoomBox, camera: Camera, depth: DepthMap, panoptic: Panoptic, image: Image
) -> dict[str, Any]:
    """Refine the room box (and the camera's focal length) by differentiable rendering (§4.2, eq. 2).

    Minimises ``L_box = −Σ_i IoU(M_i^r, M_i^t) + w_depth · L1(D^r, D^t)`` (:func:`box_loss`) over the box's yaw,
    translation and per-axis scale, i ∈ {wall, floor, ceiling}, with anti-aliased masks and depth from the
    ``renderer`` whose boundary terms carry gradients through the box's silhouette edges, and the ``optimizer``
    (Adam, per-parameter ``learning_rates``). Depths are normalised by the target's 98th percentile; with
    ``keep_floor`` the box stands on the floor (:func:`box_vertices`). Beyond the paper, the camera's focal
    length is refined too (``log_focal``; learning rate 0 keeps the estimated FoV): masks and depth together
    constrain it, and a FoV error otherwise bends the box.
    """
    settings = ctx.settings(RoomFit)
    # set up: the targets at the render's size, a renderer of the box's sides, and the parameters
    cam = camera.resized(settings.render_width)
    targets = room_targets(panoptic, depth, (cam.width, cam.height))
    if targets.visible.sum() < 1.0:
        raise PsdrRoomError("room_fit: the segmentation shows no wall, floor or ceiling; label them to fit the room")
    meshes = {name: quad_mesh(quad) for name, quad in room_quads(room).items()}
    parts = {name: ROOM_PARTS["wall" if name.startswith("wall") else name] for name in meshes}
    renderer = ctx.impl("renderer", Renderer).geometry(cam, np.asarray(room.camera_to_world), meshes, parts)
    theta = {
        "yaw": torch.zeros((), requires_grad=True),
        "translation": torch.zeros(3, requires_grad=True),
        "log_scale": torch.zeros(3, requires_grad=True),
        "tilt": torch.zeros(2, requires_grad=True),
        "log_focal": torch.zeros((), requires_grad=True),
    }
    # optimise eq. 2
    loss = box_loss(room, theta, renderer, targets, depth_weight=settings.depth_weight, keep_floor=settings.keep_floor)
    history = untimed(
        ctx.impl("optimizer", Optimizer).minimize(
            theta,
            dataclasses.asdict(settings.learning_rates),
            loss,
            settings.iterations,
            lambda it: ctx.progress(it, total=settings.iterations),
        ),
        ctx.timings,
    )
    # decide: the box and the camera the parameters give
    fitted_camera, fitted = fitted_room(room, camera, theta, keep_floor=settings.keep_floor, final=history[-1])
    # report
    return {
        "room": fitted,
        "camera": fitted_camera,
        "log": _fit_log(history, image, (camera, room), (fitted_camera, fitted), panoptic),
    }


def box_loss(
    room: RoomBox,
    theta: dict[str, torch.Tensor],
    renderer: Any,
    targets: RoomTargets,
    *,
    depth_weight: float,
    keep_floor: bool,
) -> Callable[[int], tuple[torch.Tensor, dict[str, float]]]:
    """Eq. 2 for the optimizer: minus the soft IoU of each rendered part's mask with its target over the visible
    region, plus ``depth_weight`` times the coverage-weighted L1 of the depth over the target's 98th percentile,
    of the box moved by ``theta`` (:func:`box_vertices`, translation in units of the box's mean half size) seen
    with the focal length scaled by ``exp(theta["log_focal"])``."""
    scale = float(np.mean(room.half_size))
    camera_to_world = np.asarray(room.camera_to_world, dtype=np.float64)
    t_masks, visible = torch.from_numpy(targets.masks), torch.from_numpy(targets.visible)
    t_depth, d_weight = torch.from_numpy(targets.depth), torch.from_numpy(targets.depth_weight)
    valid = targets.depth[targets.depth_weight > 0]
    depth_scale = float(np.percentile(valid, 98)) if valid.size else 1.0
    weight_sum = d_weight.sum().clamp_min(1e-6)

    def loss(iteration: int) -> tuple[torch.Tensor, dict[str, float]]:
        quads = box_vertices(room, theta, scale, keep_floor)
        vertices = {name: with_focal_scale(q, camera_to_world, theta["log_focal"]) for name, q in quads.items()}
        masks, weighted_depth, alpha = renderer.render(vertices, iteration)
        rendered_depth = weighted_depth / alpha.clamp_min(1e-3)  # coverage-weighted → depth of covered pixels
        ious = [soft_iou(masks[k], t_masks[k], visible) for k in range(len(ROOM_PARTS))]
        l1 = (d_weight * (rendered_depth - t_depth).abs()).sum() / weight_sum / depth_scale
        terms = {f"iou_{name}": ious[k].item() for name, k in ROOM_PARTS.items()} | {"depth_l1": l1.item()}
        return -torch.stack(ious).sum() + depth_weight * l1, terms

    return loss


def fitted_room(
    room: RoomBox, camera: Camera, theta: dict[str, torch.Tensor], *, keep_floor: bool, final: dict[str, float]
) -> tuple[Camera, RoomBox]:
    """The camera and the room box that the parameters ``theta`` of :func:`box_loss` give (``final``: the last
    loss terms, kept in the box's ``extra``)."""
    scale = float(np.mean(room.half_size))
    camera_to_world = np.asarray(room.camera_to_world, dtype=np.float64)
    with torch.no_grad():
        half_size = np.asarray(room.half_size) * np.exp(theta["log_scale"].numpy().astype(np.float64))
        center = np.asarray(room.center) + scale * theta["translation"].numpy().astype(np.float64)
        if keep_floor:
            center[1] = half_size[1]
        # the box stays upright in its frame; the tilt moves the camera instead: about itself, by R⁻¹
        tilted = camera_to_world.copy()
        tilted[:3, :3] = tilt_rotation(theta["tilt"]).numpy().astype(np.float64).T @ camera_to_world[:3, :3]
        focal = float(torch.exp(theta["log_focal"]))
        fitted_camera = dataclasses.replace(
            camera, fx=camera.fx * focal, fy=camera.fy * focal, method=f"{camera.method}+room_fit"
        )
        fitted = RoomBox(
            camera_to_world=tilted,
            center=center,
            half_size=half_size,
            yaw=float(room.yaw) + float(theta["yaw"]),
            ceiling_visible=room.ceiling_visible,
            extra={**room.extra, "room_fit": {k: float(v) for k, v in final.items()}},
        )
    return fitted_camera, fitted


def _fit_log(
    history: list[dict[str, float]],
    image: Image,
    before: tuple[Camera, RoomBox],
    after: tuple[Camera, RoomBox],
    panoptic: Panoptic,
) -> OptimizationLog:
    """Loss curves and before/after overlays (Fig. 3 of the paper) of a room fit."""
    base = segment_overlay(image.to_uint8(), panoptic, alpha=0.35)
    curves = {k: [h[k] for h in history] for k in history[0]}
    return OptimizationLog(
        history=history,
        images={
            "before": room_edges_overlay(base, *before),
            "after": room_edges_overlay(base, *after),
            "loss": plot_curves(curves, title="room_fit"),
        },
        summary={"iterations": len(history), "initial": history[0], "final": history[-1]},
    )


def room_iou(reference: RoomBox, estimate: RoomBox) -> float:
    """3D IoU of two room boxes compared through the camera: ``estimate`` is mapped into ``reference``'s
    world frame (each box's frame is its own camera's floor-based frame, which room_fit's tilt may change)."""
    to_reference = np.asarray(reference.camera_to_world) @ np.linalg.inv(np.asarray(estimate.camera_to_world))
    center = to_reference[:3, :3] @ np.asarray(estimate.center) + to_reference[:3, 3]
    x_axis = to_reference[:3, :3] @ rotation_y(float(estimate.yaw)) @ np.array([1.0, 0.0, 0.0])
    yaw = float(np.arctan2(-x_axis[2], x_axis[0]))
    return box_iou_3d(
        np.asarray(reference.center),
        np.asarray(reference.half_size),
        float(reference.yaw),
        center,
        np.asarray(estimate.half_size),
        yaw,
    )
