"""Exact ground-truth depth and panoptic segmentation of a synthetic room by analytic ray casting.

One ray through each pixel centre; the room is hit from inside (the nearest exit among its slabs), the
furniture boxes and light panels from outside. Depth is z-depth along the optical axis.
"""

from __future__ import annotations

import numpy as np

from psdr_room_core.method.artifacts import Segment, rotation_y

from .room import Box, SyntheticRoom

ROOM_SIDES = {
    1: ("floor", "floor"),
    2: ("ceiling", "ceiling"),
    3: ("wall", "wall -x"),
    4: ("wall", "wall +x"),
    5: ("wall", "wall -z"),
    6: ("wall", "wall +z"),
}
FURNITURE_ID0 = 10
LIGHT_ID0 = 100
LIGHT_THICKNESS = 0.01


def pixel_rays(room: SyntheticRoom) -> tuple[np.ndarray, np.ndarray]:
    """World ray origin (3) and directions (H·W×3) scaled so that t is z-depth."""
    u, v = np.meshgrid(np.arange(room.width) + 0.5, np.arange(room.height) + 0.5)
    cam = np.stack([(u - room.width / 2) / room.fy, (v - room.height / 2) / room.fy, np.ones_like(u)], -1).reshape(
        -1, 3
    )
    pose = np.asarray(room.camera_to_world)
    return pose[:3, 3], cam @ pose[:3, :3].T


def _slabs(box: Box, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Entry and exit distances of rays against a box, with the axis of each (in the box frame)."""
    rot = rotation_y(box.yaw)
    o = rot.T @ (origin - np.asarray(box.center))
    d = dirs @ rot
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-np.asarray(box.half) - o) / d
        t2 = (np.asarray(box.half) - o) / d
    near, far = np.minimum(t1, t2), np.maximum(t1, t2)
    return near.max(1), near.argmax(1), far.min(1), far.argmin(1)


def raycast(room: SyntheticRoom) -> tuple[np.ndarray, np.ndarray, list[Segment]]:
    """(z-depth HxW, id map HxW, segments) of the synthetic room, exact at pixel centres."""
    origin, dirs = pixel_rays(room)
    _, _, exit_t, exit_axis = _slabs(room.room, origin, dirs)
    rot = rotation_y(room.room.yaw)
    local_dir = (dirs @ rot)[np.arange(len(dirs)), exit_axis]
    # exit through +side when the local direction is positive on that axis: ids 1..6 = floor, ceiling, walls
    side = {(1, False): 1, (1, True): 2, (0, False): 3, (0, True): 4, (2, False): 5, (2, True): 6}
    ids = np.array([side[(int(a), bool(p))] for a, p in zip(exit_axis, local_dir > 0)], dtype=np.int32)
    depth = exit_t.copy()
    segments = [Segment(id=i, category=c, label=label) for i, (c, label) in ROOM_SIDES.items()]
    occluders: list[tuple[int, Box]] = [(FURNITURE_ID0 + f.id, part) for f in room.furniture for part in f.parts]
    for k, light in enumerate(room.lights):
        panel = Box(center=light.center, half=(light.half[0], LIGHT_THICKNESS / 2, light.half[1]), yaw=light.yaw)
        occluders.append((LIGHT_ID0 + k, panel))
        segments.append(Segment(id=LIGHT_ID0 + k, category="lamp", label="ceiling light"))
    segments += [Segment(id=FURNITURE_ID0 + f.id, category="object", label=f.label) for f in room.furniture]
    for seg_id, box in occluders:
        near, _, far, _ = _slabs(box, origin, dirs)
        hit = (near <= far) & (near > 1e-6) & (near < depth)
        depth[hit], ids[hit] = near[hit], seg_id
    present = set(np.unique(ids).tolist())
    shape = (room.height, room.width)
    return depth.reshape(shape).astype(np.float32), ids.reshape(shape), [s for s in segments if s.id in present]
