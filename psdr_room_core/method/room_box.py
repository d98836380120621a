"""Room-box initialisation from a segmented room point cloud (paper §4.2, "Room initialization").

Pipeline:

1. RANSAC floor plane on the floor points; its normal is oriented toward the camera and the camera height is
   the camera centre's distance to it; this fixes ``camera_to_world``;
2. room height: a high percentile of the ceiling point heights, or, when no ceiling is visible,
   ``ceiling_margin`` times the top of the room points and at least ``height_ratio`` camera heights;
3. yaw: sequential RANSAC planes on the wall points; the near-vertical ones vote (weighted by inliers) for the
   box rotation about the floor normal, modulo 90 degrees;
4. extents in the yaw-rotated frame: a side sits on the wall plane that bounds it, else at a robust percentile
   of the room points, and never closer to the camera than ``behind_margin`` times the scene scale (so the
   unseen back wall lies behind the camera and an unseen side wall never cuts into the visible frustum); an
   unseen side the camera faces lies at least ``size_ratio`` camera heights from the opposite side.

Conventions: camera frame is OpenCV (x right, y down, z forward). World frame: Y up, floor y = 0, origin on
the floor below the camera, Z = optical axis projected on the floor, X = Y x Z (so X points to the camera's
left). Box: world corner = center + R_y(yaw) @ (+-half_size). Planes are (a, b, c, d) with unit normal,
n.p + d = 0, oriented so the camera centre (camera-frame origin) is on the positive side, i.e. d is the
camera's distance to the plane. Distances are in depth units; every threshold is a fraction of the scene
scale (median point distance to the camera), so a uniformly scaled cloud gives the same box, scaled.

RANSAC is our own numpy implementation driven by ``numpy.random.Generator(seed)`` rather than open3d's
``segment_plane``: open3d scores hypotheses in an OpenMP loop fed by one process-global, mutex-shared sampler
and stops early once a model looks good enough, so which samples get scored depends on thread scheduling and
on whoever last reseeded open3d. The numpy version samples every hypothesis up front, scores them without
BLAS (elementwise products and pairwise sums) and refines by least squares on the inliers, so the result is
bit-identical for the same inputs, seed and machine, whatever the thread count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psdr_room_core.engine.settings import setting

_MIN_FLOOR_POINTS = 50
"""Fewer (valid) floor points than this cannot give a trustworthy floor plane."""
_MIN_PLANE_POINTS = 30
"""Wall / ceiling clouds with fewer points than this are treated as absent."""
_MAX_SCORING_POINTS = 4096
"""RANSAC hypotheses are scored on a seeded random subset of at most this many points."""
_HYPOTHESIS_BLOCK = 32
"""Hypotheses scored per vectorised block (bounds the temporary memory)."""
_REFINE_STEPS = 3
"""Least-squares re-fits on the inliers after the RANSAC winner."""
_WALL_AXIS_TOLERANCE_DEG = 20.0
"""A wall bounds a box side only if its normal is within this of that side's axis (after the yaw)."""


@dataclass(frozen=True)
class RoomInitParams:
    """Knobs of :func:`init_room_box`: the ``room_init`` settings. Lengths are fractions of the scene scale (the
    median point distance to the camera)."""

    ransac_threshold: float = setting(gt=0, doc="Plane inlier distance, a fraction of the median point distance.")
    ransac_iterations: int = setting(ge=1, doc="RANSAC hypotheses per plane.")
    max_walls: int = setting(ge=0, doc="Planes extracted one after another from the wall points.")
    min_wall_inliers: float = setting(
        gt=0, le=1, doc="Fraction of the wall points a wall plane needs; extraction stops at the first smaller plane."
    )
    vertical_tolerance_deg: float = setting(
        ge=0,
        le=90,
        doc="A wall plane's normal must be within this (degrees) of horizontal, else it is dropped (an estimated "
        "depth's smooth error tilts real walls by 10-15 degrees).",
    )
    ceiling_margin: float = setting(
        ge=1, doc="Room height = this × the top of the room points when no ceiling is visible (§4.2) ..."
    )
    height_ratio: float = setting(
        gt=0,
        doc="... and at least this many camera heights (the walls go on above the frame: a camera at 1.5 m sees "
        "rooms about 2.8 m high).",
    )
    size_ratio: float = setting(
        gt=0,
        doc="An unseen side the camera faces lies at least this many camera heights from the opposite side (rooms "
        "about 4.5 m across for a camera at 1.5 m).",
    )
    extent_percentile: float = setting(
        gt=50,
        le=100,
        doc="Robust 'maximum' of point coordinates (ceiling height, top of the points, box sides without a wall).",
    )
    behind_margin: float = setting(
        ge=0,
        doc="Box sides no wall bounds (the unseen back wall) are at least this far behind the camera, a fraction of "
        "the median point distance (photos are taken 0.5-1 m in front of the back wall, points 2.5-3.5 m away).",
    )
    camera_height: float = setting(
        gt=0,
        doc="No floor, ceiling or two walls in view: the camera this high (depth units) above the floor (the 1.5 m "
        "the layout depth assumes too).",
    )


@dataclass(frozen=True)
class RoomInitResult:
    """The initial room box, in the world frame defined by the floor (see the module docstring)."""

    camera_to_world: np.ndarray
    """4x4 matrix mapping camera-frame points to world."""
    center: np.ndarray
    """Box centre in world (center[1] = half_size[1]: the floor is y = 0)."""
    half_size: np.ndarray
    """Half extents along the box's local x, y, z."""
    yaw: float
    """Box rotation about world +Y, in [-pi/4, pi/4]."""
    floor_plane: np.ndarray
    """(a, b, c, d) in the camera frame, unit normal pointing to the camera side."""
    wall_planes: list[np.ndarray]
    """Near-vertical wall planes (a, b, c, d) in the camera frame, camera side positive."""
    ceiling_visible: bool
    """Whether the room height comes from ceiling points (else from ``ceiling_margin``)."""
    camera_height: float
    """Camera centre height above the floor."""
    floor_source: str = "floor"
    """Where the floor plane came from: ``floor`` points, or, with none in view, the ``ceiling``, two ``walls``,
    one ``wall`` and the camera held level, or the ``camera`` alone (see :func:`floor_without_floor_points`)."""


def fit_floor_plane(points: np.ndarray, threshold: float, iterations: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """RANSAC plane (a, b, c, d) through ``points`` (N x 3, camera frame) and its inlier mask.

    ``threshold`` is the absolute inlier distance. The normal points to the camera side (d >= 0).
    Deterministic: the same inputs and seed give bit-identical outputs (on the same machine).
    """
    return _ransac_plane(np.asarray(points, dtype=np.float64), threshold, iterations, np.random.default_rng(seed))


def camera_to_world_from_floor(floor_plane: np.ndarray) -> np.ndarray:
    """4x4 camera-to-world matrix of the floor-based world frame (see the module docstring)."""
    up = floor_plane[:3]
    forward = _project_on_plane(np.array([0.0, 0.0, 1.0]), up)
    if np.linalg.norm(forward) < 1e-6:  # looking straight down: image-up is the forward direction
        forward = _project_on_plane(np.array([0.0, -1.0, 0.0]), up)
    forward /= np.linalg.norm(forward)
    transform = np.eye(4)
    transform[:3, :3] = np.stack([np.cross(up, forward), up, forward])
    transform[1, 3] = floor_plane[3]
    return transform


def init_room_box(points: dict[str, np.ndarray], params: RoomInitParams, *, seed: int) -> RoomInitResult:
    """Coarse room box from camera-frame points labelled "floor", "wall", "ceiling" (paper §4.2).

    Missing or empty categories are allowed; ``objects`` (optional) are the points of everything else, which
    only bound the floor from above when it is not seen. Without a visible floor
    (:func:`floor_without_floor_points`) the floor plane is inferred from the ceiling, the walls or the
    camera; ``floor_source`` says which. Non-finite points and points not in front of the camera (z <= 0,
    e.g. missing depth) are ignored. Raises ``ValueError`` only when no room point has a depth.
    """
    clouds = {name: _valid_points(points.get(name)) for name in ("floor", "wall", "ceiling")}
    if not sum(len(c) for c in clouds.values()):
        raise ValueError("room_init: no wall, floor or ceiling point has a depth; label them and check the depth")
    objects = _valid_points(points.get("objects"))
    scale = _scene_scale(clouds)
    threshold = params.ransac_threshold * scale
    if len(clouds["floor"]) >= _MIN_FLOOR_POINTS:
        floor_plane, _ = fit_floor_plane(clouds["floor"], threshold, params.ransac_iterations, seed)
        floor_source = "floor"
    else:
        floor_plane, floor_source = floor_without_floor_points(
            {**clouds, "objects": objects}, threshold, scale, params, seed=seed
        )
    camera_to_world = camera_to_world_from_floor(floor_plane)
    world = {name: _transform(cloud, camera_to_world) for name, cloud in clouds.items()}
    camera_height = float(floor_plane[3])
    height, ceiling_visible = _room_height(world, camera_height, params)

    walls = _extract_wall_planes(clouds["wall"], floor_plane[:3], threshold, params, seed=seed)
    wall_normals = [camera_to_world[:3, :3] @ plane[:3] for plane, _ in walls]
    wall_inliers = [_transform(inliers, camera_to_world) for _, inliers in walls]
    yaw = _wall_yaw(wall_normals, [len(inliers) for inliers in wall_inliers])

    room = np.concatenate([world["floor"], world["wall"], world["ceiling"]])
    lower, upper = _horizontal_extents(
        room, wall_normals, wall_inliers, yaw, params.behind_margin * scale, params.size_ratio * camera_height, params
    )
    center_local = np.array([(lower[0] + upper[0]) / 2, height / 2, (lower[1] + upper[1]) / 2])
    half_size = np.array([(upper[0] - lower[0]) / 2, height / 2, (upper[1] - lower[1]) / 2])
    return RoomInitResult(
        camera_to_world=camera_to_world,
        center=_rotation_y(yaw) @ center_local,
        half_size=half_size,
        yaw=yaw,
        floor_plane=floor_plane,
        wall_planes=[plane for plane, _ in walls],
        ceiling_visible=ceiling_visible,
        camera_height=camera_height,
        floor_source=floor_source,
    )


def floor_without_floor_points(
    clouds: dict[str, np.ndarray], threshold: float, scale: float, params: RoomInitParams, *, seed: int
) -> tuple[np.ndarray, str]:
    """The floor plane (camera frame, camera side positive) of a photo that shows no floor, and how it was found.

    From the ceiling plane when one is seen: parallel to it, the camera ``1 / (height_ratio - 1)`` of the
    ceiling's distance above it (a camera at 1.5 m under a 2.8 m ceiling). Else from two walls: up is their
    normals' cross product. Else from what the photo leaves: up is the image's up (the camera held level), made
    parallel to the one wall seen if there is one (``wall``), or not (``camera``). Without a ceiling the
    floor lies just below the lowest point seen (10% lower: objects and walls stand on it), and at least
    ``camera_height`` below the camera.
    """
    if len(clouds["ceiling"]) >= _MIN_FLOOR_POINTS:
        ceiling, _ = fit_floor_plane(clouds["ceiling"], threshold, params.ransac_iterations, seed)
        up = -ceiling[:3]  # the ceiling's normal points down, to the camera
        return np.append(up, ceiling[3] / (params.height_ratio - 1.0)), "ceiling"
    normals = _wall_normals(clouds["wall"], threshold, params, seed=seed)
    pairs = [(a, b) for i, a in enumerate(normals) for b in normals[i + 1 :] if abs(a @ b) < 0.3]
    image_up = np.array([0.0, -1.0, 0.0])  # camera y points down
    if pairs:
        up, source = np.cross(*pairs[0]), "walls"
    elif normals:
        up, source = _project_on_plane(image_up, normals[0]), "wall"
    else:
        up, source = image_up, "camera"
    up = up / np.linalg.norm(up) * (1.0 if up[1] < 0 else -1.0)
    seen = np.concatenate([clouds[name] for name in ("wall", "floor", "objects") if name in clouds])
    drop = float(np.max(-(seen @ up))) if len(seen) else 0.0
    return np.append(up, max(1.1 * drop, params.camera_height if source != "walls" else 0.5 * scale)), source


def _wall_normals(points: np.ndarray, threshold: float, params: RoomInitParams, *, seed: int) -> list[np.ndarray]:
    """Normals of the planes found one after another in the wall points (at most ``max_walls``)."""
    rng = np.random.default_rng((seed, 2))
    remaining = points
    normals: list[np.ndarray] = []
    while len(remaining) >= _MIN_FLOOR_POINTS and len(normals) < params.max_walls:
        plane, inliers = _ransac_plane(remaining, threshold, params.ransac_iterations, rng)
        if inliers.sum() < max(params.min_wall_inliers * len(points), _MIN_PLANE_POINTS):
            break
        normals.append(plane[:3])
        remaining = remaining[~inliers]
    return normals


def box_iou_3d(
    center_a: np.ndarray,
    half_a: np.ndarray,
    yaw_a: float,
    center_b: np.ndarray,
    half_b: np.ndarray,
    yaw_b: float,
) -> float:
    """3-D IoU of two boxes rotated about the vertical (Y) axis: footprint overlap x height overlap."""
    footprint = _polygon_area(_clip_convex(_footprint(center_a, half_a, yaw_a), _footprint(center_b, half_b, yaw_b)))
    low = max(center_a[1] - half_a[1], center_b[1] - half_b[1])
    high = min(center_a[1] + half_a[1], center_b[1] + half_b[1])
    intersection = footprint * max(high - low, 0.0)
    union = 8 * np.prod(half_a) + 8 * np.prod(half_b) - intersection
    return float(intersection / union) if union > 0 else 0.0


# --- point clouds and planes -------------------------------------------------------------------------------


def _valid_points(points: np.ndarray | None) -> np.ndarray:
    """N x 3 float64 points that are finite and in front of the camera."""
    if points is None:
        return np.zeros((0, 3))
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return points[np.isfinite(points).all(axis=1) & (points[:, 2] > 0)]


def _scene_scale(clouds: dict[str, np.ndarray]) -> float:
    """Median distance of all room points to the camera: the unit of every threshold."""
    return float(np.median(np.linalg.norm(np.concatenate(list(clouds.values())), axis=1)))


def _transform(points: np.ndarray, transform: np.ndarray) -> np.ndarray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def _project_on_plane(vector: np.ndarray, normal: np.ndarray) -> np.ndarray:
    return vector - (vector @ normal) * normal


def _signed_distances(points: np.ndarray, plane: np.ndarray) -> np.ndarray:
    return points[:, 0] * plane[0] + points[:, 1] * plane[1] + points[:, 2] * plane[2] + plane[3]


def _least_squares_plane(points: np.ndarray) -> np.ndarray:
    """Total-least-squares plane through ``points``, camera side positive."""
    centroid = points.mean(axis=0)
    centred = points - centroid
    covariance = np.einsum("ni,nj->ij", centred, centred)
    normal = np.linalg.eigh(covariance)[1][:, 0]
    return _orient_to_camera(np.append(normal, -normal @ centroid))


def _orient_to_camera(plane: np.ndarray) -> np.ndarray:
    return -plane if plane[3] < 0 else plane


def _ransac_plane(
    points: np.ndarray, threshold: float, iterations: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """MSAC plane fit (truncated quadratic cost) refined by least squares on the inliers."""
    if len(points) < 3:
        raise ValueError(f"room_init: {len(points)} points cannot define a plane (need at least 3)")
    scoring = points
    if len(points) > _MAX_SCORING_POINTS:
        scoring = points[np.sort(rng.choice(len(points), _MAX_SCORING_POINTS, replace=False))]
    samples = points[rng.integers(0, len(points), size=(iterations, 3))]
    edge_1, edge_2 = samples[:, 1] - samples[:, 0], samples[:, 2] - samples[:, 0]
    normals = np.cross(edge_1, edge_2)
    lengths = np.linalg.norm(normals, axis=1)
    spans = np.linalg.norm(edge_1, axis=1) * np.linalg.norm(edge_2, axis=1)
    usable = lengths > 1e-6 * spans
    if not usable.any():
        raise ValueError(f"room_init: {len(points)} points are degenerate (collinear); cannot fit a plane")
    normals = normals[usable] / lengths[usable, None]
    planes = np.column_stack([normals, -np.einsum("ni,ni->n", normals, samples[usable, 0])])
    best = planes[int(np.argmin(_msac_costs(scoring, planes, threshold)))]
    for _ in range(_REFINE_STEPS):
        inliers = np.abs(_signed_distances(points, best)) < threshold
        if inliers.sum() < 3:
            break
        best = _least_squares_plane(points[inliers])
    return _orient_to_camera(best), np.abs(_signed_distances(points, best)) < threshold


def _msac_costs(points: np.ndarray, planes: np.ndarray, threshold: float) -> np.ndarray:
    """Sum over points of min(distance^2, threshold^2) for each plane (no BLAS: reproducible)."""
    costs = np.empty(len(planes))
    for start in range(0, len(planes), _HYPOTHESIS_BLOCK):
        block = planes[start : start + _HYPOTHESIS_BLOCK]
        distances = (
            points[:, None, 0] * block[None, :, 0]
            + points[:, None, 1] * block[None, :, 1]
            + points[:, None, 2] * block[None, :, 2]
            + block[None, :, 3]
        )
        costs[start : start + len(block)] = np.minimum(distances**2, threshold**2).sum(axis=0)
    return costs


# --- room height, walls, yaw, extents ----------------------------------------------------------------------


def _room_height(world: dict[str, np.ndarray], camera_height: float, params: RoomInitParams) -> tuple[float, bool]:
    """Ceiling height (robust top of the ceiling points) or ceiling_margin x the top of the room points."""
    if len(world["ceiling"]) >= _MIN_PLANE_POINTS:
        height = float(np.percentile(world["ceiling"][:, 1], params.extent_percentile))
        if height > camera_height:
            return height, True
    upper = np.concatenate([world["wall"], world["ceiling"]])
    if len(upper) < _MIN_PLANE_POINTS:
        upper = np.concatenate([upper, world["floor"]])
    top = max(float(np.percentile(upper[:, 1], params.extent_percentile)) if len(upper) else 0.0, camera_height)
    return max(params.ceiling_margin * top, params.height_ratio * camera_height), False


def _extract_wall_planes(
    points: np.ndarray, up: np.ndarray, threshold: float, params: RoomInitParams, *, seed: int
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Sequential RANSAC on the wall points: (plane, inlier points) of each near-vertical plane."""
    rng = np.random.default_rng((seed, 1))
    min_inliers = max(params.min_wall_inliers * len(points), _MIN_PLANE_POINTS)
    max_tilt = np.sin(np.radians(params.vertical_tolerance_deg))
    walls = []
    remaining = points
    for _ in range(params.max_walls):
        if len(remaining) < min_inliers:
            break
        plane, inliers = _ransac_plane(remaining, threshold, params.ransac_iterations, rng)
        if inliers.sum() < min_inliers:
            break
        if abs(plane[:3] @ up) <= max_tilt:
            walls.append((plane, remaining[inliers]))
        remaining = remaining[~inliers]
    return walls


def _wall_yaw(normals: list[np.ndarray], weights: list[int]) -> float:
    """Yaw in [-pi/4, pi/4] best aligning the box axes with the wall normals (inlier-weighted, mod 90 deg).

    Maximises sum_i w_i cos(4 (phi_i - yaw)), phi_i = atan2(n_x, n_z): the circular mean of 4 phi_i.
    Without walls the box faces the camera (yaw 0).
    """
    if not normals:
        return 0.0
    angles = 4 * np.array([np.arctan2(normal[0], normal[2]) for normal in normals])
    w = np.asarray(weights, dtype=np.float64)
    return float(np.arctan2(w @ np.sin(angles), w @ np.cos(angles)) / 4)


def _horizontal_extents(
    room: np.ndarray,
    wall_normals: list[np.ndarray],
    wall_inliers: list[np.ndarray],
    yaw: float,
    clearance: float,
    size: float,
    params: RoomInitParams,
) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) box bounds along the yaw-rotated local (x, z).

    A side is placed at the wall (median inlier coordinate) that bounds it, the one with most inliers if
    several do; otherwise at the extent_percentile of the room points, at least ``clearance`` from the camera
    (the camera, at the origin, stands inside the room), and, unless it is the side most directly behind the
    camera (the wall the photo was taken from), at least ``size`` from the opposite side: it lies beyond the
    frame, where a room of typical size would have it.
    """
    rotation = _rotation_y(yaw)
    local = room @ rotation
    lower = np.percentile(local[:, [0, 2]], 100 - params.extent_percentile, axis=0)
    upper = np.percentile(local[:, [0, 2]], params.extent_percentile, axis=0)
    lower, upper = np.minimum(lower, -clearance), np.maximum(upper, clearance)
    support: dict[tuple[int, bool], int] = {}
    min_alignment = np.cos(np.radians(_WALL_AXIS_TOLERANCE_DEG))
    for normal, inliers in zip(wall_normals, wall_inliers):
        horizontal = (rotation.T @ normal)[[0, 2]]
        axis = int(np.argmax(np.abs(horizontal)))
        if abs(horizontal[axis]) < min_alignment * np.linalg.norm(horizontal):
            continue
        position = float(np.median((inliers @ rotation)[:, 2 * axis]))
        side = (axis, position > 0)
        if len(inliers) > support.get(side, 0):
            support[side] = len(inliers)
            (upper if position > 0 else lower)[axis] = position
    forward = (rotation.T @ np.array([0.0, 0.0, 1.0]))[[0, 2]]  # the camera looks along world +Z
    back = int(np.argmax(np.abs(forward)))
    behind = (back, bool(forward[back] < 0))  # the side the camera turns its back to: the photo is taken from there
    for axis in (0, 1):
        # a side is known when a wall bounds it or it is the one behind the camera; an unknown side lies beyond
        # the frame: `size` from a known opposite side, else the visible extent widened to `size` about its middle
        known = [(axis, side) in support or (axis, side) == behind for side in (False, True)]
        middle = (lower[axis] + upper[axis]) / 2
        if not known[1]:
            upper[axis] = max(upper[axis], lower[axis] + size if known[0] else middle + size / 2)
        if not known[0]:
            lower[axis] = min(lower[axis], upper[axis] - size if known[1] else middle - size / 2)
    return lower, upper


def _rotation_y(angle: float) -> np.ndarray:
    cos, sin = np.cos(angle), np.sin(angle)
    return np.array([[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]])


# --- footprint polygons (box_iou_3d) -----------------------------------------------------------------------


def _footprint(center: np.ndarray, half: np.ndarray, yaw: float) -> np.ndarray:
    """Counter-clockwise (x, z) corners of a box's floor footprint."""
    signs = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    local = np.column_stack([signs[:, 0] * half[0], np.zeros(4), signs[:, 1] * half[2]])
    world = local @ _rotation_y(yaw).T + np.asarray(center, dtype=np.float64)
    return world[:, [0, 2]]


def _clip_convex(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman intersection of two counter-clockwise convex polygons."""
    polygon = list(subject)
    for start, end in zip(clip, np.roll(clip, -1, axis=0)):
        if not polygon:
            break
        edge = end - start
        inside = [edge[0] * (p[1] - start[1]) - edge[1] * (p[0] - start[0]) >= 0 for p in polygon]
        clipped = []
        for i, point in enumerate(polygon):
            previous, previous_inside = polygon[i - 1], inside[i - 1]
            if inside[i] != previous_inside:
                clipped.append(_segment_line_intersection(previous, point, start, edge))
            if inside[i]:
                clipped.append(point)
        polygon = clipped
    return np.array(polygon).reshape(-1, 2)


def _segment_line_intersection(a: np.ndarray, b: np.ndarray, origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    side_a = direction[0] * (a[1] - origin[1]) - direction[1] * (a[0] - origin[0])
    side_b = direction[0] * (b[1] - origin[1]) - direction[1] * (b[0] - origin[0])
    return a + (b - a) * (side_a / (side_a - side_b))


def _polygon_area(polygon: np.ndarray) -> float:
    if len(polygon) < 3:
        return 0.0
    x, z = polygon[:, 0], polygon[:, 1]
    return float(abs(x @ np.roll(z, -1) - z @ np.roll(x, -1)) / 2)
