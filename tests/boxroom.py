"""Tiny numpy ray caster of a textured box room, for testing camera estimation.

The room is 5 x 3 x 4 m (x right, y up, z towards the default viewer) with a planked
floor, a panelled ceiling, a door, a window and a picture on the walls, and a few boxes
as furniture (one turned 30 degrees, as non-Manhattan clutter). Surfaces are Lambert
shaded by a point light so walls, floor and ceiling differ in brightness. The image is
rendered with 2x2 supersampling, then slightly blurred and given Gaussian noise.
"""

from __future__ import annotations

import numpy as np

ROOM_MIN = np.array([-2.5, 0.0, -2.0])
ROOM_MAX = np.array([2.5, 3.0, 2.0])
LIGHT = np.array([0.5, 2.8, 0.5])
FACE_ALBEDO = [  # left wall, right wall, floor, ceiling, back wall, front wall
    (0.7, 0.65, 0.5),
    (0.55, 0.65, 0.7),
    (0.5, 0.4, 0.3),
    (0.85, 0.85, 0.82),
    (0.7, 0.7, 0.6),
    (0.6, 0.55, 0.65),
]

# (min corner, max corner, yaw in degrees about the box centre, RGB albedo)
BOXES = [
    (np.array([0.4, 0.0, -1.3]), np.array([1.6, 0.75, -0.5]), 0.0, (0.55, 0.35, 0.2)),  # table
    (np.array([1.3, 0.0, -2.0]), np.array([2.4, 1.9, -1.5]), 0.0, (0.75, 0.72, 0.65)),  # cabinet
    (np.array([-2.0, 0.0, -0.9]), np.array([-1.2, 0.45, 0.1]), 0.0, (0.3, 0.4, 0.6)),  # bench
    (np.array([-0.9, 0.0, 0.6]), np.array([-0.3, 0.5, 1.2]), 30.0, (0.6, 0.25, 0.25)),  # turned crate
]


def render_box_room(
    vfov_deg: float,
    width: int = 480,
    height: int = 360,
    yaw_deg: float = 0.0,
    pitch_deg: float = 0.0,
    roll_deg: float = 0.0,
    position: tuple[float, float, float] = (0.2, 1.5, 1.7),
    noise: float = 0.01,
    seed: int = 0,
) -> np.ndarray:
    """Render the room; returns float32 HxWx3 in [0, 1].

    The camera looks along -z at yaw 0; positive pitch looks up, positive yaw turns left.
    Principal point at the image centre, square pixels.
    """
    ss = 2
    rays = _camera_rays(vfov_deg, width * ss, height * ss, yaw_deg, pitch_deg, roll_deg)
    origin = np.asarray(position, dtype=np.float64)
    image = _shade(origin, rays.reshape(-1, 3)).reshape(height * ss, width * ss, 3)
    image = image.reshape(height, ss, width, ss, 3).mean(axis=(1, 3))
    image = _blur(image)
    image += np.random.default_rng(seed).normal(0.0, noise, image.shape)
    return np.clip(image, 0.0, 1.0).astype(np.float32)


def _camera_rays(vfov_deg: float, width: int, height: int, yaw: float, pitch: float, roll: float) -> np.ndarray:
    """(H, W, 3) world ray directions through pixel centres."""
    focal = height / (2.0 * np.tan(np.radians(vfov_deg) / 2.0))
    u, v = np.meshgrid(np.arange(width) - (width - 1) / 2.0, np.arange(height) - (height - 1) / 2.0)
    cam = np.stack([u / focal, v / focal, np.ones_like(u)], axis=-1)  # x right, y down, z forward
    to_world = _rot_y(yaw) @ _rot_x(pitch) @ _rot_z(roll) @ np.diag([1.0, -1.0, -1.0])
    dirs = cam @ to_world.T
    return dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)


def _rot_x(deg: float) -> np.ndarray:
    """Rotation about the x axis."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_y(deg: float) -> np.ndarray:
    """Rotation about the y (up) axis."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(deg: float) -> np.ndarray:
    """Rotation about the z axis."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _shade(origin: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Colour of the first surface hit by each ray."""
    t, normal, albedo = _hit_room(origin, dirs)
    for lo, hi, yaw, colour in BOXES:
        tb, nb = _hit_box(origin, dirs, lo, hi, yaw)
        closer = tb < t
        t[closer], normal[closer] = tb[closer], nb[closer]
        albedo[closer] = colour
    points = origin + t[:, None] * dirs
    to_light = LIGHT - points
    dist = np.linalg.norm(to_light, axis=1, keepdims=True)
    lambert = np.clip(np.sum(normal * to_light / dist, axis=1, keepdims=True), 0.0, None)
    return albedo * (0.25 + 0.9 * lambert * 4.0 / (1.0 + dist**2))


def _hit_room(origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exit distance, inward normal and textured albedo of the room's six faces."""
    safe = np.where(np.abs(dirs) < 1e-12, 1e-12, dirs)
    t_faces = np.where(dirs > 0, (ROOM_MAX - origin) / safe, (ROOM_MIN - origin) / safe)  # (N, 3)
    t = np.minimum(np.minimum(t_faces[:, 0], t_faces[:, 1]), t_faces[:, 2])
    axis = np.where(t_faces[:, 0] == t, 0, np.where(t_faces[:, 1] == t, 1, 2))
    sign = np.sign(dirs[np.arange(len(dirs)), axis])
    normal = np.zeros_like(dirs)
    normal[np.arange(len(dirs)), axis] = -sign
    p = origin + t[:, None] * dirs
    albedo = np.empty_like(dirs)
    for face, (ax, sg) in enumerate([(0, -1), (0, 1), (1, -1), (1, 1), (2, -1), (2, 1)]):
        m = (axis == ax) & (sign == sg)
        albedo[m] = _face_texture(face, p[m])
    return t, normal, albedo


def _face_texture(face: int, p: np.ndarray) -> np.ndarray:
    """Albedo of room face ``face`` (0/1: left/right wall, 2/3: floor/ceiling, 4/5: back/front wall)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    out = np.tile(np.array(FACE_ALBEDO[face]), (len(p), 1))
    if face == 2:  # planks 0.2 m wide along x, joints every 1 m, staggered
        plank = np.floor(z / 0.2)
        shift = (plank * 0.37) % 1.0
        piece = np.floor(x + shift)
        tone = 0.8 + 0.4 * ((plank * 7 + piece * 13) % 5) / 4.0
        out *= tone[:, None]
        seam = (np.abs(z / 0.2 - np.round(z / 0.2)) < 0.04) | (np.abs(x + shift - np.round(x + shift)) < 0.01)
        out[seam] *= 0.5
    elif face == 3:  # ceiling panels 0.6 m grid
        grid = (np.abs(x / 0.6 - np.round(x / 0.6)) < 0.03) | (np.abs(z / 0.6 - np.round(z / 0.6)) < 0.03)
        out[grid] *= 0.6
    elif face == 0:  # door with frame on the left wall
        frame = (z > -1.15) & (z < 0.05) & (y < 2.25)
        door = (z > -1.05) & (z < -0.05) & (y < 2.15)
        out[frame] = (0.3, 0.2, 0.1)
        out[door] = (0.55, 0.35, 0.2)
    elif face == 4:  # window with a mullion cross on the back wall
        frame = (x > -1.8) & (x < -0.2) & (y > 0.9) & (y < 2.3)
        glass = (x > -1.7) & (x < -0.3) & (y > 1.0) & (y < 2.2)
        mullion = (np.abs(x + 1.0) < 0.04) | (np.abs(y - 1.6) < 0.04)
        out[frame] = (0.95, 0.95, 0.95)
        out[glass & ~mullion] = (0.45, 0.6, 0.85)
        skirting = y < 0.12
        out[skirting] = (0.35, 0.3, 0.25)
    elif face == 1:  # picture on the right wall
        pic = (z > -1.2) & (z < 0.2) & (y > 1.2) & (y < 2.1)
        out[pic] = (0.2, 0.3, 0.25)
    return out


def _hit_box(
    origin: np.ndarray, dirs: np.ndarray, lo: np.ndarray, hi: np.ndarray, yaw: float
) -> tuple[np.ndarray, np.ndarray]:
    """Entry distance (inf on a miss) and outward normal of a box turned by ``yaw`` about y."""
    centre = (lo + hi) / 2.0
    rot = _rot_y(yaw)
    o = (origin - centre) @ rot  # box frame
    d = dirs @ rot
    half = (hi - lo) / 2.0
    safe = np.where(np.abs(d) < 1e-12, 1e-12, d)
    t1, t2 = (-half - o) / safe, (half - o) / safe
    t_near, t_far = np.minimum(t1, t2), np.maximum(t1, t2)
    t_enter = np.maximum(np.maximum(t_near[:, 0], t_near[:, 1]), t_near[:, 2])
    t_exit = np.minimum(np.minimum(t_far[:, 0], t_far[:, 1]), t_far[:, 2])
    axis = np.where(t_near[:, 0] == t_enter, 0, np.where(t_near[:, 1] == t_enter, 1, 2))
    hit = (t_enter <= t_exit) & (t_enter > 1e-6)
    normal = np.zeros_like(d)
    normal[np.arange(len(d)), axis] = -np.sign(d[np.arange(len(d)), axis])
    return np.where(hit, t_enter, np.inf), normal @ rot.T


def _blur(image: np.ndarray) -> np.ndarray:
    """Separable [1, 2, 1] / 4 blur with edge replication."""
    for axis in (0, 1):
        first, last = np.take(image, [0], axis=axis), np.take(image, [-1], axis=axis)
        padded = np.concatenate([first, image, last], axis=axis)
        n = image.shape[axis]
        image = (
            np.take(padded, range(0, n), axis=axis)
            + 2 * np.take(padded, range(1, n + 1), axis=axis)
            + np.take(padded, range(2, n + 2), axis=axis)
        ) / 4.0
    return image


def checker_floor(
    vfov: float,
    pitch: float,
    tile: float,
    yaw: float = 20.0,
    width: int = 320,
    height: int = 240,
    noise_seed: int = 0,
) -> np.ndarray:
    """A floor of big black and white tiles (``tile`` metres) filling the view of a camera 1.5 m above it, looking
    ``pitch`` degrees down: two families of a few long lines, no vertical one; sensor noise drawn from
    ``noise_seed``."""
    focal = height / (2 * np.tan(np.radians(vfov) / 2))
    ys, xs = np.mgrid[0 : 2 * height, 0 : 2 * width] / 2.0 + 0.25  # 2x2 rays per pixel
    rays = np.stack([(xs - width / 2) / focal, (ys - height / 2) / focal, np.ones_like(xs)], -1)  # y down, z ahead
    p, q = np.radians(pitch), np.radians(yaw)
    down = np.array([[1, 0, 0], [0, np.cos(p), np.sin(p)], [0, -np.sin(p), np.cos(p)]])
    turn = np.array([[np.cos(q), 0, np.sin(q)], [0, 1, 0], [-np.sin(q), 0, np.cos(q)]])
    world = rays @ (turn @ down).T
    hit = 1.5 / np.maximum(world[..., 1], 1e-6)
    tiles = (np.floor(world[..., 0] * hit / tile) + np.floor(world[..., 2] * hit / tile)) % 2
    grey = np.where(world[..., 1] > 0, 0.35 + 0.3 * tiles, 0.8).reshape(height, 2, width, 2).mean(axis=(1, 3))
    grey += np.random.default_rng(noise_seed).normal(0.0, 0.04, grey.shape)
    return np.clip(np.repeat(grey[..., None], 3, axis=-1), 0.0, 1.0).astype(np.float32)
