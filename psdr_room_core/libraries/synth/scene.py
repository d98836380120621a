"""Random room layouts with exact ground truth (:mod:`.room`): a room box, box-built furniture, ceiling lights
and a camera, drawn so that the photo shows what each case asks for; in the world frame of :mod:`.room`, so a
reconstruction's room box is directly comparable with the truth.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from psdr_room_core.method.artifacts import rotation_y, vec3

from .raycast import raycast
from .room import Box, Furniture, Light, SyntheticRoom, camera_pose

HARD_CASES = ("no_ceiling", "cut_wall", "strong_perspective", "floor_only", "one_wall", "ceiling_only", "close_up")
"""Cases the benchmark must also cover: ceiling out of view, a wall cut by the frame, a wide close-up view, and
photos that show too little of the room to stand it on its floor: the floor alone (looking down 40-70°), one
wall alone, the ceiling alone (looking up 40-70°), a close-up of one piece of furniture."""


Vec3 = tuple[float, float, float]
Part = tuple[Vec3, Vec3]
"""A part of a box-built piece: its local centre and half-size."""


def _furniture_parts(kind: str, rng: np.random.Generator) -> tuple[Vec3, list[Part]]:
    """Footprint half-size and parts (local center, half) of a parametric piece standing at y = 0."""
    parts: list[Part]
    if kind == "table":
        w, d, h = rng.uniform(0.5, 0.9), rng.uniform(0.4, 0.6), rng.uniform(0.7, 0.78)
        leg = 0.03
        parts = [((0, h - 0.02, 0), (w, 0.02, d))]
        parts += [
            ((sx * (w - leg), (h - 0.04) / 2, sz * (d - leg)), (leg, (h - 0.04) / 2, leg))
            for sx in (-1, 1)
            for sz in (-1, 1)
        ]
        return (w, h, d), parts
    if kind == "chair":
        w, seat = rng.uniform(0.2, 0.25), rng.uniform(0.42, 0.48)
        leg = 0.02
        parts = [((0, seat, 0), (w, 0.03, w)), ((0, seat + 0.25, -w + 0.02), (w, 0.25, 0.02))]
        parts += [
            ((sx * (w - leg), seat / 2, sz * (w - leg)), (leg, seat / 2, leg)) for sx in (-1, 1) for sz in (-1, 1)
        ]
        return (w, seat + 0.5, w), parts
    if kind == "cabinet":
        w, h, d = rng.uniform(0.4, 0.8), rng.uniform(0.8, 1.9), rng.uniform(0.2, 0.3)
        return (w, h, d), [((0, h / 2, 0), (w, h / 2, d))]
    if kind == "sofa":
        w, d = rng.uniform(0.8, 1.1), rng.uniform(0.4, 0.5)
        parts = [
            ((0, 0.22, 0), (w, 0.22, d)),
            ((0, 0.6, -d + 0.1), (w, 0.2, 0.1)),
            ((-w + 0.1, 0.52, 0), (0.1, 0.1, d)),
            ((w - 0.1, 0.52, 0), (0.1, 0.1, d)),
        ]
        return (w, 0.8, d), parts
    # bed
    w, d = rng.uniform(0.7, 0.9), rng.uniform(0.95, 1.05)
    parts = [((0, 0.25, 0), (w, 0.25, d)), ((0, 0.55, -d + 0.04), (w, 0.55, 0.04))]
    return (w, 1.1, d), parts


def _place_furniture(room: Box, rng: np.random.Generator, count: int) -> list[Furniture]:
    """Pieces against the walls and in the room, inside it, not overlapping, in front of the camera."""
    placed: list[tuple[float, float, float, float]] = []  # local x, z, half x, half z
    result: list[Furniture] = []
    cam_local = rotation_y(room.yaw).T @ (np.zeros(3) - np.array(room.center))
    hx, _, hz = room.half
    for _ in range(200):
        if len(result) == count:
            break
        kind = str(rng.choice(["table", "chair", "cabinet", "sofa", "bed"]))
        (fw, _, fd), parts = _furniture_parts(kind, rng)
        turn = int(rng.integers(4))  # face into the room from one of the walls, or free-standing
        fw_, fd_ = (fd, fw) if turn % 2 else (fw, fd)
        against = rng.random() < 0.6
        x = rng.uniform(-hx + fw_ + 0.05, hx - fw_ - 0.05) if hx > fw_ + 0.05 else 0.0
        z = rng.uniform(-hz + fd_ + 0.05, hz - fd_ - 0.05) if hz > fd_ + 0.05 else 0.0
        if against:
            side = int(rng.integers(3))  # the back (+z) wall and the side walls: visible from the camera
            if side == 0:
                z = hz - fd_ - 0.02
            else:
                x = (hx - fw_ - 0.02) * (1 if side == 1 else -1)
        if abs(x - cam_local[0]) < fw_ + 0.6 and abs(z - cam_local[2]) < fd_ + 0.6:
            continue  # keep clear of the camera
        if z < cam_local[2] + 0.5:
            continue  # behind or beside the camera: not in the photo
        if any(abs(x - px) < fw_ + pw + 0.05 and abs(z - pz) < fd_ + pd + 0.05 for px, pz, pw, pd in placed):
            continue
        placed.append((x, z, fw_, fd_))
        yaw = room.yaw + turn * math.pi / 2 + rng.normal(0, 0.03)
        origin = np.array(room.center) + rotation_y(room.yaw) @ np.array([x, -room.half[1], z])
        boxes = tuple(
            Box(
                center=vec3(origin + rotation_y(yaw) @ np.array(c)),
                half=vec3(h),
                yaw=yaw,
            )
            for c, h in parts
        )
        albedo = vec3(rng.uniform(0.08, 0.75, 3))
        result.append(Furniture(id=len(result) + 1, label=kind, parts=boxes, albedo=albedo))
    return result


VISIBLE = {
    "random": (True, (3, 4), True),
    "no_ceiling": (True, (2, 4), False),
    "cut_wall": (True, (2, 4), None),
    "strong_perspective": (True, (2, 4), None),
    "floor_only": (True, (0, 0), False),
    "one_wall": (None, (1, 1), False),
    "ceiling_only": (False, (0, 0), True),
    "close_up": (None, (0, 4), None),
}
"""Per case: whether the floor must (True), must not (False) or may (None) be seen, how many walls (least,
most), and the same for the ceiling."""
CLOSE_UP_FRACTION = 0.3
"""A close-up's nearest piece of furniture covers at least this fraction of the photo."""
MIN_FRACTION = 0.02
"""A surface counts as seen when it covers at least this fraction of the photo."""


def generate(
    seed: int, case: str = "random", width: int = 320, height: int = 240, objects: int | None = None
) -> SyntheticRoom:
    """A random room for ``seed`` whose photo shows the floor, the walls and ceiling ``case`` asks for
    (``random`` or one of :data:`HARD_CASES`): an unseen side cannot be reconstructed, so default scenes
    are well observed and the hard cases are explicit. It holds 3-5 pieces of furniture, or as many of
    ``objects`` as fit."""
    if case not in VISIBLE:
        raise ValueError(f"unknown case '{case}'; choose random or one of {', '.join(HARD_CASES)}")
    rng = np.random.default_rng(seed)
    floor, (least, most), ceiling = VISIBLE[case]
    for _ in range(400):
        room = _sample(rng, seed, case, width, height, objects)
        _, ids, segments = raycast(dataclasses.replace(room, width=64, height=48))
        shares = {s.id: (ids == s.id).mean() for s in segments}
        categories = [s.category for s in segments if shares[s.id] >= MIN_FRACTION]
        furniture = max([shares[s.id] for s in segments if s.category not in ("wall", "floor", "ceiling")], default=0)
        if (
            floor in (None, "floor" in categories)
            and least <= categories.count("wall") <= most
            and ceiling in (None, "ceiling" in categories)
            and (case != "close_up" or furniture >= CLOSE_UP_FRACTION)
        ):
            return room
    raise RuntimeError(f"no {case} room satisfying the visibility rules for seed {seed}")


def _sample(
    rng: np.random.Generator, seed: int, case: str, width: int, height: int, objects: int | None = None
) -> SyntheticRoom:
    """One candidate room, camera, furniture and lights."""
    size = np.array([rng.uniform(3.5, 6.5), rng.uniform(2.5, 3.1), rng.uniform(3.5, 6.5)])
    vfov = rng.uniform(45.0, 75.0)
    cam_height = rng.uniform(1.2, 1.7)
    pitch, roll = rng.uniform(-15.0, 0.0), rng.uniform(-3.0, 3.0)
    room_yaw = math.radians(rng.uniform(-25.0, 25.0))
    back = rng.uniform(0.3, 0.7)  # camera distance to the wall behind it (photos are taken from a room's edge)
    lateral = rng.uniform(-0.25, 0.25) * size[0]
    if case == "no_ceiling":
        pitch, vfov, size[1] = rng.uniform(-30.0, -24.0), rng.uniform(45.0, 52.0), rng.uniform(3.2, 3.6)
    elif case == "cut_wall":
        room_yaw = math.radians(rng.choice([-1, 1]) * rng.uniform(38.0, 44.0))
    elif case == "strong_perspective":
        vfov, back = rng.uniform(72.0, 75.0), rng.uniform(0.25, 0.4)
    elif case == "floor_only":  # a big room seen steeply from above: its walls stay beyond the frame
        pitch, vfov, back = -rng.uniform(40.0, 70.0), rng.uniform(40.0, 55.0), rng.uniform(1.5, 2.5)
        size[[0, 2]] = rng.uniform(7.0, 9.0, 2)
    elif case == "ceiling_only":
        pitch, vfov, back = rng.uniform(40.0, 70.0), rng.uniform(40.0, 55.0), rng.uniform(1.5, 2.5)
        size[[0, 2]] = rng.uniform(7.0, 9.0, 2)
    elif case == "one_wall":  # facing a wall from close by, level
        pitch, vfov, room_yaw = rng.uniform(-8.0, 0.0), rng.uniform(40.0, 50.0), math.radians(rng.uniform(-8.0, 8.0))
        back = size[2] - rng.uniform(1.2, 1.8)
    elif case == "close_up":  # one piece of furniture fills the frame
        pitch, vfov = -rng.uniform(25.0, 45.0), rng.uniform(40.0, 55.0)
    if case in (
        "random",
        "cut_wall",
        "strong_perspective",
    ):  # look down enough that the floor shows in front of the far wall
        floor_visible = math.degrees(math.atan(cam_height / (0.6 * (size[2] - back)))) - vfov / 2 + 2.0
        pitch = min(pitch, -floor_visible)
    half = size / 2
    # the camera (at the world origin, above the floor) sits `back` in front of the box's -z wall
    local_camera = np.array([lateral, 0.0, -half[2] + back])
    center = -(rotation_y(room_yaw) @ local_camera)
    center[1] = half[1]
    room = Box(center=vec3(center), half=vec3(half), yaw=room_yaw)
    count = int(rng.integers(3, 6))  # drawn either way, so the default rooms stay as they were
    furniture = _place_furniture(room, rng, count if objects is None else objects)
    light_local = [np.array([0.0, half[1] - 0.01, 0.15 * half[2]])]
    if rng.random() < 0.5:
        light_local.append(np.array([0.0, half[1] - 0.01, 0.6 * half[2]]))
    lights = [
        Light(
            center=vec3(center + rotation_y(room_yaw) @ p),
            half=(0.3, 0.3),
            yaw=room_yaw,
            radiance=float(rng.uniform(8.0, 14.0)),
        )
        for p in light_local
    ]
    albedo = {
        "wall": vec3(rng.uniform(0.45, 0.85, 3)),
        "floor": vec3(rng.uniform(0.15, 0.5, 3)),
        "ceiling": (0.85, 0.85, 0.85),
    }
    return SyntheticRoom(
        seed=seed,
        case=case,
        width=width,
        height=height,
        vfov_deg=float(vfov),
        camera_to_world=camera_pose(cam_height, pitch, roll).tolist(),
        room=room,
        furniture=furniture,
        lights=lights,
        albedo=albedo,
    )
