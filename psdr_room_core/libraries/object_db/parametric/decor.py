"""Decor: potted plants, pictures, mirrors and boards on the wall."""

from __future__ import annotations

import math

import numpy as np

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, cylinder, lathe, rot_x, rot_y, sphere, transform
from .common import FABRICS, METALS, WOODS, colour


def plant(
    pot: str = "taper", height: float = 0.9, foliage: str = "bush", pot_colour: str = "terracotta", leaves: str = "sage"
) -> ObjectMesh:
    """A potted plant: groups ``pot``, ``soil`` and ``foliage`` (a bush of blobs, a tall spiky plant, or a
    small tree with a trunk)."""
    b = MeshBuilder().group("pot", colour(pot_colour, FABRICS, WOODS)).group("soil", (0.25, 0.18, 0.12))
    b.group("foliage", colour(leaves, FABRICS) if leaves in FABRICS else (0.22, 0.45, 0.2))
    b.group("trunk", colour("walnut", WOODS))
    r, ph = 0.16 if height > 0.7 else 0.1, 0.3 if height > 0.7 else 0.16
    if pot == "taper":
        b.add("pot", lathe([(r * 0.7, 0.0), (r, ph), (r * 1.05, ph), (r * 1.05, ph + 0.02)], 28))
    elif pot == "cylinder":
        b.add("pot", cylinder((0, 0, 0), r, ph + 0.02, 28))
    else:  # bowl
        b.add("pot", lathe([(r * 0.5, 0.0), (r * 0.95, ph * 0.45), (r, ph * 0.8), (r * 0.85, ph + 0.02)], 28))
    b.add("soil", cylinder((0, ph - 0.01, 0), r * 0.95, 0.04, 28))
    top = ph + 0.02
    crown = height - top
    if foliage == "bush":
        for k in range(9):
            a = math.radians(40 * k)
            rr = r * (0.2 + 0.9 * ((k * 5) % 9) / 9)
            y = top + crown * (0.3 + 0.5 * ((k * 4) % 9) / 9)
            s = crown * (0.28 + 0.1 * (k % 3) / 2)
            b.add("foliage", sphere((rr * math.cos(a), y, rr * math.sin(a)), s, 12, scale=(1, 0.8, 1)))
    elif foliage == "spiky":
        for k in range(11):
            a = math.radians(33 * k)
            tilt = 8 + 14 * ((k * 3) % 5) / 4
            leaf = cylinder((0, 0, 0), 0.03, crown * (0.7 + 0.3 * ((k * 7) % 5) / 4), 6, radius_top=0.0, scale_z=0.3)
            leaf = transform(leaf, rot_y(math.degrees(a)) @ rot_x(tilt))
            b.add("foliage", (leaf[0] + np.array([0.0, top - 0.02, 0.0]), leaf[1]))
    else:  # tree
        b.add("trunk", cylinder((0, top - 0.02, 0), 0.02, crown * 0.55, 10, radius_top=0.012))
        for k in range(6):
            a = math.radians(60 * k)
            b.add(
                "foliage",
                sphere((0.12 * math.cos(a), top + crown * 0.72 + 0.06 * (k % 2), 0.12 * math.sin(a)), crown * 0.2, 12),
            )
        b.add("foliage", sphere((0, top + crown * 0.82, 0), crown * 0.22, 12))
    return b.build()


def frame(
    kind: str = "picture",
    width: float = 0.6,
    height: float = 0.8,
    border: float = 0.05,
    depth: float = 0.03,
    mat: float = 0.0,
    moulding: str = "black",
    picture: tuple[float, float, float] = (0.45, 0.5, 0.55),
) -> ObjectMesh:
    """A framed picture, a mirror, a whiteboard or a poster, hanging on a wall and facing +Z: groups ``frame``
    (the moulding), ``mat`` (a passe-partout ``mat`` metres wide, none if 0) and ``picture`` (the image, the
    glass of a mirror, the board)."""
    if kind not in ("picture", "mirror", "whiteboard", "poster"):
        raise ValueError(f"frame: kind {kind!r}")
    surface = {"picture": picture, "mirror": (0.75, 0.78, 0.8), "whiteboard": (0.95, 0.95, 0.95), "poster": picture}[
        kind
    ]
    b = MeshBuilder().group("frame", colour(moulding, WOODS, METALS)).group("mat", colour("cream", FABRICS))
    b.group("picture", surface)
    if kind == "poster":
        border, mat = 0.0, 0.0
    z = depth / 2
    if border > 0:
        for sy in (-1, 1):
            b.add("frame", box((0, height / 2 + sy * (height / 2 - border / 2), 0), (width, border, depth)))
        for sx in (-1, 1):
            b.add("frame", box((sx * (width / 2 - border / 2), height / 2, 0), (border, height - 2 * border, depth)))
        b.add("frame", box((0, height / 2, -z + 0.004), (width - 2 * border, height - 2 * border, 0.008)))
    inner_w, inner_h = width - 2 * border, height - 2 * border
    if mat > 0:
        b.add("mat", box((0, height / 2, z - 0.012), (inner_w, inner_h, 0.004)))
        inner_w, inner_h = inner_w - 2 * mat, inner_h - 2 * mat
    thickness = 0.006 if kind != "poster" else 0.005
    b.add("picture", box((0, height / 2, (z - 0.008) if kind != "poster" else 0.0), (inner_w, inner_h, thickness)))
    if kind == "whiteboard":  # a pen tray along the bottom edge
        b.add("frame", box((0, border + 0.01, z + 0.03), (width * 0.5, 0.02, 0.06)))
    return b.build()
