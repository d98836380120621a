"""Posing one database model to match one object in the photo (§4.3's yaw sweep, made occlusion-aware).

A pose is scored against the object's mask and the photo's depth at a search resolution. A pixel the model
would cover but the photo shows *something nearer* (another object, or anything in front) is hidden, not
wrong, so a cabinet behind a sofa may be whole; pixels outside the frame do not exist, so an object cut by
the image border is not shrunk into it.

For each of ``n_yaw`` rotations about the vertical axis the model is first moved and scaled so its visible
part has the mask's area, its back-projected pixels the median of the object's points across the view, and
its depth the object's where they overlap. Each hypothesis is then improved by a coarse pattern search over
shift, depth, scale and yaw (the best ``explore`` of them, or all), the best ``polish`` of those at finer
steps; the best is also turned by each of ``turns`` in place and refined, and the best of all wins. A model that
stands with its back to a wall (:mod:`~psdr_room_core.method.backs`) pays for a pose that shows the camera its back.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import cv2
import numpy as np

from .artifacts import Camera, RoomBox, rotation_y
from .backs import back_shown, wall_gap
from .image_boxes import box_iou, mask_box
from .objects import pose_matrix
from .params import SearchParams
from .seen_boxes import SeenPrior
from .silhouette import MeshCaster, Window, world_to_camera
from .sizes import SizePrior


def point_depth(camera: Camera, camera_to_world: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(H, W) float32 camera depth of the nearest world point falling in each pixel (0 where none does)."""
    local = world_to_camera(points, camera_to_world)
    local = local[local[:, 2] > 1e-6]
    u = np.floor(camera.fx * local[:, 0] / local[:, 2] + camera.cx).astype(np.int64)
    v = np.floor(camera.fy * local[:, 1] / local[:, 2] + camera.cy).astype(np.int64)
    inside = (u >= 0) & (u < camera.width) & (v >= 0) & (v < camera.height)
    nearest = np.full(camera.height * camera.width, np.inf, np.float32)
    np.minimum.at(nearest, v[inside] * camera.width + u[inside], local[inside, 2].astype(np.float32))
    nearest[~np.isfinite(nearest)] = 0.0
    return nearest.reshape(camera.height, camera.width)


@dataclass(frozen=True)
class ViewTarget:
    """What one object's pose is scored against, at the search resolution."""

    camera: Camera
    camera_to_world: np.ndarray
    mask: np.ndarray
    """(h, w) bool: the object's segment (area-resampled, majority)."""
    own_depth: np.ndarray
    """(h, w) float32 depth of the object's own points (0: none)."""
    seen_depth: np.ndarray
    """(h, w) float32 depth of the nearest point of any segment (0: none): what may hide the model."""
    points: np.ndarray
    """(N, 3) world points of the object."""
    free: np.ndarray
    """(h, w) bool: pixels the model may cover or not (its prompt box outside the mask)."""
    box: tuple[int, int, int, int] | None = None
    """The prompt box at the search resolution (x0, y0, x1, y1): the visible model should span it."""
    room: RoomBox | None = None
    """The room box the model must stay inside (None: anywhere)."""
    seen: SeenPrior | None = None
    """A network's 3D box of the object (None: none): a start of the search and a prior on the pose's depth and yaw."""

    # What every pose of every model is measured against: computed once per target, not once per model
    @cached_property
    def mask_box(self) -> Window:
        """The mask's bounding box."""
        ys, xs = np.nonzero(self.mask)
        return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1

    @cached_property
    def mask_area(self) -> int:
        return int(self.mask.sum())

    @cached_property
    def median_depth(self) -> float:
        """Median depth of the object's own points in its mask (of all its points where none falls there)."""
        own = self.own_depth[self.mask & (self.own_depth > 0)]
        return float(np.median(own if own.size else world_to_camera(self.points, self.camera_to_world)[:, 2]))

    @cached_property
    def points_median(self) -> np.ndarray:
        """(3,) per-axis median of the object's points (read-only: every model's search shares it)."""
        median = np.median(self.points, axis=0)
        median.flags.writeable = False
        return median

    @cached_property
    def points_spread(self) -> float:
        """Median distance of the object's points from :attr:`points_median`."""
        return float(np.median(np.linalg.norm(self.points - self.points_median, axis=1)))

    @classmethod
    def build(
        cls,
        camera: Camera,
        camera_to_world: np.ndarray,
        mask: np.ndarray,
        points: np.ndarray,
        scene_points: np.ndarray,
        width: int,
        max_pixels: int = 0,
        box: tuple[float, float, float, float] | None = None,
        room: RoomBox | None = None,
        seen: SeenPrior | None = None,
    ) -> ViewTarget:
        """The target of an object with ``mask`` (working-image resolution) and world ``points`` in a scene of
        world ``scene_points`` (every segment's), seen by ``camera`` resized to ``width``, or narrower where
        the mask would have more than ``max_pixels`` pixels (0: no limit; scores are relative, so a cap buys
        speed for big objects at the cost of their fine detail). Pixels of the prompt ``box`` (working-image
        pixels) outside the mask are free: the model may cover them or not. A pose reaching beyond the
        ``room`` box costs error, one far from the ``seen`` box in depth or yaw too."""
        scale = min(int(width), camera.width) / camera.width
        if max_pixels > 0:
            scale = min(scale, math.sqrt(max_pixels / max(int(mask.sum()), 1)))
        cam = camera.resized(max(16, round(camera.width * scale)))
        small = cv2.resize(mask.astype(np.float32), (cam.width, cam.height), interpolation=cv2.INTER_AREA) > 0.5
        if not small.any():  # a sliver: keep its pixels rather than lose the object
            small = cv2.resize(mask.astype(np.uint8), (cam.width, cam.height), interpolation=cv2.INTER_AREA) > 0
        c2w = np.asarray(camera_to_world, np.float64)
        free = np.zeros_like(small)
        small_box = None
        if box is not None:
            s = cam.width / camera.width
            x0, y0, x1, y1 = (int(round(v * s)) for v in box)
            small_box = (max(0, x0), max(0, y0), min(cam.width, max(x1, x0 + 1)), min(cam.height, max(y1, y0 + 1)))
            free[small_box[1] : small_box[3], small_box[0] : small_box[2]] = True
            free &= ~small
        return cls(
            cam,
            c2w,
            small,
            point_depth(cam, c2w, points),
            point_depth(cam, c2w, scene_points),
            points,
            free,
            small_box,
            room,
            seen,
        )


@dataclass(frozen=True)
class ViewFit:
    """A model posed to match an object's mask and points in one view."""

    position: np.ndarray
    yaw: float
    scale: float
    iou: float
    """IoU of the model's visible silhouette (hidden and free pixels left out) with the mask."""
    error: float
    """Mask disagreement (wrong pixels / mask pixels, hidden and free pixels not wrong) + ``depth_weight`` × the
    mean relative depth error where the model meets the object's points (+ ``box_weight`` × (1 − IoU of the
    visible model's box with the prompt box), for a prompted segment) + the size prior's penalty on the scale
    (:class:`~psdr_room_core.method.sizes.SizePrior`, where one is given) + ``room_weight`` × how far (metres)
    its bounding box reaches beyond the target's room box (+ ``back_weight`` × how far it shows the camera its
    back, :func:`~psdr_room_core.method.backs.back_shown`, + ``wall_weight`` × how much farther than the nearest
    wall the wall behind it is, :func:`~psdr_room_core.method.backs.wall_gap`, for a model that stands with its
    back to a wall) (+ ``seen_depth_weight`` × |log| of its centre's depth over the network's and
    ``seen_yaw_weight`` × the network's confidence × (1 − cos) / 2 of its yaw from the network's, for a target with a
    :attr:`ViewTarget.seen` box)."""
    terms: dict[str, float] = field(default_factory=dict)
    """:attr:`error` term by term (:data:`ERROR_TERMS` that apply; they sum to it)."""


ERROR_TERMS = {
    "silhouette": "mask disagreement: wrong pixels / mask pixels",
    "depth": "depth_weight × mean relative depth error where the model meets the object's points",
    "box": "box_weight × (1 − IoU of the visible model's box with the prompt box)",
    "size": "the size prior's penalty on the scale",
    "room": "room_weight × metres the model reaches beyond the room box",
    "back": "back_weight × how far a model that stands with its back to a wall shows the camera its back",
    "wall": "wall_weight × metres farther than the nearest wall the wall behind a model that stands with its back to one is",
    "seen": "seen_depth_weight × |log depth ratio| + seen_yaw_weight × confidence × (1 − cos yaw difference) / 2 "
    "to a network's 3D box of the object",
}
"""The terms of :attr:`ViewFit.error`, by name: what a user reads to see why a model was ranked where it was."""


class _Scorer:
    """Scores poses of one mesh against one :class:`ViewTarget`."""

    def __init__(
        self,
        target: ViewTarget,
        vertices: np.ndarray,
        faces: np.ndarray,
        params: SearchParams,
        caster: MeshCaster | None = None,
        prior: SizePrior | None = None,
        backed: bool = False,
    ) -> None:
        self.target, self.params, self.prior = target, params, prior
        self.backed = backed and params.back_weight > 0
        self.walled = backed and params.wall_weight > 0 and target.room is not None
        self.seen_weighted = target.seen is not None and (params.seen_depth_weight > 0 or params.seen_yaw_weight > 0)
        self.caster = caster or MeshCaster(vertices, faces)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        self.corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        self.mask_box, self.mask_area, self.median_depth = target.mask_box, target.mask_area, target.median_depth

    def window(self, to_world: np.ndarray) -> Window:
        """The mask's box joined with the posed model's projected box, inside the image."""
        cam = self.target.camera
        local = world_to_camera(self.corners @ to_world[:3, :3].T + to_world[:3, 3], self.target.camera_to_world)
        if np.any(local[:, 2] <= 1e-3):
            return 0, 0, cam.width, cam.height
        u = cam.fx * local[:, 0] / local[:, 2] + cam.cx
        v = cam.fy * local[:, 1] / local[:, 2] + cam.cy
        x0, y0, x1, y1 = self.mask_box
        return (
            max(0, min(x0, math.floor(u.min()))),
            max(0, min(y0, math.floor(v.min()))),
            min(cam.width, max(x1, math.ceil(u.max()) + 1)),
            min(cam.height, max(y1, math.ceil(v.max()) + 1)),
        )

    def render_many(self, poses: list[np.ndarray]) -> tuple[Window, np.ndarray, np.ndarray]:
        """(window, (K, h, w) depths, (K, h, w) visible pixels) of K poses over the union of their windows, in
        one cast. Every score below is the same over any window holding the pose's own."""
        windows = np.array([self.window(pose) for pose in poses])
        window = (
            int(windows[:, 0].min()),
            int(windows[:, 1].min()),
            int(windows[:, 2].max()),
            int(windows[:, 3].max()),
        )
        depth = self.caster.depth_many(self.target.camera, self.target.camera_to_world, poses, window)
        x0, y0, x1, y1 = window
        seen = self.target.seen_depth[y0:y1, x0:x1]
        hidden = (seen > 0) & (seen < depth * (1.0 - self.params.hidden_margin)) & ~self.target.mask[y0:y1, x0:x1]
        return window, depth, (depth > 0) & ~hidden

    def surface_points(self, window: Window, depth: np.ndarray, visible: np.ndarray) -> np.ndarray:
        """(N, 3) world points of the model's visible pixels."""
        c2w = self.target.camera_to_world
        local = self.caster.rays(self.target.camera, window)[visible.ravel()] * depth[visible][:, None]
        return local @ c2w[:3, :3].T + c2w[:3, 3]

    def depth_residual(self, window: Window, depth: np.ndarray, visible: np.ndarray) -> float:
        """Median of (observed − model) depth where the model's visible pixels meet the object's points (0
        where they do not meet)."""
        x0, y0, x1, y1 = window
        own = self.target.own_depth[y0:y1, x0:x1]
        both = visible & (own > 0)
        return float(np.median(own[both] - depth[both])) if both.any() else 0.0

    def counted(self, window: Window, visible: np.ndarray) -> np.ndarray:
        """The visible model pixels that count: those outside the target's free pixels (``visible``: one
        pose's (h, w) or K poses' (K, h, w))."""
        x0, y0, x1, y1 = window
        return visible & ~self.target.free[y0:y1, x0:x1]

    def score(self, to_world: np.ndarray) -> tuple[float, float]:
        """(error, visible IoU) of a pose; see :attr:`ViewFit.error`."""
        return self.score_many([to_world])[0]

    def score_many(self, poses: list[np.ndarray]) -> list[tuple[float, float]]:
        """:meth:`score` of each pose, rendered in one cast."""
        terms, iou = self.terms_many(poses)
        error = sum(
            terms.values(), np.zeros(len(poses))
        )  # in the order the terms were added (as before they were named)
        return [(float(e), float(i)) for e, i in zip(error, iou)]

    def terms_many(self, poses: list[np.ndarray]) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """The terms of each pose's error (:data:`ERROR_TERMS` that apply, each (K,), weighted; they sum to the
        error) and its visible IoU (K,), rendered in one cast."""
        window, depth, visible = self.render_many(poses)
        x0, y0, x1, y1 = window
        mask = self.target.mask[y0:y1, x0:x1]
        own = self.target.own_depth[y0:y1, x0:x1]
        overlap = (visible & mask).sum(axis=(1, 2))
        visible_area = self.counted(window, visible).sum(axis=(1, 2))
        wrong = visible_area - overlap + self.mask_area - overlap
        both = visible & (mask & (own > 0))
        count = both.sum(axis=(1, 2))
        depth_sum = np.where(both, np.abs(depth - own).astype(np.float64), 0.0).sum(axis=(1, 2))
        depth_error = np.where(count > 0, depth_sum / np.maximum(count, 1) / self.median_depth, 1.0)
        terms = {"silhouette": wrong / self.mask_area, "depth": self.params.depth_weight * depth_error}
        if self.target.box is not None:
            terms["box"] = self.params.box_weight * (1.0 - np.array([self.prompt_iou(window, v) for v in visible]))
        if self.prior is not None:
            terms["size"] = np.array([self.prior.penalty(float(np.linalg.norm(pose[:3, 0]))) for pose in poses])
        if self.target.room is not None and self.params.room_weight > 0:
            terms["room"] = self.params.room_weight * self.beyond_room(poses)
        if self.backed:
            front = np.array([pose[:3, 2] for pose in poses])  # R_y(yaw) S +Z = s (sin yaw, 0, cos yaw)
            front /= np.linalg.norm(front, axis=1, keepdims=True)
            towards = np.array([pose[:3, 3] for pose in poses]) - self.target.camera_to_world[:3, 3]
            terms["back"] = self.params.back_weight * back_shown(front[:, 0], front[:, 2], towards[:, 0], towards[:, 2])
        if self.walled:
            terms["wall"] = self.params.wall_weight * self.wall_gaps(poses)
        if self.seen_weighted:
            terms["seen"] = self.seen_gaps(poses)
        iou = overlap / np.maximum(self.mask_area + visible_area - overlap, 1)
        return terms, iou

    def beyond_room(self, poses: list[np.ndarray]) -> np.ndarray:
        """(K,) how far (metres) each posed bounding box reaches beyond the target's room box."""
        room = self.target.room
        assert room is not None
        corners = np.stack([self.corners @ pose[:3, :3].T + pose[:3, 3] for pose in poses])  # (K, 8, 3)
        local = room.local(corners)
        return np.max(np.maximum(np.abs(local) - np.asarray(room.half_size), 0.0), axis=(1, 2))

    def wall_gaps(self, poses: list[np.ndarray]) -> np.ndarray:
        """(K,) how much farther (metres) than the nearest wall of the target's room box the wall behind each pose
        is (:func:`~psdr_room_core.method.backs.wall_gap`)."""
        room = self.target.room
        assert room is not None
        local = room.local(np.array([pose[:3, 3] for pose in poses]))
        front = room.local(np.array([pose[:3, 2] for pose in poses]) + np.asarray(room.center))  # directions
        front /= np.linalg.norm(front[:, [0, 2]], axis=1, keepdims=True)
        half = np.asarray(room.half_size)
        return wall_gap(front[:, 0], front[:, 2], local[:, 0], local[:, 2], float(half[0]), float(half[2]))

    def seen_gaps(self, poses: list[np.ndarray]) -> np.ndarray:
        """(K,) each pose's distance from the target's :attr:`~ViewTarget.seen` box, weighted: the log ratio of its
        box centre's camera depth to the seen one's, and how far (1 − cos) / 2 its yaw turns from the seen one's,
        by the network's confidence in it."""
        seen = self.target.seen
        assert seen is not None
        middle = self.corners.mean(axis=0)
        centres = np.array([pose[:3, :3] @ middle + pose[:3, 3] for pose in poses])
        depth = np.maximum(world_to_camera(centres, self.target.camera_to_world)[:, 2], 1e-3)
        yaws = np.array([math.atan2(pose[0, 2], pose[2, 2]) for pose in poses])
        return self.params.seen_depth_weight * np.abs(np.log(depth / seen.depth)) + (
            self.params.seen_yaw_weight * seen.confidence * (1.0 - np.cos(yaws - seen.yaw)) / 2.0
        )

    def prompt_iou(self, window: Window, visible: np.ndarray) -> float:
        """IoU of the visible model's bounding box with the target's prompt box."""
        box = mask_box(visible)
        if box is None:
            return 0.0
        assert self.target.box is not None  # only targets with a prompt box are scored by it
        box += (window[0], window[1], window[0], window[1])
        return float(box_iou(np.asarray(self.target.box, np.float64), box[None])[0])


Hypothesis = tuple[float, float, np.ndarray, float]
"""(error, yaw, position, scale)."""


class ViewSearch:
    """One mesh (canonical: bottom at 0, centred on the vertical axis) posed against one target in two steps:
    building it sweeps the ``n_yaw`` moment-matched starts (all rotations in one cast per step; :attr:`start`
    is the best, a cheap score to shortlist models by), :meth:`finish` refines them by the pattern search. With
    ``support_height`` the mesh's bottom stays at that height; ``caster``: the mesh's, when one is at hand (its
    hierarchy serves every target); ``prior``: the size prior every pose's error includes; ``backed``: the model
    stands with its back to a wall (its category is in :data:`~psdr_room_core.method.backs.BACKED`), so a pose
    showing the camera its back costs ``back_weight``."""

    def __init__(
        self,
        target: ViewTarget,
        vertices: np.ndarray,
        faces: np.ndarray,
        params: SearchParams,
        support_height: float | None = None,
        caster: MeshCaster | None = None,
        prior: SizePrior | None = None,
        backed: bool = False,
    ) -> None:
        self.params, self.support_height = params, support_height
        self.scorer = _Scorer(target, vertices, faces, params, caster, prior, backed)
        box_centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
        self.size = float(np.linalg.norm(np.ptp(vertices, axis=0)))
        # start: the mesh's box centre on the points' median, its size the points' spread; a supported object
        # reaches at least as high as its highest points (its lower part is what others hide)
        median, spread = target.points_median, target.points_spread
        start_scale = max(spread, 1e-3) / max(float(np.median(np.linalg.norm(vertices - box_centre, axis=1))), 1e-9)
        if support_height is not None:
            reach = float(np.percentile(target.points[:, 1], 98)) - support_height
            start_scale = max(start_scale, reach / max(float(np.ptp(vertices[:, 1])), 1e-9))
        self.seen_start = self._seen_start(box_centre, np.ptp(vertices, axis=0)) if target.seen is not None else None
        starts = self._moment_matched(median, box_centre, start_scale)
        self.hypotheses = sorted(starts + ([self.seen_start] if self.seen_start else []), key=lambda h: h[0])

    @property
    def start(self) -> Hypothesis:
        """The best moment-matched start."""
        return self.hypotheses[0]

    def supported(self, position: np.ndarray) -> np.ndarray:
        """``position`` with its height held at the support's."""
        if self.support_height is None:
            return position
        position = position.copy()
        position[1] = self.support_height
        return position

    def _seen_start(self, box_centre: np.ndarray, extent: np.ndarray) -> Hypothesis:
        """The network's box as a pose: the mesh's box centre on the seen centre, turned to the seen yaw, scaled to
        the seen box's volume (held on the support, where there is one)."""
        seen = self.scorer.target.seen
        assert seen is not None
        scale = float(np.prod(seen.size) / max(float(np.prod(np.maximum(extent, 1e-3))), 1e-9)) ** (1.0 / 3.0)
        position = self.supported(seen.center - rotation_y(seen.yaw) @ (scale * box_centre))
        error, _ = self.scorer.score(pose_matrix(position, seen.yaw, scale))
        return error, seen.yaw, position, scale

    def _moment_matched(self, median: np.ndarray, box_centre: np.ndarray, start_scale: float) -> list[Hypothesis]:
        """Each rotation moved and scaled ``refine`` times so its visible part has the mask's area, its points
        the object's median and its depth the object's where they meet (a rotation nothing of which is visible
        stops moving)."""
        scorer, axis = self.scorer, self.scorer.target.camera_to_world[:3, 2]
        yaws = [float(y) for y in np.arange(self.params.n_yaw) * (2.0 * math.pi / self.params.n_yaw)]
        positions = [self.supported(median - start_scale * box_centre) for _ in yaws]
        scales = [start_scale for _ in yaws]
        moving = list(range(len(yaws)))
        for _ in range(self.params.refine):
            if not moving:
                break
            window, depth, visible = scorer.render_many([pose_matrix(positions[k], yaws[k], scales[k]) for k in moving])
            still = []
            for i, k in enumerate(moving):
                if not visible[i].any():
                    continue
                seen = scorer.surface_points(window, depth[i], visible[i])
                shift = median - np.median(seen, axis=0)
                shift += axis * (scorer.depth_residual(window, depth[i], visible[i]) - shift @ axis)
                positions[k] = self.supported(positions[k] + shift)
                scales[k] *= math.sqrt(scorer.mask_area / max(int(scorer.counted(window, visible[i]).sum()), 1))
                still.append(k)
            moving = still
        scores = scorer.score_many([pose_matrix(p, y, s) for p, y, s in zip(positions, yaws, scales)])
        return [(error, yaw, p, s) for (error, _), yaw, p, s in zip(scores, yaws, positions, scales)]

    def finish(self) -> ViewFit:
        """The best pose: the best ``explore`` starts (and the network's box, where the target has one) refined by a
        coarse pattern search, the best ``polish`` of those at finer steps, the best also turned by each of
        ``turns`` and refined."""
        params, scorer = self.params, self.scorer
        spacing = 2.0 * math.pi / max(params.n_yaw, 1)
        search = _PatternSearch(
            scorer, self.supported, spacing / 2.0, self.size, scorer.target.camera_to_world[:3, 3], params.rounds
        )
        explored = self.hypotheses[: params.explore] if params.explore else list(self.hypotheses)
        if self.seen_start is not None and not any(h is self.seen_start for h in explored):
            explored.append(self.seen_start)
        coarse = sorted((search.run(h, range(params.coarse)) for h in explored), key=lambda h: h[0])
        fine_levels = range(params.coarse, params.coarse + params.halvings)
        fine = [search.run(h, fine_levels) for h in coarse[: params.polish]]
        best = min(fine + coarse[:1], key=lambda h: h[0])
        if params.polish:  # a front/back or side flip of the best, refined from there: it keeps its place and size
            turns = [best[1] + turn for turn in np.radians(params.turns)]
            scores = scorer.score_many([pose_matrix(best[2], yaw, best[3]) for yaw in turns]) if turns else []
            turned = [search.run((error, yaw, best[2], best[3]), fine_levels) for (error, _), yaw in zip(scores, turns)]
            best = min([best, *turned], key=lambda h: h[0])
        error, yaw, position, scale = best
        terms, iou = scorer.terms_many([pose_matrix(position, yaw, scale)])
        return ViewFit(
            position,
            yaw % (2.0 * math.pi),
            scale,
            float(iou[0]),
            error,
            {name: float(value[0]) for name, value in terms.items()},
        )


def fit_view(
    target: ViewTarget,
    vertices: np.ndarray,
    faces: np.ndarray,
    params: SearchParams,
    support_height: float | None = None,
    prior: SizePrior | None = None,
    backed: bool = False,
) -> ViewFit:
    """The pose of a mesh (canonical: bottom at 0, centred on the vertical axis) that best explains the
    object in ``target``; with ``support_height`` its bottom stays at that height, with ``prior`` its size is
    a likelihood, ``backed``: it stands with its back to a wall (:class:`ViewSearch`)."""
    return ViewSearch(target, vertices, faces, params, support_height, prior=prior, backed=backed).finish()


class _PatternSearch:
    """Pattern search over a sideways and a forward shift (horizontal, camera-aligned), a move along the view
    ray that keeps the apparent size, a scale about the model's origin, and a turn; the first move that helps
    is taken, the last one that helped tried first. At step level ``k`` the steps are 8% of the model's size
    (shifts), 8% (log scale) and ``yaw_step``, halved ``k`` times; a level ends when no move helps or after
    ``rounds`` moves."""

    def __init__(
        self,
        scorer: _Scorer,
        supported: Callable[[np.ndarray], np.ndarray],
        yaw_step: float,
        size: float,
        origin: np.ndarray,
        rounds: int,
    ) -> None:
        self.scorer, self.supported, self.yaw_step, self.size, self.origin, self.rounds = (
            scorer,
            supported,
            yaw_step,
            size,
            origin,
            rounds,
        )
        forward = scorer.target.camera_to_world[:3, 2] * [1.0, 0.0, 1.0]
        self.forward = forward / max(float(np.linalg.norm(forward)), 1e-9)
        self.right = np.cross([0.0, 1.0, 0.0], self.forward)

    def run(self, start: Hypothesis, levels: range) -> Hypothesis:
        """The hypothesis improved at each step level of ``levels``."""
        error, yaw, position, scale = start
        last = 0  # the move that helped last is tried first
        for level in levels:
            step = 0.08 / 2**level
            turn = self.yaw_step / 2**level
            for _ in range(self.rounds):
                shift = step * scale * self.size
                moves = []
                for sign in (1.0, -1.0):
                    ray = math.exp(sign * step)
                    moves += [
                        (yaw, self.supported(position + sign * shift * self.right), scale),
                        (yaw, self.supported(position + sign * shift * self.forward), scale),
                        (yaw, position, scale * math.exp(sign * step)),
                        (yaw, self.supported(self.origin + (position - self.origin) * ray), scale * ray),
                        (yaw + sign * turn, position, scale),
                    ]
                for k in (last, *(k for k in range(len(moves)) if k != last)):
                    y, p, s = moves[k]
                    value = self.scorer.score(pose_matrix(p, y, s))[0]
                    if value < error - 1e-9:
                        error, yaw, position, scale, last = value, y, p, s, k
                        break
                else:
                    break
        return error, yaw, position, scale
