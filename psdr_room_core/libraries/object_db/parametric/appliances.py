"""Appliances: refrigerators, microwaves, ovens and ranges, washing machines."""

from __future__ import annotations

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, cylinder, lathe, rot_x, torus, transform
from .common import METALS, colour

FINISHES = {
    "white": (0.9, 0.9, 0.89),
    "steel": METALS["steel"],
    "black": (0.09, 0.09, 0.1),
    "cream": (0.88, 0.85, 0.76),
}
"""Body colours of appliances."""


def refrigerator(
    width: float = 0.7, height: float = 1.8, depth: float = 0.68, style: str = "top_freezer", finish: str = "white"
) -> ObjectMesh:
    """A refrigerator, doors facing +Z: groups ``body``, ``doors`` and ``handles``; ``style`` is single,
    top_freezer, bottom_freezer or side_by_side."""
    if style not in ("single", "top_freezer", "bottom_freezer", "side_by_side"):
        raise ValueError(f"refrigerator: style {style!r}")
    b = MeshBuilder().group("body", FINISHES[finish]).group("doors", FINISHES[finish])
    b.group("handles", colour("steel" if finish != "steel" else "black metal", METALS))
    b.add("body", box((0, height / 2, -0.03), (width, height, depth - 0.06)))
    zf, gap = depth / 2 - 0.03, 0.006
    if style == "side_by_side":
        doors = [
            ((-width / 4, height / 2), (width / 2 - gap, height - 0.02), 1),
            ((width / 4, height / 2), (width / 2 - gap, height - 0.02), -1),
        ]
    elif style == "single":
        doors = [((0.0, height / 2), (width - gap, height - 0.02), 1)]
    else:
        split = height * (0.7 if style == "top_freezer" else 0.38)
        low, high = (split, height - split) if style == "top_freezer" else (split, height - split)
        doors = [
            ((0.0, low / 2), (width - gap, low - 0.015), 1),
            ((0.0, low + high / 2), (width - gap, high - 0.015), 1),
        ]
    for (x, y), (w, h), side in doors:
        b.add("doors", box((x, y, zf), (w, h, 0.06)))
        hx = x + side * (w / 2 - 0.05)
        b.add("handles", box((hx, y, zf + 0.05), (0.025, min(0.6, h * 0.6), 0.03)))
    return b.build()


def microwave(width: float = 0.5, height: float = 0.3, depth: float = 0.38, finish: str = "black") -> ObjectMesh:
    """A countertop microwave, door facing +Z: groups ``body``, ``door`` (its window), ``panel`` (controls)
    and ``handles``."""
    b = MeshBuilder().group("body", FINISHES[finish]).group("door", (0.05, 0.05, 0.06))
    b.group("panel", (0.15, 0.15, 0.16)).group("handles", colour("steel", METALS))
    b.add("body", box((0, height / 2 + 0.01, 0), (width, height, depth)))
    panel = width * 0.25
    door_w = width - panel - 0.02
    y, z = height / 2 + 0.01, depth / 2 + 0.005
    b.add("door", box((-width / 2 + 0.01 + door_w / 2, y, z), (door_w, height - 0.04, 0.01)))
    b.add("panel", box((width / 2 - panel / 2 - 0.01, y, z), (panel, height - 0.04, 0.01)))
    b.add("handles", box((-width / 2 + door_w, height / 2 + 0.01, depth / 2 + 0.02), (0.015, height * 0.6, 0.02)))
    for sx in (-1, 1):
        for sz in (-1, 1):
            b.add("body", cylinder((sx * (width / 2 - 0.04), 0.0, sz * (depth / 2 - 0.04)), 0.015, 0.012, 10))
    return b.build()


def oven(
    kind: str = "range",
    width: float = 0.6,
    height: float = 0.9,
    depth: float = 0.62,
    burners: int = 4,
    finish: str = "steel",
) -> ObjectMesh:
    """A freestanding range (an oven under a cooktop) or a built-in wall oven, door facing +Z: groups
    ``body``, ``door`` (with its window), ``cooktop`` (the hob and burners of a range) and ``handles``."""
    if kind not in ("range", "wall"):
        raise ValueError(f"oven: kind {kind!r}")
    b = MeshBuilder().group("body", FINISHES[finish]).group("door", (0.06, 0.06, 0.07))
    b.group("cooktop", (0.05, 0.05, 0.05)).group("handles", colour("steel", METALS))
    top = height - (0.03 if kind == "range" else 0.0)
    b.add("body", box((0, top / 2, 0), (width, top, depth)))
    door_h = top * (0.55 if kind == "range" else 0.7)
    y0 = 0.1 if kind == "range" else (top - door_h) / 2
    b.add("door", box((0, y0 + door_h / 2, depth / 2 + 0.01), (width - 0.04, door_h, 0.02)))
    b.add("handles", box((0, y0 + door_h - 0.04, depth / 2 + 0.045), (width - 0.12, 0.02, 0.02)))
    if kind == "range":
        b.add("cooktop", box((0, top + 0.01, 0), (width, 0.02, depth)))
        b.add("body", box((0, top + 0.06, -depth / 2 + 0.03), (width, 0.12, 0.04)))  # the control backsplash
        for k in range(burners):
            x = (-1 if k % 2 == 0 else 1) * width * 0.22
            z = (-1 if k < 2 else 1) * depth * 0.2
            b.add("cooktop", lathe([(0.09, 0.0), (0.09, 0.008), (0.0, 0.008)], 20, (x, top + 0.02, z)))
    return b.build()


def washer(width: float = 0.6, height: float = 0.85, depth: float = 0.6, finish: str = "white") -> ObjectMesh:
    """A front-loading washing machine or dryer, door facing +Z: groups ``body``, ``door`` (a round window)
    and ``panel`` (the control strip)."""
    b = MeshBuilder().group("body", FINISHES[finish]).group("door", (0.25, 0.27, 0.3)).group("panel", (0.7, 0.7, 0.72))
    b.add("body", box((0, height / 2, 0), (width, height, depth)))
    b.add("panel", box((0, height - 0.07, depth / 2 + 0.004), (width - 0.02, 0.12, 0.01)))
    r = width * 0.32
    centre_y = (height - 0.14) / 2 + 0.02
    b.add("door", transform(cylinder((0, 0, 0), r, 0.03, 32), rot_x(90), translate=(0, centre_y, depth / 2)))
    b.add("panel", transform(torus((0, 0, 0), r, 0.025, 32, 8), rot_x(90), translate=(0, centre_y, depth / 2 + 0.03)))
    return b.build()
