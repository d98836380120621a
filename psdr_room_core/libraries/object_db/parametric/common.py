"""What the generators share: named colours (woods, fabrics, metals) and legs."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..primitives import MeshBuilder, box, cylinder, tube

RGB = tuple[float, float, float]

WOODS: dict[str, RGB] = {
    "oak": (0.66, 0.48, 0.30),
    "walnut": (0.36, 0.23, 0.14),
    "birch": (0.82, 0.70, 0.52),
    "teak": (0.55, 0.34, 0.19),
    "white": (0.90, 0.89, 0.86),
    "black": (0.14, 0.14, 0.14),
    "grey": (0.55, 0.55, 0.54),
    "cherry": (0.50, 0.25, 0.16),
}
FABRICS: dict[str, RGB] = {
    "grey": (0.55, 0.56, 0.58),
    "beige": (0.80, 0.73, 0.60),
    "navy": (0.18, 0.25, 0.42),
    "sage": (0.52, 0.60, 0.48),
    "mustard": (0.80, 0.60, 0.18),
    "terracotta": (0.72, 0.38, 0.27),
    "charcoal": (0.26, 0.26, 0.28),
    "cream": (0.92, 0.89, 0.80),
    "teal": (0.15, 0.45, 0.48),
    "blush": (0.86, 0.63, 0.61),
    "leather": (0.47, 0.27, 0.15),
    "burgundy": (0.45, 0.12, 0.16),
}
METALS: dict[str, RGB] = {"steel": (0.72, 0.72, 0.74), "black metal": (0.11, 0.11, 0.12), "brass": (0.78, 0.62, 0.32)}


def colour(name: str | Sequence[float], *tables: dict[str, RGB]) -> RGB:
    if not isinstance(name, str):
        return (float(name[0]), float(name[1]), float(name[2]))
    for table in tables:
        if name in table:
            return table[name]
    raise KeyError(f"unknown colour {name!r}")


def add_legs(
    b: MeshBuilder,
    group: str,
    corners: Sequence[tuple[float, float]],
    height: float,
    style: str,
    size: float = 0.045,
    top: float | None = None,
) -> None:
    """Legs from the floor to ``height`` under ``corners`` (x, z): square, round, tapered, splayed,
    block or metal."""
    y1 = height if top is None else top
    for x, z in corners:
        if style == "square":
            b.add(group, box((x, y1 / 2, z), (size, y1, size)))
        elif style == "block":
            b.add(group, box((x, y1 / 2, z), (size * 1.6, y1, size * 1.6)))
        elif style == "round":
            b.add(group, cylinder((x, 0, z), size / 2, y1, 14))
        elif style == "tapered":
            b.add(group, cylinder((x, 0, z), size * 0.28, y1, 14, radius_top=size * 0.55))
        elif style == "splayed":
            out = np.array([x, z]) / max(math.hypot(x, z), 1e-9) * min(0.06, 0.25 * y1)
            b.add(group, tube((x + out[0], 0.0, z + out[1]), (x, y1, z), size * 0.3, 12, radius1=size * 0.5))
        elif style == "metal":
            b.add(group, box((x, y1 / 2, z), (size * 0.5, y1, size * 0.5)))
        else:
            raise ValueError(f"leg style {style!r}")
