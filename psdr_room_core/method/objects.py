"""Object stage method (paper §4.3): queries from the segmentation, initial poses and support relations.

World frame as in :mod:`.artifacts` (Y up, floor ``y = 0``). Database meshes are canonical: Y up, bottom
at ``y = 0``, centred on ``x = z = 0``, front facing +Z. A pose is ``to_world = T(position) R_y(yaw) S(scale)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import cv2
import numpy as np

from .artifacts import Camera, Image, Panoptic, Placement, PointCloud, RoomBox, rotation_y
from .labels import alternates, meaning
from .params import SupportParams
from .seen_boxes import SeenPrior, scene_scale, seen_prior
from .silhouette import mask_l1, silhouette

OBJECT_CATEGORIES = ("object", "lamp")
"""Segment categories that become retrieved objects (doors and windows are openings of the room)."""


@dataclass(frozen=True)
class ObjectQuery:
    """One segmented object: what retrieval and initialisation see of it."""

    segment_id: int
    label: str
    categories: tuple[str, ...]
    """Database categories to search, from the label, the most likely first (empty: any; :mod:`.labels`)."""
    mask: np.ndarray
    """(H, W) bool at the working image's resolution."""
    points: np.ndarray
    """(N, 3) world points of the segment."""
    crop: np.ndarray
    """uint8 RGB crop around the mask (square, with context) for image-based retrieval."""
    scene_points: np.ndarray
    """(M, 3) world points of every segment (one array shared by all queries): what may hide the object."""
    box: tuple[float, float, float, float] | None = None
    """The segment's prompt box (:attr:`~psdr_room_core.method.artifacts.Segment.box`): a model may cover it outside the
    mask without being wrong."""
    alternates: tuple[str, ...] = ()
    """What else a guessed segment may be (:func:`~.labels.alternates`): searched too, taken only where the shape
    says so."""
    guessed: bool = False
    """The segment is an automatic guess (it has a score): its label is weak."""
    room: RoomBox | None = None
    """The room box the object stands in (its model must fit inside)."""
    photo: np.ndarray | None = None
    """The working image (float RGB, one array shared by all queries): the object in its whole picture, for an
    image network that reads the room around it."""
    seen: SeenPrior | None = None
    """The segmenting network's 3D box of the object, in the world at the scene's scale (:mod:`.seen_boxes`)."""


def object_queries(
    image: Image, panoptic: Panoptic, cloud: PointCloud, room: RoomBox, min_points: int, min_pixels: int
) -> list[ObjectQuery]:
    """A query per object segment with at least ``min_pixels`` pixels and ``min_points`` depth points whose label
    names something the database holds (:func:`~.labels.meaning`), with its segment's 3D box where a network gave
    one (:func:`~.seen_boxes.seen_prior`, at the scene's scale over all of them)."""
    to_world = np.asarray(room.camera_to_world)
    rgb8 = image.to_uint8()
    scene = cloud.points.astype(np.float64) @ to_world[:3, :3].T + to_world[:3, 3]
    queries = []
    for segment in panoptic.segments:
        if segment.category not in OBJECT_CATEGORIES:
            continue
        named = meaning(segment.label, segment.category)
        if named is None:
            continue
        mask = panoptic.ids == segment.id
        points = scene[cloud.segment == segment.id]
        if mask.sum() < min_pixels or len(points) < min_points:
            continue
        guessed = segment.score is not None
        queries.append(
            ObjectQuery(
                segment.id,
                segment.label,
                named.categories,
                mask,
                points,
                square_crop(rgb8, mask),
                scene,
                segment.box,
                alternates(named, segment.second_opinion) if guessed else (),
                guessed,
                room,
                image.rgb,
            )
        )
    boxes = {s.id: s.seen for s in panoptic.segments if s.seen is not None}
    scale = scene_scale(boxes, {q.segment_id: q.points for q in queries}, to_world)
    return [
        replace(q, seen=seen_prior(boxes[q.segment_id], to_world, scale)) if q.segment_id in boxes else q
        for q in queries
    ]


def square_crop(rgb8: np.ndarray, mask: np.ndarray, context: float = 0.1) -> np.ndarray:
    """A square crop round ``mask``'s bounding box with ``context`` (a share of its size) on each side."""
    ys, xs = np.nonzero(mask)
    cx, cy = (xs.min() + xs.max()) / 2.0, (ys.min() + ys.max()) / 2.0
    half = max(xs.max() - xs.min(), ys.max() - ys.min()) * (0.5 + context) + 1
    x0, x1 = int(max(0, cx - half)), int(min(rgb8.shape[1], cx + half + 1))
    y0, y1 = int(max(0, cy - half)), int(min(rgb8.shape[0], cy + half + 1))
    return rgb8[y0:y1, x0:x1].copy()


# ------------------------------------------------------------------------------------------ poses
def pose_matrix(position: np.ndarray, yaw: float, scale: float) -> np.ndarray:
    """4x4 ``T(position) R_y(yaw) S(scale)``."""
    matrix = np.eye(4)
    matrix[:3, :3] = rotation_y(yaw) * scale
    matrix[:3, 3] = position
    return matrix


def transform(vertices: np.ndarray, to_world: np.ndarray) -> np.ndarray:
    return vertices @ to_world[:3, :3].T + to_world[:3, 3]


def footprint(p: Placement) -> tuple[np.ndarray, float, float]:
    """(4x2 xz corners of the object's rotated bounding box, bottom y, top y) in the world."""
    v = p.mesh.vertices
    lo, hi = v.min(axis=0) * p.scale, v.max(axis=0) * p.scale
    corners = np.array([[lo[0], lo[2]], [hi[0], lo[2]], [hi[0], hi[2]], [lo[0], hi[2]]])
    c, s = math.cos(p.yaw), math.sin(p.yaw)
    # R_y acts on (x, z) as [[c, s], [-s, c]]
    xz = corners @ np.array([[c, -s], [s, c]]) + [p.position[0], p.position[2]]
    return xz, p.position[1] + lo[1], p.position[1] + hi[1]


def mesh_radius(vertices: np.ndarray) -> float:
    """Median distance of the mesh's vertices to its bounding-box centre."""
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
    return float(np.median(np.linalg.norm(vertices - centre, axis=1)))


def initial_pose(points: np.ndarray, vertices: np.ndarray, radius_factor: float) -> tuple[np.ndarray, float]:
    """(position, scale) of §4.3: the mesh's bounding-box centre on the per-axis median of the points and its
    radius ``radius_factor`` × the points' radius (median distance to that centre; the paper uses 0.5)."""
    centre = np.median(points, axis=0)
    radius = float(np.median(np.linalg.norm(points - centre, axis=1)))
    scale = radius_factor * radius / max(mesh_radius(vertices), 1e-9)
    box_centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
    return centre - scale * box_centre, scale  # box_centre is on the vertical axis (x = z = 0)


def best_yaw(
    camera: Camera,
    camera_to_world: np.ndarray,
    vertices: np.ndarray,
    faces: np.ndarray,
    position: np.ndarray,
    scale: float,
    target: np.ndarray,
    n_yaw: int,
) -> tuple[float, float]:
    """(yaw, mean L1) of the rotation about the vertical axis whose silhouette best matches ``target``
    (a mask at the camera's resolution), over ``n_yaw`` evenly spaced angles."""
    best = (0.0, np.inf)
    for yaw in np.arange(n_yaw) * (2.0 * np.pi / n_yaw):
        rendered = silhouette(camera, camera_to_world, transform(vertices, pose_matrix(position, yaw, scale)), faces)
        error = mask_l1(rendered, target)
        if error < best[1]:
            best = (float(yaw), error)
    return best


# ----------------------------------------------------------------------------------- support relations


def mask_distance(mask: np.ndarray, other: np.ndarray) -> float:
    """Smallest pixel distance from ``mask`` to ``other`` (inf when ``other`` is empty)."""
    if not other.any() or not mask.any():
        return float("inf")
    distance = cv2.distanceTransform((~other).astype(np.uint8), cv2.DIST_L2, 3)
    return float(distance[mask].min())


def nearest_wall(room: RoomBox, point: np.ndarray) -> tuple[int, float]:
    """(index, distance) of the room box's nearest vertical side to a world point; sides are numbered
    -x, +x, -z, +z of the box's own frame."""
    local = room.local(point)
    half = np.asarray(room.half_size)
    distances = [local[0] + half[0], half[0] - local[0], local[2] + half[2], half[2] - local[2]]
    index = int(np.argmin(np.abs(distances)))
    return index, float(abs(distances[index]))


def wall_frame(room: RoomBox, index: int) -> tuple[np.ndarray, np.ndarray, float]:
    """(inward unit normal, unit tangent, plane offset d with normal·x = d) of a side of the room box."""
    rotation = rotation_y(room.yaw)
    axis = rotation[:, 0] if index < 2 else rotation[:, 2]
    inward = axis if index in (0, 2) else -axis
    tangent = np.cross(np.array([0.0, 1.0, 0.0]), inward)
    half = room.half_size[0] if index < 2 else room.half_size[2]
    offset = float(inward @ np.asarray(room.center) - half)
    return inward, tangent, offset


Support = tuple[str, int | None]
"""(``floor`` | ``parent`` | ``wall`` | ``free``, the parent's segment id or the wall's index)."""


def support_relations(
    queries: list[ObjectQuery],
    floor_mask: np.ndarray,
    room: RoomBox,
    params: SupportParams,
    categories: Mapping[int, str] | None = None,
) -> dict[int, list[Support]]:
    """Segment id → the supports §4.3's rules allow it, the rules' choice first, by these rules in this order:
    on the floor; on a floor object whose mask touches its own from below, whose top is at its bottom and
    whose points' footprint holds its centre; an object of a ``grounded`` category whose bottom is hidden
    (below mid-height) on the floor; near a wall, on it, unless its category is ``floor_only`` (then on the
    floor); else free. An object's category is ``categories[segment id]`` (the model placed for it), else its
    label's first.

    A grounded object that a parent could hold may also stand on the floor behind it (a tall cabinet whose
    lower part a low one hides looks the same): both are listed, and the view search decides."""
    relations: dict[int, list[Support]] = {}
    bottoms = {q.segment_id: float(np.percentile(q.points[:, 1], params.bottom_percentile)) for q in queries}
    for q in queries:
        if (
            abs(bottoms[q.segment_id] - room.floor) < params.floor_distance
            and mask_distance(q.mask, floor_mask) < params.edge_px
        ):
            relations[q.segment_id] = [("floor", None)]
    on_floor = [q for q in queries if q.segment_id in relations]
    for q in queries:
        if q.segment_id in relations:
            continue
        bottom = bottoms[q.segment_id]
        rows = np.flatnonzero(q.mask.any(axis=1))
        centre = np.median(q.points[:, [0, 2]], axis=0)
        parents = []
        for p in on_floor:
            p_rows = np.flatnonzero(p.mask.any(axis=1))
            lo, hi = np.percentile(p.points[:, [0, 2]], [2, 98], axis=0)
            over = bool(np.all((centre > lo - params.floor_distance) & (centre < hi + params.floor_distance)))
            on_top = (
                bottom > float(np.percentile(p.points[:, 1], 100 - params.bottom_percentile)) - params.floor_distance
            )
            distance = mask_distance(q.mask, p.mask)
            if rows.mean() < p_rows.mean() and over and on_top and distance < params.edge_px:
                parents.append((distance, p.segment_id))
        category = (categories or {}).get(q.segment_id) or (q.categories[0] if q.categories else "")
        hidden_bottom = category in params.grounded and bottom < float(room.center[1])
        grounded: list[Support] = [("floor", None)] if hidden_bottom or category in params.floor_only else []
        wall, wall_distance = nearest_wall(room, np.median(q.points, axis=0))
        if parents:
            relations[q.segment_id] = [("parent", min(parents)[1]), *grounded]
        elif grounded:
            relations[q.segment_id] = grounded
        elif wall_distance < params.wall_distance:
            relations[q.segment_id] = [("wall", wall)]
        else:
            relations[q.segment_id] = [("free", None)]
    return relations
