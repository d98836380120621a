"""A network's 3D boxes (:class:`~.artifacts.SeenBox`) in the scene: what the view search takes from them.

A network that regresses an object's box from the photo alone (``segmentation=eyes`` and ``layout_eyes``) sees it
where the depth map may only guess: an object cut by the frame, one whose feet are hidden, a chair behind a table.
Its depths are metric for a camera it knows only by its focal, so the scene's depths and the network's can differ
by a common factor (a wrong camera height, a room scaled to fit): the boxes are brought to the scene's scale by
the median, over the photo's objects, of the depth the scene gives an object's visible surface against the depth
the network gives the surface of its box nearest the camera. What they keep is what a single photo tells a
network best: which object is nearer and by how much, and which way each one faces.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .artifacts import SeenBox
from .silhouette import world_to_camera


@dataclass(frozen=True)
class SeenPrior:
    """A network's box of one object in the world frame, at the scene's scale."""

    center: np.ndarray
    """(3,) world position of the box's centre."""
    depth: float
    """The centre's camera depth (z, metres)."""
    size: np.ndarray
    """(3,) width, height, depth along the object's own axes (metres)."""
    yaw: float
    """World yaw of the object's front (the placements' convention: the model's +Z turned by ``yaw`` about up)."""
    confidence: float
    """How sure the network is of the yaw, in [0, 1]."""


def heading(camera_to_world: np.ndarray) -> float:
    """The camera's heading: the world yaw of its optical axis projected on the floor."""
    forward = np.asarray(camera_to_world)[:3, 2]
    return math.atan2(float(forward[0]), float(forward[2]))


def near_face_depth(box: SeenBox) -> float:
    """Camera depth of where the ray through the box's centre enters it: the centre's less half the box's extent
    along that ray (its width and depth, turned by the observation angle)."""
    x, _, z = box.center
    alpha = box.yaw + math.atan2(x, z)
    width, _, depth = box.size
    return z - 0.5 * (abs(math.cos(alpha)) * depth + abs(math.sin(alpha)) * width)


def depth_ratio(depths: Mapping[int, float], boxes: Mapping[int, SeenBox]) -> float | None:
    """The median, over the segments with a box and a depth (``depths[segment id]``, of its visible surface), of
    that depth over the box's :func:`near_face_depth`; None where no segment has both."""
    ratios = [depths[k] / near_face_depth(box) for k, box in boxes.items() if k in depths and near_face_depth(box) > 0]
    return float(np.median(ratios)) if ratios else None


def scene_scale(boxes: Mapping[int, SeenBox], points: Mapping[int, np.ndarray], camera_to_world: np.ndarray) -> float:
    """The factor from the network's depths to the scene's: the :func:`depth_ratio` of the objects' points (world,
    ``points[segment id]``, their median camera depth) to their boxes (1: none)."""
    depths = {
        k: float(np.median(world_to_camera(seen, camera_to_world)[:, 2])) for k, seen in points.items() if len(seen)
    }
    ratio = depth_ratio(depths, boxes)
    return 1.0 if ratio is None else ratio


def seen_prior(box: SeenBox, camera_to_world: np.ndarray, scale: float) -> SeenPrior:
    """``box`` (the photo's camera frame) in the world of a camera posed by ``camera_to_world``, its position and
    size times ``scale`` (:func:`scene_scale`)."""
    c2w = np.asarray(camera_to_world, np.float64)
    center = scale * np.asarray(box.center)
    return SeenPrior(
        center=c2w[:3, :3] @ center + c2w[:3, 3],
        depth=float(center[2]),
        size=scale * np.asarray(box.size),
        yaw=heading(c2w) + box.yaw,
        confidence=box.confidence,
    )
