"""What the eyes network's 3D heads mean, in numpy: each piece of furniture's box in the camera frame, read at its
pixels, and the targets a data-engine sample gives them.

Conventions (those of :mod:`psdr_room_core.libraries.synth.instances`): camera frame OpenCV (x right, y down, z
forward), metres; a box's yaw is the turn about world up from the camera's heading to the model's front (0: it faces
away from the camera). What a picture shows of a box, and so what the heads predict at its pixels, is:

    box_depth     log(z · REFERENCE_FOCAL / f): the centre's z-depth as a camera of focal REFERENCE_FOCAL (input
                  pixels) would see an object of that apparent size; f is the photo's focal in input pixels
    box_size      log of the size (w, h, d) along the model's own axes, metres
    yaw_bin       logits of YAW_BINS bins of the observation angle α = yaw + atan2(x, z) (the yaw relative to
                  the ray through the centre: an object turned with the ray looks the same)
    yaw_residual  per bin, α's offset from the bin's centre in half-bin widths, [-1, 1]
    amodal        distances from the pixel to the whole box's left, top, right and bottom edges in the image
                  (the projected 3D box, also where the frame or another object hides it), in AMODAL_UNIT label
                  pixels
    embedding     EMBEDDING numbers whose mean over an instance, normalised, lies near its catalogue model's
                  (the training's model proxies, shipped as the catalogue file)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .decode import softmax

YAW_BINS = 12
EMBEDDING = 16
REFERENCE_FOCAL = 240.0 / (2.0 * math.tan(math.radians(30.0)))
"""The focal (input pixels, 240 rows) of a 60° vertical field of view: depths are predicted as this camera's."""
AMODAL_UNIT = 16.0
"""Label pixels per unit of the amodal head."""
BOX_OUTPUTS = {
    "box_depth": 1,
    "box_size": 3,
    "yaw_bin": YAW_BINS,
    "yaw_residual": YAW_BINS,
    "amodal": 4,
    "embedding": EMBEDDING,
}
"""The 3D heads' outputs: name → channels."""
CATALOGUE = "eyes_models.npz"
"""The file beside a network with its catalogue models' unit embeddings (``model_ids``, ``embeddings``)."""


def wrap(angle: np.ndarray | float) -> np.ndarray:
    """Angles (radians) in [-π, π)."""
    return (np.asarray(angle) + math.pi) % (2 * math.pi) - math.pi


def observation_angle(yaw: np.ndarray | float, center: np.ndarray) -> np.ndarray:
    """α of boxes with heading-relative ``yaw`` and camera-frame ``center`` (..., 3)."""
    return wrap(np.asarray(yaw) + np.arctan2(center[..., 0], center[..., 2]))


def yaw_of(alpha: np.ndarray | float, center: np.ndarray) -> np.ndarray:
    """The heading-relative yaw of boxes seen at observation angle ``alpha`` with camera-frame ``center``."""
    return wrap(np.asarray(alpha) - np.arctan2(center[..., 0], center[..., 2]))


def bin_centres() -> np.ndarray:
    """The yaw bins' centres (radians)."""
    return -math.pi + (np.arange(YAW_BINS) + 0.5) * 2 * math.pi / YAW_BINS


def yaw_targets(alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(bin index, residual in half-bin widths) of observation angles ``alpha``."""
    width = 2 * math.pi / YAW_BINS
    index = np.clip(np.floor((wrap(alpha) + math.pi) / width).astype(np.int64), 0, YAW_BINS - 1)
    return index, wrap(alpha - bin_centres()[index]) / (width / 2)


def amodal_box(corners: np.ndarray, fx: float, fy: float, cx: float, cy: float, near: float = 0.1) -> np.ndarray:
    """(x0, y0, x1, y1): the image extent of a box's camera-frame ``corners`` (a corner nearer than ``near`` is
    taken at ``near``: a box reaching behind the camera spans far beyond the frame)."""
    z = np.maximum(corners[:, 2], near)
    u, v = fx * corners[:, 0] / z + cx, fy * corners[:, 1] / z + cy
    return np.array([u.min(), v.min(), u.max(), v.max()])


@dataclass(frozen=True)
class Box3D:
    """One instance's 3D box as the heads see it: centre (camera frame, m), size (w, h, d, m), heading-relative
    yaw (radians), the yaw's confidence (its bin's probability), the amodal image box (x0, y0, x1, y1, input
    pixels) and the unit embedding."""

    center: np.ndarray
    size: np.ndarray
    yaw: float
    yaw_confidence: float
    amodal: np.ndarray
    embedding: np.ndarray


def read_box(out: dict[str, np.ndarray], mask: np.ndarray, fx: float, fy: float, stride: int = 4) -> Box3D:
    """The box of the instance on ``mask`` (the outputs' resolution) from one image's outputs ([C, h, w] each),
    for a photo whose focal is (``fx``, ``fy``) input pixels, its principal point at the input's centre. The
    centre lies on the ray through the amodal box's middle."""
    ys, xs = np.nonzero(mask)
    mean = {name: out[name][:, ys, xs].mean(axis=1) for name in ("box_depth", "box_size", "yaw_residual", "embedding")}
    probabilities = softmax(out["yaw_bin"][:, ys, xs]).mean(axis=1)
    k = int(probabilities.argmax())
    alpha = float(wrap(bin_centres()[k] + np.clip(mean["yaw_residual"][k], -1.0, 1.0) * math.pi / YAW_BINS))
    px, py = xs + 0.5, ys + 0.5
    reach = AMODAL_UNIT * out["amodal"][:, ys, xs]
    amodal = np.array([(px - reach[0]).mean(), (py - reach[1]).mean(), (px + reach[2]).mean(), (py + reach[3]).mean()])
    amodal *= stride
    height, width = (n * stride for n in mask.shape)
    depth = float(np.exp(mean["box_depth"][0]) * fy / REFERENCE_FOCAL)
    ray = np.array([((amodal[0] + amodal[2]) / 2 - width / 2) / fx, ((amodal[1] + amodal[3]) / 2 - height / 2) / fy, 1])
    center = ray * depth
    return Box3D(
        center=center,
        size=np.exp(mean["box_size"]),
        yaw=float(yaw_of(alpha, center)),
        yaw_confidence=float(probabilities[k]),
        amodal=amodal,
        embedding=mean["embedding"] / max(float(np.linalg.norm(mean["embedding"])), 1e-9),
    )
