"""``depth=layout``: depth from a box room fitted to the segmentation, objects standing on its floor."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from psdr_room_core.method.artifacts import Camera, DepthMap, Image, Panoptic

from .fit import Layout, fit_layout
from .settings import LayoutDepthSettings

ROOM = ("wall", "floor", "ceiling")


def object_depth(
    mask: np.ndarray, rays: np.ndarray, room_depth: np.ndarray, box: tuple[float, float, float, float] | None = None
) -> tuple[np.ndarray, bool]:
    """(Z-depth (H, W) of an object's pixels (0 elsewhere) on the vertical plane through its floor contact,
    whether it has one).

    The contact is the lowest mask pixel (median column of the lowest row), or, for a box-prompted segment,
    that column on its prompt ``box``'s bottom row (a box-prompted cut loses thin legs: the mask ends at the
    seat, the box at the floor); it is put on the floor ``y = -1`` of the frame; the plane faces the camera
    (normal = the contact ray's horizontal direction). An object whose contact ray misses the floor, or lands
    beyond the room, has none: it lies just in front of the room surface (2% nearer). Depths never exceed the
    room's.
    """
    rows = np.flatnonzero(mask.any(axis=1))
    col = int(np.median(np.flatnonzero(mask[rows[-1]])))
    bottom = rows[-1] if box is None else min(mask.shape[0] - 1, max(rows[-1], int(np.ceil(box[3])) - 1))
    ray = rays[bottom, col]
    depth = np.zeros(mask.shape, dtype=np.float32)
    behind = 0.98 * room_depth
    if ray[1] >= 0 or -1.0 / ray[1] > 1.0001 * room_depth[bottom, col]:
        depth[mask] = behind[mask]
        return depth, False
    contact = ray * (-1.0 / ray[1])
    normal = np.array([ray[0], 0.0, ray[2]])
    normal /= np.linalg.norm(normal)
    along = rays[mask] @ normal
    t = np.where(along > 1e-6, float(contact @ normal) / np.maximum(along, 1e-6), np.inf)
    depth[mask] = np.minimum(t, room_depth[mask])
    return depth, True


def shaped_by(
    relative: np.ndarray, plane: np.ndarray, mask: np.ndarray, rays: np.ndarray, room: np.ndarray, extent: float
) -> np.ndarray:
    """An object's depth (H, W; 0 off its mask) from its contact ``plane`` (:func:`object_depth`) shaped by a
    network's ``relative`` depth: that depth scaled to the plane's on the mask's lowest rows (where it meets
    the floor), each pixel no nearer than the plane, no farther behind it than ``extent`` times the object's
    width on it, and never beyond the ``room``. So a bed seen from its foot recedes to its headboard, where the
    plane alone stands it up as a slab."""
    rows = np.flatnonzero(mask.any(axis=1))
    lowest = mask & (np.arange(mask.shape[0])[:, None] >= rows[-1] - max(2, (rows[-1] - rows[0]) // 10))
    scaled = scaled_to(relative, plane, lowest)
    on_plane = rays[mask][:, [0, 2]] * plane[mask][:, None]  # (N, 2) x, z of the pixels on the plane
    spread = on_plane - on_plane.mean(axis=0)
    along = np.linalg.eigh(spread.T @ spread)[1][:, -1]  # the plane's horizontal direction
    width = float(np.ptp(spread @ along))
    near = plane[mask]
    depth = np.zeros_like(plane)
    depth[mask] = np.clip(scaled[mask], near, np.maximum(near, np.minimum(room[mask], near + extent * width)))
    return depth


def scaled_to(relative: np.ndarray, depth: np.ndarray, where: np.ndarray) -> np.ndarray:
    """``relative`` (a depth up to scale) times the scale that matches it to ``depth`` on the pixels ``where``
    both are positive: the median of their log ratios there (1 when there are none)."""
    both = where & (relative > 0) & (depth > 0) & np.isfinite(depth)
    if not both.any():
        return relative
    return relative * float(np.exp(np.median(np.log(depth[both]) - np.log(relative[both]))))


class LayoutDepth:
    """Depth without a network: the room box fitted to the segmentation's wall/floor/ceiling and the
    photo's lines, objects placed on its floor; metres if the camera is ``camera_height_m`` above it."""

    def __init__(self, **settings: Any) -> None:
        """``settings``: the fields of :class:`~.settings.LayoutDepthSettings`."""
        self.settings = LayoutDepthSettings(**settings)

    def fit(self, image: Image, camera: Camera, panoptic: Panoptic) -> Layout:
        """The box room used for the depth."""
        return fit_layout(image, camera, self.settings, panoptic=panoptic)

    def estimate(
        self, image: Image, camera: Camera, panoptic: Panoptic, photo: Path, relative: np.ndarray | None = None
    ) -> DepthMap:
        """The depth map; ``relative``: a network's depth of the photo (H, W) up to scale, which gives the objects
        with no floor contact theirs (:func:`scaled_to`) instead of the room surface's behind them, and those
        with one their shape behind their contact plane (:func:`shaped_by`, ``relative_extent``; those at least
        ``relative_min_width`` of the photo wide)."""
        fitted = self.fit(image, camera, panoptic)
        _, room = fitted.trace(camera, image.width, image.height)
        depth = room.copy()
        rays = fitted.frame.rays(camera, image.width, image.height)
        unplaced = []
        for segment in panoptic.segments:
            if segment.category in ROOM:
                continue
            mask = panoptic.ids == segment.id
            if mask.any():
                placed, on_floor = object_depth(mask, rays, room, segment.box)
                columns = np.flatnonzero(mask.any(axis=0))
                wide = columns[-1] - columns[0] + 1 >= self.settings.relative_min_width * image.width
                if on_floor and relative is not None and wide and self.settings.relative_extent > 0:
                    placed = shaped_by(relative, placed, mask, rays, room, self.settings.relative_extent)
                depth = np.where(mask, placed, depth)
                if not on_floor:
                    unplaced.append(segment.id)
        if relative is not None and unplaced:
            lost = np.isin(panoptic.ids, unplaced)
            depth = np.where(lost, np.minimum(scaled_to(relative, depth, ~lost & (panoptic.ids > 0)), room), depth)
            unplaced = []
        valid = np.isfinite(depth) & (depth > 0)
        depth = np.where(valid, depth * self.settings.camera_height_m, 0.0).astype(np.float32)
        return DepthMap(
            depth=depth,
            valid=valid,
            metric=False,
            source=f"layout (box {np.round(fitted.box, 2).tolist()} camera heights; "
            f"camera {self.settings.camera_height_m} m above the floor assumed)",
            unplaced=tuple(unplaced),
        )


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import DepthEstimator

    _LayoutDepth_is_a_depth: type[DepthEstimator] = LayoutDepth
