"""Textiles: rugs and pillows."""

from __future__ import annotations

import math

import numpy as np

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, lathe, rot_x, rot_z, rounded_box, sphere, torus, transform, tube
from .common import FABRICS, colour


def rug(
    shape: str = "rect",
    width: float = 2.0,
    length: float = 1.4,
    border: float = 0.12,
    thickness: float = 0.012,
    fringe: bool = False,
    field: str = "beige",
    border_colour: str = "terracotta",
) -> ObjectMesh:
    """A rug (rect/round/oval/runner): groups ``field``, ``border`` (a band of ``border`` metres, none if 0)
    and ``fringe`` (tassels along the short ends)."""
    if shape not in ("rect", "round", "oval", "runner"):
        raise ValueError(f"rug: shape {shape!r}")
    b = MeshBuilder().group("field", colour(field, FABRICS)).group("border", colour(border_colour, FABRICS))
    b.group("fringe", colour("cream", FABRICS))
    t = thickness
    if shape in ("round", "oval"):
        r = width / 2
        scale = length / width if shape == "oval" else 1.0
        inner = r - border if border > 0 else r
        b.add("field", lathe([(inner, 0.0), (inner, t)], 64, scale_z=scale))
        if border > 0:
            b.add(
                "border",
                lathe([(inner, 0.0), (r, 0.0), (r, t), (inner, t), (inner, 0.0)], 64, scale_z=scale, caps=False),
            )
        return b.build()
    W, L = width, length  # x, z
    if border > 0:
        b.add("field", box((0, t / 2, 0), (W - 2 * border, t, L - 2 * border)))
        for sz in (-1, 1):
            b.add("border", box((0, t / 2, sz * (L / 2 - border / 2)), (W, t, border)))
        for sx in (-1, 1):
            b.add("border", box((sx * (W / 2 - border / 2), t / 2, 0), (border, t, L - 2 * border)))
    else:
        b.add("field", box((0, t / 2, 0), (W, t, L)))
    if fringe:
        short_x = W < L  # the fringe hangs off the two short ends
        count = int((W if short_x else L) / 0.05)
        for end in (-1, 1):
            for k in range(count):
                along = -(W if short_x else L) / 2 + 0.025 + k * 0.05
                if short_x:
                    b.add("fringe", box((along, t * 0.3, end * (L / 2 + 0.03)), (0.012, t * 0.6, 0.06)))
                else:
                    b.add("fringe", box((end * (W / 2 + 0.03), t * 0.3, along), (0.06, t * 0.6, 0.012)))
    return b.build()


def pillow(
    shape: str = "square",
    size: float = 0.45,
    thickness: float = 0.12,
    puff: float = 0.3,
    piping: bool = False,
    button: bool = False,
    fabric: str = "mustard",
    trim: str = "cream",
) -> ObjectMesh:
    """A cushion standing upright, facing +Z: square, lumbar (wide), round (a disc) or bolster (a roll along
    x); groups ``cover``, ``piping`` (a cord round the edge) and ``button``."""
    if shape not in ("square", "lumbar", "round", "bolster"):
        raise ValueError(f"pillow: shape {shape!r}")
    b = MeshBuilder().group("cover", colour(fabric, FABRICS)).group("piping", colour(trim, FABRICS))
    b.group("button", colour(trim, FABRICS))
    front = thickness / 2 + puff * size * 0.25
    if shape in ("square", "lumbar"):
        w, h = (size, size) if shape == "square" else (size * 1.4, size * 0.7)
        b.add("cover", rounded_box((0, h / 2, 0), (w, h, thickness), thickness * 0.45, flat=(8, 8, 1), puff=puff))
        if piping:  # a cord along each straight edge of the rim (z = 0), stopping where the corners round off
            r, inset = 0.009, thickness * 0.45
            for y in (0.0, h):
                b.add("piping", tube((-w / 2 + inset, y, 0), (w / 2 - inset, y, 0), r, 8))
            for sx in (-1, 1):
                b.add("piping", tube((sx * w / 2, inset, 0), (sx * w / 2, h - inset, 0), r, 8))
        if button:
            b.add("button", sphere((0, h / 2, front * 0.92), 0.02, 10, scale=(1, 1, 0.5)))
        return b.build()
    if shape == "round":  # a disc: profile from the back centre round the rim to the front centre
        r, half_t = size / 2, thickness / 2
        crown = half_t + puff * r * 0.5
        rim = [
            (r - half_t + half_t * math.cos(a), half_t * math.sin(a)) for a in np.linspace(-math.pi / 2, math.pi / 2, 9)
        ]
        prof = [
            (0.0, -crown),
            (r * 0.6, -half_t - puff * r * 0.35),
            *rim,
            (r * 0.6, half_t + puff * r * 0.35),
            (0.0, crown),
        ]
        part = transform(lathe(prof, 32), rot_x(90), translate=(0, r, 0))
        b.add("cover", part)
        if piping:
            b.add("piping", transform(torus((0, 0, 0), r, 0.008, 40), rot_x(90), translate=(0, r, 0)))
        if button:
            b.add("button", sphere((0, r, crown), 0.02, 10, scale=(1, 1, 0.5)))
        return b.build()
    # bolster: a roll along x
    length, r = size * 1.1, size * 0.2
    prof = [
        (0.0, -length / 2),
        (r * 0.75, -length / 2),
        (r, -length / 2 + 0.03),
        (r, length / 2 - 0.03),
        (r * 0.75, length / 2),
        (0.0, length / 2),
    ]
    b.add("cover", transform(lathe(prof, 28), rot_z(-90), translate=(0, r, 0)))
    if piping:
        for sx in (-1, 1):
            b.add(
                "piping",
                transform(torus((0, 0, 0), r * 0.9, 0.01, 28), rot_z(90), translate=(sx * (length / 2 - 0.015), r, 0)),
            )
    if button:
        for sx in (-1, 1):
            b.add("button", sphere((sx * length / 2, r, 0), 0.022, 10, scale=(0.5, 1, 1)))
    return b.build()
