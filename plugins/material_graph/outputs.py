"""Graph outputs: the maps a material hands to the renderer, with their channels and valid ranges.

``base_color`` [3, H, W] sRGB-encoded albedo in [0, 1]; ``roughness`` [1, H, W] in [0, 1] (principled
roughness, i.e. perceptual); ``metallic`` [1, H, W] in [0, 1]; ``height`` [1, H, W] in [0, 1]; ``normal``
[3, H, W] unit tangent-space normals (OpenGL convention: x right, y up the image, z out of the surface),
components in [−1, 1]. A graph names a node (``node`` or ``node.port``) or a constant for each; missing ones
take :data:`OUTPUTS`' defaults, and a missing normal is derived from the height (strength
:data:`DEFAULT_NORMAL_STRENGTH`) or flat.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

from .nodes import Context, to_channels
from .nodes.filters import height_to_normal

DEFAULT_NORMAL_STRENGTH = 2.0


def _unit(x: torch.Tensor) -> torch.Tensor:
    if x.shape[0] != 3:
        raise ValueError("a normal output needs a 3-channel map (use height_to_normal)")
    return x / torch.linalg.vector_norm(x, dim=0, keepdim=True).clamp(min=1e-8)


@dataclass(frozen=True)
class OutputSpec:
    """One graph output: channels, default (a constant), and how a connected map is finalised."""

    name: str
    channels: int
    default: float | str
    finalise: Callable[[torch.Tensor], torch.Tensor]
    doc: str


OUTPUTS: dict[str, OutputSpec] = {
    "base_color": OutputSpec(
        "base_color", 3, "#808080", lambda x: to_channels(x, 3).clamp(0, 1), "albedo, sRGB-encoded, [0, 1]"
    ),
    "roughness": OutputSpec(
        "roughness", 1, 0.5, lambda x: to_channels(x, 1).clamp(0, 1), "principled roughness, [0, 1]"
    ),
    "metallic": OutputSpec("metallic", 1, 0.0, lambda x: to_channels(x, 1).clamp(0, 1), "metalness, [0, 1]"),
    "height": OutputSpec("height", 1, 0.5, lambda x: to_channels(x, 1).clamp(0, 1), "relief, [0, 1]"),
    "normal": OutputSpec("normal", 3, 0.0, _unit, "unit tangent-space normal (OpenGL: +y up), [−1, 1]"),
}
"""Every output a graph may define, in the order they are written."""


def flat_normal(ctx: Context) -> torch.Tensor:
    n = torch.zeros(3, ctx.height, ctx.width, dtype=ctx.dtype, device=ctx.device)
    n[2] = 1.0
    return n


def normal_from_height(ctx: Context, height: torch.Tensor, strength: float = DEFAULT_NORMAL_STRENGTH) -> torch.Tensor:
    """The normal a graph without a normal output gets from its height."""
    normal = height_to_normal(ctx, {"height": height}, {"strength": torch.tensor(strength, dtype=ctx.dtype)})
    assert isinstance(normal, torch.Tensor)  # a single-output node returns its map
    return normal
