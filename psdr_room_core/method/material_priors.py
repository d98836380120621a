"""What fitted materials may be (priors of eq. 4): the ranges a real material of the kind has, so that a scene
that matches the photo from its one camera still holds when a light or the camera moves.

**Painted surfaces** (the room's walls and ceiling). Paint makers publish each colour's light reflectance value
(LRV: the share of visible light a painted surface reflects, luminance-weighted, 0 for ideal black to 100 for
ideal white). In practice the blackest paint has an LRV of about 5 and the whitest reaches the low 90s, and dark
wall colours in use sit near 10 (e.g. PPG "Bigfoot", LRV 10, shown on a living-room wall):
https://e-designcompany.com/what-is-light-reflectance-value-of-colour/. A fitted wall or ceiling therefore keeps
the luminance of its (linear) base colour within ``albedo`` (LRVs of 10 to 90), and no channel above the top of
that range (the whitest paints are spectrally flat: a wall cannot be whiter than white in red and blue by giving
up green). Its hue is the photo's: each channel of its chromaticity (the colour over its brightest channel) stays
within a factor ``hue_range`` of the initial one, so that a fit held in the luminance range cannot escape along
the hue (a dark wall turned olive green, whose red and blue stay black at a luminance of 0.1; a white ceiling
turned pink, whose red and blue pass 0.9). Flat to eggshell wall paint reflects much light but no images (https://www.mpi.net, "Gloss and Light
Reflectance"): its binder (refractive index about 1.5) reflects 4% at normal incidence, a principled
``specular`` of 0.5; the sheen is in the roughness. A wall or ceiling keeps ``specular`` at most
``max_specular`` (0.5), whatever its material (paint, plaster, wallpaper, brick).

**Metals**: the scene's BSDF has no metallic input; no part is fitted as a metal (a retrieved metal graph renders
as its colour and roughness).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .artifacts import PartAppearance, vec3
from .params import PaintPrior

LUMINANCE = (0.2126, 0.7152, 0.0722)
"""Rec. 709 / sRGB luminance weights of linear RGB: how LRV weighs a colour's reflectance."""


def painted(part: str) -> bool:
    """Whether a scene part is a painted room surface: a wall or the ceiling."""
    return part == "ceiling" or part.startswith("wall_")


def within_paint(part: PartAppearance, prior: PaintPrior) -> PartAppearance:
    """``part`` brought into ``prior`` if it is a wall or the ceiling: a homogeneous one's base colour scaled (hue
    kept) to the nearest luminance in range with no channel above its top, any one's specular lowered to the
    highest allowed. The fit starts
    there, and a wall the camera does not see (not optimised) is exported so."""
    if not painted(part.part):
        return part
    specular = min(part.specular, prior.max_specular)
    if part.kind != "homogeneous":
        return replace(part, specular=specular)
    colour = np.maximum(np.asarray(part.base_color, np.float64), 1e-6)
    lum = float(colour @ LUMINANCE)
    low, high = prior.albedo
    scaled = colour * min(min(max(lum, low), high) / lum, high / colour.max())  # hue kept
    return replace(part, base_color=vec3(scaled), specular=specular)
