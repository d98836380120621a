"""Procedural material search (§4.4): retrieval of library graphs for photo crops by a texture descriptor,
voting across a part's crops, and the texture-transform search on the crop pairs.

Materials are compared by how they look head-on under the library's thumbnail light
(``material_graph.appearance``). In a crop, a material is laid on the part's surface: every crop pixel is
back-projected with the rendered depth, the crop's points get the planar frame of their least-squares
plane (:func:`psdr_room_core.method.shading.planar_frame`, the renderer's texture mapping), and the graph's tile
covers ``tile_size / scale`` metres of that frame, rotated by ``rotation`` degrees. On the room's planes this
is the exact perspective view of the texture; on curved object parts, the one of their mean plane.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F

from .artifacts import Camera, Rect
from .shading import planar_frame

INDEX_SCALES = (0.75, 1.5, 3.0)
"""Tiles across a retrieval view (the index holds each material at these scales × rotations)."""
INDEX_ROTATIONS = (0.0, 45.0, 90.0)
INDEX_CROP = 128
"""Side of a retrieval view, pixels."""


@dataclass
class MaterialIndex:
    """Texture descriptors of every library material seen at :data:`INDEX_SCALES` × :data:`INDEX_ROTATIONS`,
    and the index's own distance scale."""

    names: list[str]
    descriptors: torch.Tensor
    """[M, V, D]."""
    spacing: float
    """Median distance between two different materials of the library (their nearest views): how far apart
    library materials typically are. :meth:`similarity` is measured against it."""

    @classmethod
    def build(cls, library: Any, descriptor: Any, map_size: int, names: Sequence[str] | None = None) -> MaterialIndex:
        """Describe each of ``names`` (default: the whole library) with the ``texture`` implementation."""
        names = list(names if names is not None else library.names())
        blocks = []
        with torch.no_grad():
            for name in names:
                look = library.appearance(name, map_size)
                views = [
                    tiled_view(library, look, (INDEX_CROP, INDEX_CROP), s, r)
                    for s in INDEX_SCALES
                    for r in INDEX_ROTATIONS
                ]
                blocks.append(descriptor.describe(torch.stack(views)))
            descriptors = torch.stack(blocks)
            apart = []
            for i in range(len(names)):
                d = torch.stack([descriptor.distance(descriptors, v).amin(dim=1) for v in descriptors[i]]).amin(dim=0)
                apart += [float(x) for j, x in enumerate(d) if j != i]
        spacing = float(np.median(apart)) if apart else 1.0
        return cls(names=names, descriptors=descriptors, spacing=spacing)

    def distances(self, descriptor: Any, query: torch.Tensor) -> torch.Tensor:
        """[M] distance of a query descriptor [D] to each material's nearest view."""
        return descriptor.distance(self.descriptors, query).amin(dim=1)

    def similarity(self, distance: float) -> float:
        """``1 − distance / spacing``: 1 for a perfect match, 0 when a query is as far from a material as two
        library materials typically are from each other, negative beyond."""
        return 1.0 - distance / self.spacing if self.spacing > 0 else 0.0


def tiled_view(library: Any, look: torch.Tensor, size: tuple[int, int], scale: float, rotation: float) -> torch.Tensor:
    """An (H, W) head-on view of a tileable image with ``scale`` tiles across its width, rotated."""
    h, w = size
    ys = ((torch.arange(h, dtype=torch.float32) + 0.5) / w)[:, None] - 0.5 * h / w
    xs = ((torch.arange(w, dtype=torch.float32) + 0.5) / w)[None, :] - 0.5
    u, v = rotate(xs * scale, ys * scale, rotation)
    return library.sample(prefiltered(look, scale * look.shape[-1] / w), u, v)


def rotate(u: torch.Tensor, v: torch.Tensor, degrees: float) -> tuple[torch.Tensor, torch.Tensor]:
    a = math.radians(degrees)
    return math.cos(a) * u - math.sin(a) * v, math.sin(a) * u + math.cos(a) * v


def prefiltered(look: torch.Tensor, texels_per_pixel: float) -> torch.Tensor:
    """The tileable image box-filtered by the largest power of two not above ``texels_per_pixel`` (a mip
    level), so that minified views do not alias."""
    level = int(math.floor(math.log2(texels_per_pixel))) if texels_per_pixel > 1 else 0
    factor = 2 ** min(level, int(math.log2(min(look.shape[-2:]))) - 2)
    return F.avg_pool2d(look[None], factor)[0] if factor > 1 else look


def flat_image(colour: Sequence[float], size: tuple[int, int]) -> torch.Tensor:
    return torch.tensor(colour, dtype=torch.float32).reshape(3, 1, 1).expand(3, *size).contiguous()


def vote(per_crop: list[list[tuple[str, float]]]) -> list[tuple[str, float]]:
    """Materials ranked across crops (§4.4): those in the top lists of several crops, if any, else all; by
    their mean similarity over the crops that listed them, best first."""
    listed: dict[str, list[float]] = {}
    for ranked in per_crop:
        for name, sim in ranked:
            listed.setdefault(name, []).append(sim)
    several = {n: s for n, s in listed.items() if len(s) > 1}
    pool = several if several else listed
    return sorted(((n, float(np.mean(s))) for n, s in pool.items()), key=lambda t: -t[1])


# --------------------------------------------------------------------------------- surface mapping
def surface_coordinates(
    camera: Camera, camera_to_world: np.ndarray, depth: np.ndarray, rect: Rect
) -> tuple[torch.Tensor, torch.Tensor] | None:
    """(u, v) metres in the planar frame of the surface seen in ``rect`` (see the module docstring), per
    pixel of the window, from the rendered z-depth at the camera's resolution; None without depth there."""
    x0, y0, x1, y1 = rect
    z = depth[y0:y1, x0:x1].astype(np.float64)
    if not np.all(z > 0):
        return None
    xs, ys = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
    local = np.stack([(xs - camera.cx) / camera.fx * z, (ys - camera.cy) / camera.fy * z, z], axis=-1)
    world = local @ camera_to_world[:3, :3].T + camera_to_world[:3, 3]
    points = world.reshape(-1, 3)
    centre = points.mean(axis=0)
    normal = np.linalg.svd(points - centre, full_matrices=False)[2][-1]
    if np.dot(normal, camera_to_world[:3, 3] - centre) < 0:  # the side the camera sees, as the mesh's normal
        normal = -normal
    tangent, bitangent = planar_frame(normal)
    return (
        torch.from_numpy((world @ tangent).astype(np.float32)),
        torch.from_numpy((world @ bitangent).astype(np.float32)),
    )


def surface_view(
    library: Any,
    look: torch.Tensor,
    coords: tuple[torch.Tensor, torch.Tensor],
    tile_size: float,
    scale: float,
    rotation: float,
) -> torch.Tensor:
    """The material image laid on a crop's surface coordinates (``tile_size / scale`` metres per tile)."""
    u, v = rotate(coords[0] * (scale / tile_size), coords[1] * (scale / tile_size), rotation)
    step = float(torch.median(torch.hypot(u[:, 1:] - u[:, :-1], v[:, 1:] - v[:, :-1]))) if u.shape[1] > 1 else 0.0
    return library.sample(prefiltered(look, step * look.shape[-1]), u, v)


@dataclass(frozen=True)
class TransformFit:
    """The best texture transform of a material on a part's crops."""

    scale: float
    rotation: float
    loss: float
    """Mean descriptor distance over the crops."""
    views: list[torch.Tensor]
    """The material in each crop at that transform (sRGB [3, h, w])."""


def search_transform(
    library: Any,
    descriptor: Any,
    look: torch.Tensor,
    tile_size: float,
    crops: list[tuple[torch.Tensor, torch.Tensor, tuple[torch.Tensor, torch.Tensor]]],
    scales: Sequence[float],
    rotations: Sequence[float],
) -> TransformFit:
    """The (scale, rotation) of §4.4's sweep whose views have the least mean descriptor distance to the
    photo crops; ``crops`` holds (photo crop [3, h, w], its descriptor, its surface coordinates). Each view is
    scaled to the photo crop's mean luminance: the stand-in for the scene's lighting at this stage."""
    best: TransformFit | None = None
    with torch.no_grad():
        for scale in scales:
            for rotation in rotations:
                views, losses = [], []
                for photo, target, coords in crops:
                    view = surface_view(library, look, coords, tile_size, scale, rotation)
                    view = (view * luminance(photo) / max(luminance(view), 1e-4)).clamp(0.0, 1.0)
                    views.append(view)
                    losses.append(float(descriptor.distance(descriptor.describe(view), target)))
                loss = float(np.mean(losses))
                if best is None or loss < best.loss:
                    best = TransformFit(float(scale), float(rotation), loss, views)
    assert best is not None
    return best


def luminance(image: torch.Tensor) -> float:
    """Mean Rec. 709 luma of an sRGB image [3, h, w]."""
    return float((0.2126 * image[0] + 0.7152 * image[1] + 0.0722 * image[2]).mean())
