"""Fit a box room to a photo: Manhattan frame, line-segment orientation map, optional label evidence."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from psdr_room_core.libraries.vanishing_points import VanishingPointParams, estimate_camera, line_segments
from psdr_room_core.method.artifacts import Camera, Detections, Image, Panoptic

from . import box
from .manhattan import ManhattanFrame, frame_from_vanishing_points, looking_down
from .orientation import orientation_map, segment_families
from .settings import LayoutParams

log = logging.getLogger("psdr_room")


@dataclass(frozen=True)
class Layout:
    """A fitted box room seen from the camera."""

    frame: ManhattanFrame
    box: np.ndarray
    """(x0, x1, ceiling, z0, z1) in camera heights (see :mod:`.box`)."""
    score: float

    def trace(self, camera: Camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """Surface labels (H, W) int8 and z-depth in camera heights (H, W) on a ``width`` x ``height`` grid."""
        rays = self.frame.rays(camera, width, height).reshape(-1, 3)
        labels, t = box.trace(rays, self.box[None])
        return labels[0].reshape(height, width), t[0].reshape(height, width)


def manhattan_frame(image: Image, camera: Camera, lines: VanishingPointParams) -> ManhattanFrame:
    """The room frame from the camera's vanishing points, estimated from the photo (with ``lines``) when ``fov``
    gave none."""
    vps = camera.vanishing_points
    if len(vps) < 2:
        vps = estimate_camera(image.rgb, lines).vanishing_points
    return frame_from_vanishing_points(camera, vps)


def _grid_shape(image: Image, side: int) -> tuple[int, int]:
    zoom = side / max(image.width, image.height)
    return max(8, round(image.height * zoom)), max(8, round(image.width * zoom))


def _clutter_weights(detections: Detections, image: Image, shape: tuple[int, int], weight: float) -> np.ndarray:
    weights = np.ones(shape, dtype=np.float32)
    sy, sx = shape[0] / image.height, shape[1] / image.width
    for d in detections.items:
        x0, y0, x1, y1 = d.box
        weights[int(y0 * sy) : int(np.ceil(y1 * sy)), int(x0 * sx) : int(np.ceil(x1 * sx))] = weight
    return weights


def floor_colour_region(image: Image, below: np.ndarray, band: np.ndarray, tolerance: float) -> np.ndarray:
    """(H, W) bool on the grid of ``below`` (pixels under the horizon): the 4-connected region of ``band``
    pixels and their neighbours whose blurred CIELAB colour lies within ``tolerance`` of the band's median
    (lightness differences counted half: light falls off across a floor)."""
    height, width = below.shape
    small = cv2.GaussianBlur(cv2.resize(image.to_uint8(), (width, height), interpolation=cv2.INTER_AREA), (0, 0), 1.5)
    lab = cv2.cvtColor(small, cv2.COLOR_RGB2LAB).astype(np.float32)
    seeds = band & below
    if not seeds.any():
        return np.zeros_like(below)
    difference = (lab - np.median(lab[seeds], axis=0)) * np.array([0.5, 1.0, 1.0], np.float32)
    close = (np.linalg.norm(difference, axis=-1) < tolerance) & below
    _, component = cv2.connectedComponents(close.astype(np.uint8), connectivity=4)
    joined = np.unique(component[seeds & close])
    return np.isin(component, joined[joined > 0])


def _floor_prior(
    rays: np.ndarray, detections: Detections | None, image: Image, band: float, colour_tolerance: float
) -> np.ndarray:
    """(H, W) 1 where the floor is likely, below the horizon: the bottom ``band`` of rows, the bottom edges of
    object boxes and (``colour_tolerance`` > 0) the band's colour running up from it
    (:func:`floor_colour_region`)."""
    height, width = rays.shape[:2]
    prior = np.zeros((height, width), dtype=np.float32)
    prior[height - max(1, round(band * height)) :] = 1.0
    if colour_tolerance > 0:
        prior[floor_colour_region(image, rays[..., 1] < 0, prior > 0, colour_tolerance)] = 1.0
    sy, sx = height / image.height, width / image.width
    for d in detections.items if detections is not None else []:
        x0, _, x1, y1 = d.box
        row = min(height - 1, int(y1 * sy))
        prior[max(0, row - 1) : row + 1, int(x0 * sx) : int(np.ceil(x1 * sx))] = 1.0
    return prior * (rays[..., 1] < 0)


def _room_labels(panoptic: Panoptic, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, int]:
    """Per grid pixel: 0 none / 1 wall / 2 floor / 3 ceiling, the wall segment index, the number of walls.

    A wall segment labelled with a box surface's name (``wall_x0``: a layout's) lies on one wall and gets an
    index; any other wall segment (a network's "wall", one for every wall it sees), window or door may lie on
    any wall (index -1)."""
    ids = cv2.resize(panoptic.ids, (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST).ravel()
    room = np.zeros(ids.shape, dtype=np.int64)
    wall_index = np.full(ids.shape, -1, dtype=np.int64)
    planes = [s for s in panoptic.segments if s.category == "wall" and s.label in box.SURFACES]
    for i, s in enumerate(planes):
        wall_index[ids == s.id] = i
    for s in panoptic.segments:
        if s.category in ("wall", "window", "door", "floor", "ceiling"):
            room[ids == s.id] = {"floor": 2, "ceiling": 3}.get(s.category, 1)
    return room, wall_index, len(planes)


def fit_layout(
    image: Image,
    camera: Camera,
    params: LayoutParams,
    detections: Detections | None = None,
    panoptic: Panoptic | None = None,
) -> Layout:
    """The box room that best explains the photo's line orientations (and ``panoptic``'s room labels).

    When the box fitted upright shows no floor, the photo may look steeply down at one (a tiled floor's
    lines are a wall's seen from level): the frame with the axis nearest the optical axis as up
    (:func:`.manhattan.looking_down`) is fitted too, and the better-scoring layout wins. Both are scored out
    of the larger of their evidence totals: the lines are the same in either frame, and what differs is the
    floor prior below each frame's horizon, which a floor filling the photo earns and a wall cannot use.
    """
    frame = manhattan_frame(image, camera, params.lines)
    if detections is not None:
        detections = Detections(
            items=[d for d in detections.items if d.score >= params.box_score], source=detections.source
        )
    evidence = _evidence(frame, image, camera, params, detections)
    layout = _fit_in_frame(frame, evidence, image, camera, params, panoptic, float(evidence.sum()))
    shape = _grid_shape(image, params.grid_side)
    labels, _ = layout.trace(camera, shape[1], shape[0])
    down = looking_down(camera, frame, params.look_down_deg) if params.look_down_deg < 90 else None
    if down is not None and (labels == box.FLOOR).mean() < params.min_floor:
        steep_evidence = _evidence(down, image, camera, params, detections)
        total = max(float(evidence.sum()), float(steep_evidence.sum()))
        if total > evidence.sum():
            layout = _fit_in_frame(frame, evidence, image, camera, params, panoptic, total)
        steep = _fit_in_frame(down, steep_evidence, image, camera, params, panoptic, total)
        log.info(
            "layout: no floor in the upright fit (score %.3f); looking %.0f° down at a floor scores %.3f",
            layout.score,
            np.degrees(np.arcsin(-down.rotation[2, 1])),
            steep.score,
        )
        if steep.score > layout.score:
            layout = steep
    return layout


def _evidence(
    frame: ManhattanFrame, image: Image, camera: Camera, params: LayoutParams, detections: Detections | None
) -> np.ndarray:
    """(3, N) orientation evidence on the grid in ``frame``: the lines' sweeps (weighted down inside object boxes)
    and the floor prior below the frame's horizon."""
    shape = _grid_shape(image, params.grid_side)
    zoom = np.diag([shape[1] / image.width, shape[0] / image.height, 1.0])
    segments = line_segments(image.rgb, params.lines) * np.tile(np.diag(zoom)[:2], 2)
    vps = frame.vanishing_points @ zoom.T
    families = segment_families(segments, vps, params.family_tolerance_deg)
    reach = params.sweep_fraction * float(np.hypot(*shape))
    evidence = orientation_map(segments, families, vps, shape, reach)
    if detections is not None:
        evidence *= _clutter_weights(detections, image, shape, params.clutter_weight)[None]
    rays = frame.rays(camera, shape[1], shape[0])
    evidence[1] = np.maximum(
        evidence[1], params.floor_prior * _floor_prior(rays, detections, image, params.floor_band, params.floor_colour)
    )
    return evidence.reshape(3, -1)


def _fit_in_frame(
    frame: ManhattanFrame,
    evidence: np.ndarray,
    image: Image,
    camera: Camera,
    params: LayoutParams,
    panoptic: Panoptic | None,
    total: float,
) -> Layout:
    """The best box in ``frame`` for ``evidence``, its orientation agreement counted out of ``total``."""
    shape = _grid_shape(image, params.grid_side)
    rays = frame.rays(camera, shape[1], shape[0]).reshape(-1, 3)
    labelled = panoptic is not None and any(s.category in ("wall", "floor", "ceiling") for s in panoptic.segments)
    if panoptic is not None and labelled:
        room, wall_index, n_walls = _room_labels(panoptic, shape)

    def score(boxes: np.ndarray) -> np.ndarray:
        labels, _ = box.trace(rays, boxes)
        agreement = box.orientation_score(labels, evidence, total)
        if labelled:
            agreement = agreement + params.label_weight * box.label_score(labels, room, wall_index, n_walls)
        return agreement

    best, best_score = box.search(
        score, params.search, np.random.default_rng(params.seed), params.n_random, params.n_starts
    )
    return Layout(frame=frame, box=best, score=best_score)
