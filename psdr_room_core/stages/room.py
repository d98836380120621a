"""Room stage (paper §4.2): a room box initialised from the segmented point cloud.

Initialisation fits the floor plane by RANSAC, takes the height from the highest ceiling point (or 1.2×
the highest point when no ceiling is visible), and aligns the box's yaw and extent with RANSAC wall
planes (:mod:`psdr_room_core.room_box`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..artifacts import ROOM_CATEGORIES, PointCloud, RoomBox
from ..dag import StageContext
from ..errors import PsdrRoomError
from ..room_box import RoomInitParams, init_room_box


def room_init(ctx: StageContext, cloud: PointCloud) -> RoomBox:
    """Fit the initial room box and the camera pose in the room's frame (params: ``RoomInitParams``)."""
    fields = {f.name for f in dataclasses.fields(RoomInitParams)} - {"seed"}
    unknown = set(ctx.params) - fields
    if unknown:
        raise PsdrRoomError(f"room_init: unknown parameter(s) {', '.join(sorted(unknown))}; known: {', '.join(sorted(fields))}")
    params = RoomInitParams(**ctx.params, seed=ctx.seed)
    points = {c: cloud.category_points(c).astype(np.float64) for c in ROOM_CATEGORIES}
    try:
        fit = init_room_box(points, params)
    except ValueError as exc:
        raise PsdrRoomError(str(exc)) from None
    return RoomBox(
        camera_to_world=fit.camera_to_world,
        center=fit.center,
        half_size=fit.half_size,
        yaw=fit.yaw,
        ceiling_visible=fit.ceiling_visible,
        extra={
            "camera_height": float(fit.camera_height),
            "floor_plane_camera": np.asarray(fit.floor_plane).tolist(),
            "wall_planes_camera": [np.asarray(p).tolist() for p in fit.wall_planes],
        },
    )
