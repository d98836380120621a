"""Parametric furniture: one generator per category, each with style parameters and separate material groups.

Each generator is a plain function of keyword parameters (sizes in metres) returning a canonical
:class:`~.database.ObjectMesh` (+Y up, front +Z, bottom at y = 0), built from the closed primitives of
:mod:`.primitives`. The material groups are the parts a material stage would texture separately (§4.4):
a sofa's ``frame``, ``cushion`` and ``legs``; a table's ``top``, ``legs`` and ``frame``; and so on.

:func:`catalogue` lists the variants the built-in library ships: for each category a fixed number of
parameter sets, chosen deterministically (:class:`Dice` hashes the category, index and parameter name), so
that ``parametric/<category>_<NNN>`` ids name the same model on every machine and run.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .database import ObjectMesh
from .primitives import (MeshBuilder, box, cylinder, lathe, polyline_tube, rot_x, rot_y, rot_z, rounded_box,
                         sphere, torus, transform, tube)

RGB = tuple[float, float, float]

WOODS: dict[str, RGB] = {
    "oak": (0.66, 0.48, 0.30), "walnut": (0.36, 0.23, 0.14), "birch": (0.82, 0.70, 0.52), "teak": (0.55, 0.34, 0.19),
    "white": (0.90, 0.89, 0.86), "black": (0.14, 0.14, 0.14), "grey": (0.55, 0.55, 0.54), "cherry": (0.50, 0.25, 0.16),
}
FABRICS: dict[str, RGB] = {
    "grey": (0.55, 0.56, 0.58), "beige": (0.80, 0.73, 0.60), "navy": (0.18, 0.25, 0.42), "sage": (0.52, 0.60, 0.48),
    "mustard": (0.80, 0.60, 0.18), "terracotta": (0.72, 0.38, 0.27), "charcoal": (0.26, 0.26, 0.28),
    "cream": (0.92, 0.89, 0.80), "teal": (0.15, 0.45, 0.48), "blush": (0.86, 0.63, 0.61),
    "leather": (0.47, 0.27, 0.15), "burgundy": (0.45, 0.12, 0.16),
}
METALS: dict[str, RGB] = {"steel": (0.72, 0.72, 0.74), "black metal": (0.11, 0.11, 0.12), "brass": (0.78, 0.62, 0.32)}


def _colour(name: str | Sequence[float], *tables: dict[str, RGB]) -> RGB:
    if not isinstance(name, str):
        return (float(name[0]), float(name[1]), float(name[2]))
    for table in tables:
        if name in table:
            return table[name]
    raise KeyError(f"unknown colour {name!r}")


def _legs(b: MeshBuilder, group: str, corners: Sequence[tuple[float, float]], height: float, style: str,
          size: float = 0.045, top: float | None = None) -> None:
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


# -------------------------------------------------------------------------------------------------- chair
CHAIR_BACKS = ("slats", "solid", "rails", "spindles", "upholstered", "none")
CHAIR_LEGS = ("square", "round", "tapered", "splayed", "sled", "swivel")


def chair(seat_height: float = 0.46, seat_width: float = 0.44, seat_depth: float = 0.42, back_height: float = 0.42,
          back_style: str = "slats", leg_style: str = "square", armrests: bool = False, cushion: bool = False,
          seat_shape: str = "square", back_lean: float = 8.0, wood: str = "oak", fabric: str = "grey",
          metal: str = "black metal") -> ObjectMesh:
    """A chair or stool (``back_style="none"``): groups ``frame`` (seat and back), ``cushion`` (seat pad,
    upholstered back) and ``legs``. ``leg_style="swivel"`` is an office base on a five-star foot."""
    if back_style not in CHAIR_BACKS or leg_style not in CHAIR_LEGS:
        raise ValueError(f"chair: back_style {back_style!r} / leg_style {leg_style!r}")
    b = MeshBuilder().group("frame", _colour(wood, WOODS, METALS)).group("cushion", _colour(fabric, FABRICS))
    leg_metal = leg_style in ("sled", "swivel")
    b.group("legs", _colour(metal if leg_metal else wood, METALS, WOODS))
    w, d, h, t = seat_width, seat_depth, seat_height, 0.035
    if seat_shape == "round":
        b.add("frame", cylinder((0, h - t, 0), w / 2, t, 28))
        if cushion:
            b.add("cushion", lathe([(w / 2 - 0.01, 0), (w / 2 - 0.005, 0.03), (w / 2 - 0.06, 0.055), (0.0, 0.06)],
                                   28, (0, h, 0)))
    else:
        b.add("frame", rounded_box((0, h - t / 2, 0), (w, t, d), 0.008))
        if cushion:
            b.add("cushion", rounded_box((0, h + 0.03, 0.01), (w - 0.03, 0.06, d - 0.04), 0.025, flat=(3, 1, 3),
                                         puff=0.15))
    inset = 0.035
    corners = [(sx * (w / 2 - inset), sz * (d / 2 - inset)) for sz in (1, -1) for sx in (-1, 1)]
    if seat_shape == "round":
        corners = [(sx * w * 0.3, sz * w * 0.3) for sz in (1, -1) for sx in (-1, 1)]
    if leg_style == "sled":
        for sx in (-1, 1):
            x = sx * (w / 2 - 0.03)
            b.add_all("legs", polyline_tube([(x, h - t, d / 2 - 0.04), (x, 0.012, d / 2 - 0.02),
                                             (x, 0.012, -d / 2 + 0.02), (x, h - t, -d / 2 + 0.04)], 0.011))
    elif leg_style == "swivel":
        b.add("legs", cylinder((0, 0.1, 0), 0.025, h - t - 0.1, 16))
        b.add("legs", box((0, h - t - 0.03, 0), (0.16, 0.04, 0.16)))
        b.add("legs", cylinder((0, 0.07, 0), 0.04, 0.04, 16))
        for k in range(5):
            angle = math.radians(90 + 72 * k)
            end = (0.3 * math.cos(angle), 0.07, 0.3 * math.sin(angle))
            b.add("legs", tube((0, 0.09, 0), end, 0.018, 8))
            b.add("legs", sphere((end[0], 0.03, end[2]), 0.03, 10))
    else:
        _legs(b, "legs", corners, h - t, leg_style, 0.04)
        if h > 0.6:  # bar stool: a footrest
            if seat_shape == "round":
                b.add("legs", torus((0, 0.3, 0), w * 0.3 * math.sqrt(2) + 0.01, 0.012, 32))
            else:
                for sz in (1, -1):
                    b.add("legs", box((0, 0.3, sz * (d / 2 - inset)), (w - 2 * inset, 0.025, 0.025)))
    if back_style != "none":
        pivot = (0.0, h, -d / 2 + 0.02)
        parts: list[tuple[str, tuple[np.ndarray, np.ndarray]]] = []
        z = -d / 2 + 0.02
        top = h + back_height
        if back_style == "upholstered":
            parts.append(("cushion", rounded_box((0, h + back_height / 2, z + 0.02), (w, back_height, 0.08), 0.03,
                                                 flat=(3, 3, 1), puff=0.1)))
        else:
            posts = [(sx * (w / 2 - 0.025), z) for sx in (-1, 1)]
            for x, pz in posts:
                parts.append(("frame", box((x, h + back_height / 2, pz), (0.035, back_height, 0.03))))
            parts.append(("frame", box((0, top - 0.04, z), (w, 0.08, 0.028))))
            inner_w, span = w - 0.07, back_height - 0.08
            if back_style == "solid":
                parts.append(("frame", box((0, h + span / 2 + 0.06, z), (inner_w, span - 0.06, 0.018))))
            elif back_style == "slats":
                for k in range(3):
                    x = (k - 1) * inner_w / 3
                    parts.append(("frame", box((x, h + span / 2, z), (0.05, span, 0.015))))
            elif back_style == "rails":
                for k in range(2):
                    parts.append(("frame", box((0, h + span * (0.3 + 0.3 * k), z), (inner_w, 0.04, 0.02))))
            elif back_style == "spindles":
                for k in range(5):
                    x = (k - 2) * inner_w / 5.5
                    parts.append(("frame", cylinder((x, h, z), 0.009, span, 8)))
        for group, part in parts:
            b.add(group, transform(part, rot_x(-back_lean), pivot))
    if armrests:
        arm_h = 0.22
        for sx in (-1, 1):
            x = sx * (w / 2 - 0.02)
            b.add("frame", box((x, h + arm_h / 2, d / 2 - 0.06), (0.03, arm_h, 0.03)))
            b.add("frame", rounded_box((x, h + arm_h, -0.01), (0.05, 0.03, d * 0.95), 0.01))
    return b.build()


# --------------------------------------------------------------------------------------------------- sofa
SOFA_ARMS = ("square", "rolled", "track", "rounded", "none")
SOFA_LEGS = ("block", "tapered", "round", "metal", "plinth")


def sofa(seats: int = 3, seat_width: float = 0.62, depth: float = 0.92, seat_height: float = 0.44,
         back_height: float = 0.84, arm_style: str = "square", arm_height: float = 0.62,
         cushion_thickness: float = 0.14, leg_height: float = 0.1, leg_style: str = "tapered",
         back_cushions: bool = True, chaise: str = "none", fabric: str = "grey", cushion_fabric: str | None = None,
         wood: str = "walnut") -> ObjectMesh:
    """A sofa (``seats=1`` is an armchair): groups ``frame`` (base, back, arms), ``cushion`` (seat and back
    cushions) and ``legs``; ``chaise="left"/"right"`` extends one end forward into a chaise longue."""
    if arm_style not in SOFA_ARMS or leg_style not in SOFA_LEGS or chaise not in ("none", "left", "right"):
        raise ValueError(f"sofa: arm_style {arm_style!r} / leg_style {leg_style!r} / chaise {chaise!r}")
    b = MeshBuilder().group("frame", _colour(fabric, FABRICS))
    b.group("cushion", _colour(cushion_fabric or fabric, FABRICS))
    b.group("legs", _colour(wood, WOODS, METALS))
    arm_w = {"square": 0.16, "rolled": 0.17, "track": 0.09, "rounded": 0.18, "none": 0.0}[arm_style]
    inner = seats * seat_width
    width = inner + 2 * arm_w
    leg_h = 0.0 if leg_style == "plinth" else leg_height
    base_top = seat_height - cushion_thickness
    back_t = 0.2 if back_cushions else 0.24
    chaise_len = 0.65 if chaise != "none" else 0.0
    chaise_sign = -1.0 if chaise == "left" else 1.0
    # base and back
    b.add("frame", rounded_box((0, (leg_h + base_top) / 2, 0), (width, base_top - leg_h, depth), 0.03))
    b.add("frame", rounded_box((0, (leg_h + back_height) / 2, -depth / 2 + back_t / 2), (width, back_height - leg_h,
                                                                                           back_t), 0.05))
    if chaise_len:
        cx = chaise_sign * (width / 2 - (seat_width + arm_w) / 2)
        b.add("frame", rounded_box((cx, (leg_h + base_top) / 2, depth / 2 + chaise_len / 2 - 0.03),
                                   (seat_width + arm_w, base_top - leg_h, chaise_len + 0.06), 0.03))
    # arms
    for sx in (-1, 1):
        if arm_style == "none" or (chaise_len and sx == chaise_sign):
            continue
        x = sx * (width / 2 - arm_w / 2)
        if arm_style == "rolled":
            r = arm_w * 0.62
            b.add("frame", rounded_box((x, (leg_h + arm_height - r) / 2, 0.0), (arm_w, arm_height - r - leg_h, depth),
                                       0.02))
            b.add("frame", tube((x + sx * 0.02, arm_height - r, -depth / 2 + 0.01),
                                (x + sx * 0.02, arm_height - r, depth / 2), r, 20))
        else:
            radius = {"square": 0.04, "track": 0.02, "rounded": 0.08}[arm_style]
            b.add("frame", rounded_box((x, (leg_h + arm_height) / 2, 0.0), (arm_w, arm_height - leg_h, depth), radius))
    # cushions
    seat_d = depth - back_t - 0.02
    for k in range(seats):
        x = -inner / 2 + seat_width * (k + 0.5)
        extra = chaise_len if chaise_len and ((chaise_sign > 0 and k == seats - 1) or (chaise_sign < 0 and k == 0)) else 0.0
        b.add("cushion", rounded_box((x, seat_height - cushion_thickness / 2, depth / 2 - seat_d / 2 + extra / 2),
                                     (seat_width - 0.012, cushion_thickness, seat_d + extra), 0.04, flat=(3, 1, 3),
                                     puff=0.12))
        if back_cushions:
            bh = back_height - seat_height - 0.02
            part = rounded_box((x, seat_height + bh / 2, -depth / 2 + back_t + 0.08), (seat_width - 0.02, bh, 0.16),
                               0.05, flat=(3, 3, 1), puff=0.15)
            b.add("cushion", transform(part, rot_x(-10), (0, seat_height, -depth / 2 + back_t)))
    # legs
    if leg_style != "plinth":
        front = depth / 2 - 0.06 + chaise_len
        xs = [-width / 2 + 0.07, width / 2 - 0.07]
        corners = [(x, z) for x in xs for z in (depth / 2 - 0.06, -depth / 2 + 0.06)]
        if chaise_len:
            corners = [(x, z) if not (np.sign(x) == chaise_sign and z > 0) else (x, front) for x, z in corners]
        if seats >= 3:
            corners += [(0.0, depth / 2 - 0.06), (0.0, -depth / 2 + 0.06)]
        _legs(b, "legs", corners, leg_h, "metal" if leg_style == "metal" else leg_style, 0.05, top=leg_h + 0.01)
    return b.build()


# -------------------------------------------------------------------------------------------------- table
TABLE_SHAPES = ("rect", "square", "round", "oval")
TABLE_LEGS = ("square", "round", "tapered", "splayed", "pedestal", "trestle", "metal")


def table(shape: str = "rect", width: float = 1.6, depth: float = 0.9, height: float = 0.75,
          top_thickness: float = 0.04, leg_style: str = "square", apron: bool = True, lower_shelf: bool = False,
          top: str = "oak", legs: str = "oak") -> ObjectMesh:
    """A dining, coffee, side or console table: groups ``top``, ``legs`` and ``frame`` (apron, stretchers,
    shelf). ``shape`` is rect/square/round/oval; ``leg_style="pedestal"`` is a central column."""
    if shape not in TABLE_SHAPES or leg_style not in TABLE_LEGS:
        raise ValueError(f"table: shape {shape!r} / leg_style {leg_style!r}")
    b = MeshBuilder().group("top", _colour(top, WOODS, METALS)).group("legs", _colour(legs, WOODS, METALS))
    b.group("frame", _colour(legs, WOODS, METALS))
    if shape == "square":
        depth = width
    t = top_thickness
    round_top = shape in ("round", "oval")
    if round_top:
        b.add("top", cylinder((0, height - t, 0), width / 2, t, 48, scale_z=depth / width))
    else:
        b.add("top", rounded_box((0, height - t / 2, 0), (width, t, depth), min(0.01, t / 3)))
    leg_top = height - t
    if leg_style == "pedestal":  # one central column, two along a long top
        foot = min(width, depth) * 0.32
        xs = [0.0] if width < 1.3 * depth else [-width / 4, width / 4]
        for x in xs:
            b.add("legs", lathe([(0.05, 0.0), (0.06, 0.5 * leg_top), (0.045, leg_top)], 20, (x, 0, 0)))
            b.add("legs", lathe([(foot, 0.0), (foot, 0.025), (foot * 0.55, 0.06), (0.0, 0.065)], 32, (x, 0, 0)))
            b.add("frame", cylinder((x, leg_top - 0.03, 0), min(width, depth) * 0.2, 0.03, 24))
    elif leg_style == "trestle":
        for sx in (-1, 1):
            x = sx * (width / 2 - 0.18)
            b.add("legs", box((x, leg_top / 2, 0), (0.06, leg_top, 0.08)))
            b.add("legs", box((x, 0.03, 0), (0.08, 0.06, depth * 0.75)))
            b.add("legs", box((x, leg_top - 0.03, 0), (0.08, 0.05, depth * 0.7)))
        b.add("frame", box((0, leg_top * 0.35, 0), (width - 0.36, 0.06, 0.05)))
    else:
        if round_top:
            r = 0.36
            corners = [(sx * width * r, sz * depth * r) for sz in (1, -1) for sx in (-1, 1)]
        else:
            inset = 0.06 if width > 0.7 else 0.04
            corners = [(sx * (width / 2 - inset), sz * (depth / 2 - inset)) for sz in (1, -1) for sx in (-1, 1)]
        size = 0.05 if height > 0.6 else 0.045
        _legs(b, "legs", corners, leg_top, leg_style, size)
        if apron and leg_style not in ("splayed",):
            ax, az = abs(corners[0][0]), abs(corners[0][1])
            apron_h = min(0.09, leg_top * 0.2)
            y = leg_top - apron_h / 2
            for sz in (1, -1):
                b.add("frame", box((0, y, sz * az), (2 * ax, apron_h, 0.02)))
            for sx in (-1, 1):
                b.add("frame", box((sx * ax, y, 0), (0.02, apron_h, 2 * az)))
        if lower_shelf:
            ax, az = abs(corners[0][0]), abs(corners[0][1])
            b.add("frame", box((0, leg_top * 0.22, 0), (2 * ax + 0.03, 0.025, 2 * az + 0.03)))
    return b.build()


# ---------------------------------------------------------------------------------------------------- bed
BED_HEADBOARDS = ("panel", "upholstered", "slats", "tall", "rounded", "none")


def bed(width: float = 1.6, length: float = 2.05, headboard: str = "panel", headboard_height: float = 1.0,
        footboard: bool = False, mattress_height: float = 0.22, frame_height: float = 0.32, legs: bool = True,
        pillows: int = 2, blanket: bool = True, wood: str = "oak", fabric: str = "grey", bedding: str = "cream",
        blanket_colour: str = "navy") -> ObjectMesh:
    """A bed: groups ``frame``, ``headboard``, ``mattress``, ``bedding`` (duvet), ``pillow`` and ``legs``;
    the headboard is at the back (-Z), the foot at the front (+Z)."""
    if headboard not in BED_HEADBOARDS:
        raise ValueError(f"bed: headboard {headboard!r}")
    b = MeshBuilder().group("frame", _colour(wood, WOODS, FABRICS))
    upholstered = headboard in ("upholstered", "rounded")
    b.group("headboard", _colour(fabric if upholstered else wood, FABRICS, WOODS))
    b.group("mattress", _colour("cream", FABRICS)).group("bedding", _colour(blanket_colour, FABRICS))
    b.group("pillow", _colour(bedding, FABRICS)).group("legs", _colour(wood, WOODS, METALS))
    leg_h = 0.12 if legs else 0.0
    W, L = width, length
    b.add("frame", rounded_box((0, (leg_h + frame_height) / 2, 0), (W + 0.08, frame_height - leg_h, L + 0.06), 0.015))
    if legs:
        _legs(b, "legs", [(sx * (W / 2 - 0.02), sz * (L / 2 - 0.04)) for sz in (1, -1) for sx in (-1, 1)], leg_h,
              "square", 0.06, top=leg_h + 0.01)
    top = frame_height + mattress_height
    b.add("mattress", rounded_box((0, frame_height + mattress_height / 2, 0.02), (W, mattress_height, L - 0.04),
                                  0.05, flat=(2, 1, 3)))
    if blanket:
        cover = L * 0.66
        drop = mattress_height * 0.75
        b.add("bedding", rounded_box((0, top + 0.02 - (drop + 0.04) / 2, L / 2 - cover / 2 + 0.01),
                                     (W + 0.05, drop + 0.04, cover), 0.03, flat=(4, 1, 4), puff=0.08))
    for k in range(pillows):
        pw = min(0.62, (W - 0.1) / max(pillows, 1))
        x = (k - (pillows - 1) / 2) * (pw + 0.04)
        part = rounded_box((x, top + 0.07, -L / 2 + 0.24), (pw, 0.13, 0.38), 0.05, flat=(3, 1, 3), puff=0.35)
        b.add("pillow", transform(part, rot_x(-15), (x, top, -L / 2 + 0.1)))
    z = -L / 2 - 0.02
    hb = headboard_height
    if headboard == "panel":
        b.add("headboard", box((0, hb / 2, z), (W + 0.1, hb, 0.05)))
    elif headboard == "tall":
        b.add("headboard", box((0, (hb + 0.3) / 2, z), (W + 0.12, hb + 0.3, 0.06)))
        b.add("frame", box((0, hb + 0.3, z), (W + 0.16, 0.05, 0.09)))
    elif headboard == "upholstered":
        b.add("headboard", rounded_box((0, (hb + frame_height) / 2, z - 0.02),
                                       (W + 0.12, hb - frame_height, 0.1), 0.04, flat=(6, 4, 1), puff=0.12))
        b.add("frame", box((0, frame_height / 2, z - 0.02), (W + 0.1, frame_height, 0.08)))
    elif headboard == "rounded":  # a panel with an elliptical top
        radius = (W + 0.12) / 2
        ry = min(0.45, hb * 0.45)
        disc = lathe([(0.0, 0.0), (radius, 0.0), (radius, 0.09), (0.0, 0.09)], 48, caps=False)
        disc = transform(disc, rot_x(90))  # standing in the x-y plane, 9 cm thick along +z
        vertices = disc[0] * np.array([1.0, ry / radius, 1.0]) + np.array([0.0, hb - ry, z - 0.045])
        b.add("headboard", (vertices, disc[1]))
        b.add("headboard", box((0, (hb - ry) / 2, z), (2 * radius, hb - ry, 0.09)))
    elif headboard == "slats":
        for sx in (-1, 1):
            b.add("headboard", box((sx * (W / 2 + 0.02), hb / 2, z), (0.07, hb, 0.07)))
        b.add("headboard", box((0, hb - 0.05, z), (W + 0.04, 0.08, 0.05)))
        for k in range(7):
            x = (k - 3) * W / 7.5
            b.add("headboard", box((x, (frame_height + hb) / 2, z), (0.07, hb - frame_height, 0.025)))
    if footboard:
        fb = frame_height + 0.22
        b.add("frame", box((0, fb / 2, L / 2 + 0.03), (W + 0.1, fb, 0.05)))
    return b.build()


# ------------------------------------------------------------------------------------------------ cabinet
def cabinet(width: float = 1.0, height: float = 0.85, depth: float = 0.45, drawers: int = 0, doors: int = 2,
            drawer_columns: int = 1, base: str = "plinth", handle: str = "bar", top_overhang: float = 0.01,
            wood: str = "oak", fronts: str | None = None, metal: str = "steel") -> ObjectMesh:
    """A cabinet, dresser, nightstand, wardrobe, sideboard or TV stand: drawers (in ``drawer_columns``)
    above ``doors``; groups ``body``, ``fronts`` (doors and drawer fronts), ``handles`` and ``legs``;
    ``base`` is plinth/legs/none."""
    if base not in ("plinth", "legs", "none") or handle not in ("bar", "knob", "none"):
        raise ValueError(f"cabinet: base {base!r} / handle {handle!r}")
    b = MeshBuilder().group("body", _colour(wood, WOODS)).group("fronts", _colour(fronts or wood, WOODS))
    b.group("handles", _colour(metal, METALS)).group("legs", _colour(wood if base == "plinth" else metal, WOODS, METALS))
    base_h = {"plinth": 0.08, "legs": 0.16, "none": 0.0}[base]
    if base == "plinth":
        b.add("legs", box((0, base_h / 2, -0.02), (width - 0.04, base_h, depth - 0.06)))
    elif base == "legs":
        _legs(b, "legs", [(sx * (width / 2 - 0.05), sz * (depth / 2 - 0.05)) for sz in (1, -1) for sx in (-1, 1)],
              base_h, "tapered", 0.05, top=base_h + 0.01)
    body_h = height - base_h - 0.03
    b.add("body", box((0, base_h + body_h / 2, 0), (width, body_h, depth)))
    b.add("body", rounded_box((0, height - 0.015, top_overhang / 2), (width + 2 * top_overhang, 0.03,
                                                                      depth + top_overhang), 0.006))
    gap, panel_t, zf = 0.006, 0.02, depth / 2 + 0.01
    margin = 0.02
    x0, x1 = -width / 2 + margin, width / 2 - margin
    y_top = height - 0.03 - margin
    y_bottom = base_h + margin
    rows = math.ceil(drawers / drawer_columns) if drawers else 0
    drawer_h = 0.0
    if rows:
        drawer_h = min(0.2, (y_top - y_bottom) / (rows + 2)) if doors else (y_top - y_bottom) / rows
    y = y_top
    for row in range(rows):
        count = min(drawer_columns, drawers - row * drawer_columns)
        cell = (x1 - x0) / count
        for c in range(count):
            cx = x0 + cell * (c + 0.5)
            b.add("fronts", box((cx, y - drawer_h / 2, zf), (cell - gap, drawer_h - gap, panel_t)))
            if handle == "bar":
                b.add("handles", box((cx, y - drawer_h / 2, zf + 0.02), (min(0.14, cell * 0.4), 0.014, 0.02)))
            elif handle == "knob":
                b.add("handles", sphere((cx, y - drawer_h / 2, zf + 0.018), 0.016, 10))
        y -= drawer_h
    if doors:
        cell = (x1 - x0) / doors
        door_h = y - y_bottom
        for c in range(doors):
            cx = x0 + cell * (c + 0.5)
            b.add("fronts", box((cx, y_bottom + door_h / 2, zf), (cell - gap, door_h - gap, panel_t)))
            # the handle near the edge where a pair of doors meets (or the free edge of a single door)
            side = (1 if c % 2 == 0 else -1) if doors > 1 else 1
            hx = cx + side * (cell / 2 - 0.05)
            hy = y_bottom + door_h * (0.5 if door_h > 0.9 or door_h < 0.5 else 0.75)
            if handle == "bar":
                b.add("handles", box((hx, hy, zf + 0.02), (0.014, min(0.16, door_h * 0.3), 0.02)))
            elif handle == "knob":
                b.add("handles", sphere((hx, hy, zf + 0.018), 0.016, 10))
    return b.build()


# -------------------------------------------------------------------------------------------------- shelf
def shelf(width: float = 0.8, height: float = 1.8, depth: float = 0.32, shelves: int = 5, columns: int = 1,
          back_panel: bool = True, sides: str = "solid", books: float = 0.6, wood: str = "white",
          metal: str = "black metal", book_colours: tuple[str, str] = ("terracotta", "navy")) -> ObjectMesh:
    """A bookcase or shelving unit: groups ``frame`` (sides, top, bottom, dividers), ``shelves``, ``back`` and
    ``books`` / ``books_alt`` (``books`` is the fraction of each compartment filled). ``sides="frame"`` is
    an open metal frame."""
    if sides not in ("solid", "frame"):
        raise ValueError(f"shelf: sides {sides!r}")
    b = MeshBuilder().group("frame", _colour(metal if sides == "frame" else wood, METALS, WOODS))
    b.group("shelves", _colour(wood, WOODS)).group("back", _colour(wood, WOODS))
    b.group("books", _colour(book_colours[0], FABRICS)).group("books_alt", _colour(book_colours[1], FABRICS))
    t = 0.022
    if sides == "solid":
        for sx in (-1, 1):
            b.add("frame", box((sx * (width / 2 - t / 2), height / 2, 0), (t, height, depth)))
        b.add("frame", box((0, height - t / 2, 0), (width, t, depth)))
        b.add("frame", box((0, 0.05, 0), (width - 2 * t, 0.1, depth)))
        for c in range(1, columns):
            x = -width / 2 + width * c / columns
            b.add("frame", box((x, height / 2, 0), (t, height - 0.05, depth - 0.01)))
        levels = np.linspace(0.1, height - t, shelves + 1)[1:-1]
        bottom = 0.1
    else:
        for sx in (-1, 1):
            for sz in (-1, 1):
                b.add("frame", box((sx * (width / 2 - 0.012), height / 2, sz * (depth / 2 - 0.012)), (0.024, height, 0.024)))
        levels = np.linspace(0.08, height - 0.02, shelves)
        bottom = float(levels[0])
        for y in levels:
            b.add("shelves", box((0, y, 0), (width - 0.01, t, depth - 0.01)))
        levels = levels[1:-1]
    if sides == "solid":
        for y in levels:
            b.add("shelves", box((0, y, 0.005), (width - 2 * t, t, depth - 0.02)))
    if back_panel:
        b.add("back", box((0, height / 2, -depth / 2 + 0.006), (width - 0.004, height - 0.004, 0.012)))
    floors = [bottom + (t / 2 if sides == "solid" else t / 2)] + [float(y) + t / 2 for y in levels]
    ceilings = [float(y) - t / 2 for y in levels] + [height - t]
    if books > 0:
        inner = (width - 2 * t) / columns
        for level, (y0, y1) in enumerate(zip(floors, ceilings)):
            space = y1 - y0
            if space < 0.12:
                continue
            for c in range(columns):
                x = -width / 2 + t + inner * c + 0.01
                end = x + inner * books * (0.55 + 0.45 * ((level * 7 + c * 3) % 5) / 4) - 0.02
                k = 0
                while x < end:
                    code = (level * 31 + c * 17 + k * 7) % 11
                    bw = 0.022 + 0.004 * (code % 5)
                    bh = min(space - 0.02, 0.32) * (0.7 + 0.03 * (code % 8))
                    group = "books" if (k + level) % 3 else "books_alt"
                    b.add(group, box((x + bw / 2, y0 + bh / 2, 0.02), (bw - 0.002, bh, min(0.22, depth - 0.06))))
                    x += bw
                    k += 1
    return b.build()


# --------------------------------------------------------------------------------------------------- desk
def desk(width: float = 1.3, depth: float = 0.65, height: float = 0.75, drawers_side: str = "right",
         leg_style: str = "square", modesty_panel: bool = True, hutch: bool = False, top: str = "oak",
         body: str = "white", metal: str = "black metal") -> ObjectMesh:
    """A desk: groups ``top``, ``legs``, ``drawers`` (pedestal and drawer fronts) and ``handles``;
    ``drawers_side`` is left/right/both/none (seen from the front, +Z, where the user sits)."""
    if drawers_side not in ("left", "right", "both", "none") or leg_style not in ("square", "tapered", "frame",
                                                                                 "panel"):
        raise ValueError(f"desk: drawers_side {drawers_side!r} / leg_style {leg_style!r}")
    b = MeshBuilder().group("top", _colour(top, WOODS)).group("legs", _colour(metal if leg_style == "frame" else body,
                                                                              METALS, WOODS))
    b.group("drawers", _colour(body, WOODS)).group("handles", _colour("steel", METALS))
    t = 0.03
    b.add("top", rounded_box((0, height - t / 2, 0), (width, t, depth), 0.006))
    under = height - t
    ped_w = 0.42
    sides = {"left": [-1], "right": [1], "both": [-1, 1], "none": []}[drawers_side]
    for sx in sides:
        x = sx * (width / 2 - ped_w / 2 - 0.01)
        b.add("drawers", box((x, under / 2, 0), (ped_w, under, depth - 0.04)))
        dh = (under - 0.04) / 3
        for k in range(3):
            y = 0.02 + dh * (k + 0.5)
            b.add("drawers", box((x, y, depth / 2 - 0.01), (ped_w - 0.03, dh - 0.008, 0.02)))
            b.add("handles", box((x, y + dh * 0.25, depth / 2 + 0.008), (0.12, 0.012, 0.016)))
    for sx in (-1, 1):
        if sx in sides:
            continue
        x = sx * (width / 2 - 0.04)
        if leg_style == "panel":
            b.add("legs", box((sx * (width / 2 - 0.015), under / 2, 0), (0.03, under, depth - 0.02)))
        elif leg_style == "frame":
            for sz in (-1, 1):
                b.add("legs", box((x, under / 2, sz * (depth / 2 - 0.04)), (0.04, under, 0.04)))
            b.add("legs", box((x, 0.02, 0), (0.04, 0.04, depth - 0.04)))
            b.add("legs", box((x, under - 0.03, 0), (0.04, 0.04, depth - 0.04)))
        else:
            _legs(b, "legs", [(x, sz * (depth / 2 - 0.04)) for sz in (-1, 1)], under, leg_style, 0.045)
    if modesty_panel:
        b.add("legs", box((0, under * 0.6, -depth / 2 + 0.05), (width - 0.1, under * 0.55, 0.015)))
    if hutch:
        hh = 0.35
        for sx in (-1, 1):
            b.add("drawers", box((sx * (width / 2 - 0.01), height + hh / 2, -depth / 2 + 0.12), (0.02, hh, 0.24)))
        b.add("drawers", box((0, height + hh, -depth / 2 + 0.12), (width, 0.02, 0.24)))
        b.add("drawers", box((0, height + hh / 2, -depth / 2 + 0.005), (width, hh, 0.01)))
    return b.build()


# --------------------------------------------------------------------------------------------------- lamp
LAMP_SHADES = ("drum", "cone", "bell", "globe", "dome")


def lamp(kind: str = "table", shade: str = "drum", base: str = "disk", height: float | None = None,
         shade_size: float | None = None, shade_colour: str = "cream", body: str = "brass",
         base_colour: str | None = None) -> ObjectMesh:
    """A table or floor lamp (``kind="arc"`` is an arched floor lamp): groups ``shade``, ``stem`` and
    ``base``; ``base`` is disk/tripod/square/urn."""
    if kind not in ("table", "floor", "arc") or shade not in LAMP_SHADES or base not in ("disk", "tripod", "square",
                                                                                        "urn"):
        raise ValueError(f"lamp: kind {kind!r} / shade {shade!r} / base {base!r}")
    b = MeshBuilder().group("shade", _colour(shade_colour, FABRICS, METALS))
    b.group("stem", _colour(body, METALS, WOODS)).group("base", _colour(base_colour or body, METALS, WOODS, FABRICS))
    floor = kind != "table"
    height = height or (1.62 if floor else 0.55)
    size = shade_size or (0.42 if floor else 0.32)
    shade_h = size * (0.75 if shade in ("drum", "cone") else 0.6)
    if kind == "arc":
        b.add("base", box((0, 0.04, 0), (0.3, 0.08, 0.3)) if base == "square" else cylinder((0, 0, 0), 0.18, 0.07, 28))
        radius, rise = 0.6, (height or 1.9) - 0.6
        points = [(0.0, 0.07, 0.0)] + [(radius - radius * math.cos(a), rise + radius * math.sin(a), 0.0)
                                       for a in np.radians(np.linspace(0.0, 150.0, 9))]
        b.add_all("stem", polyline_tube(points, 0.012, 10))
        end = points[-1]
        d = size
        b.add("shade", lathe([(d / 2, 0.0), (d * 0.45, d * 0.18), (d * 0.3, d * 0.3), (0.03, d * 0.36)], 28,
                             (end[0], end[1] - d * 0.36 - 0.02, 0.0)))
        return b.build()
    shade_bottom = height - shade_h
    stem_top = shade_bottom + shade_h * 0.4
    if base == "tripod":
        spread = 0.28 if floor else 0.12
        joint = height * (0.55 if floor else 0.3)
        for k in range(3):
            a = math.radians(90 + 120 * k)
            b.add("base", tube((spread * math.cos(a), 0.0, spread * math.sin(a)), (0, joint, 0), 0.012, 8))
        b.add("stem", cylinder((0, joint - 0.02, 0), 0.012, stem_top - joint + 0.02, 10))
    else:
        if base == "disk":
            b.add("base", lathe([(0.14 if floor else 0.09, 0.0), (0.14 if floor else 0.09, 0.02),
                                 (0.05, 0.035), (0.0, 0.035)], 28))
            neck = 0.03
        elif base == "square":
            s = 0.26 if floor else 0.14
            b.add("base", box((0, 0.015, 0), (s, 0.03, s)))
            neck = 0.03
        else:  # urn: a vase-shaped body
            r = 0.09 if floor else 0.08
            tall = (0.5 if floor else 0.55) * shade_bottom
            b.add("base", lathe([(r * 0.55, 0.0), (r * 0.8, tall * 0.15), (r, tall * 0.45), (r * 0.8, tall * 0.8),
                                 (r * 0.3, tall), (0.0, tall)], 28))
            neck = tall
        b.add("stem", cylinder((0, neck, 0), 0.01 if floor else 0.009, stem_top - neck, 10))
    y = shade_bottom
    if shade == "drum":
        b.add("shade", lathe([(size / 2, 0.0), (size / 2, shade_h)], 32, (0, y, 0)))
    elif shade == "cone":
        b.add("shade", lathe([(size / 2, 0.0), (size * 0.3, shade_h)], 32, (0, y, 0)))
    elif shade == "bell":
        b.add("shade", lathe([(size / 2, 0.0), (size * 0.46, shade_h * 0.15), (size * 0.33, shade_h * 0.55),
                              (size * 0.24, shade_h)], 32, (0, y, 0)))
    elif shade == "dome":
        prof = [(size / 2 * math.cos(a), shade_h * math.sin(a)) for a in np.linspace(0, math.pi / 2, 8)]
        prof[-1] = (0.0, shade_h)
        b.add("shade", lathe(prof, 32, (0, y, 0)))
    else:  # globe
        b.add("shade", sphere((0, y + size / 2, 0), size / 2, 24))
    return b.build()


# ---------------------------------------------------------------------------------------------------- rug
def rug(shape: str = "rect", width: float = 2.0, length: float = 1.4, border: float = 0.12, thickness: float = 0.012,
        fringe: bool = False, field: str = "beige", border_colour: str = "terracotta") -> ObjectMesh:
    """A rug (rect/round/oval/runner): groups ``field``, ``border`` (a band of ``border`` metres, none if 0)
    and ``fringe`` (tassels along the short ends)."""
    if shape not in ("rect", "round", "oval", "runner"):
        raise ValueError(f"rug: shape {shape!r}")
    b = MeshBuilder().group("field", _colour(field, FABRICS)).group("border", _colour(border_colour, FABRICS))
    b.group("fringe", _colour("cream", FABRICS))
    t = thickness
    if shape in ("round", "oval"):
        r = width / 2
        scale = length / width if shape == "oval" else 1.0
        inner = r - border if border > 0 else r
        b.add("field", lathe([(inner, 0.0), (inner, t)], 64, scale_z=scale))
        if border > 0:
            b.add("border", lathe([(inner, 0.0), (r, 0.0), (r, t), (inner, t), (inner, 0.0)], 64, scale_z=scale,
                                  caps=False))
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


# ------------------------------------------------------------------------------------------------- pillow
def pillow(shape: str = "square", size: float = 0.45, thickness: float = 0.12, puff: float = 0.3,
           piping: bool = False, button: bool = False, fabric: str = "mustard", trim: str = "cream") -> ObjectMesh:
    """A cushion standing upright, facing +Z: square, lumbar (wide), round (a disc) or bolster (a roll along
    x); groups ``cover``, ``piping`` (a cord round the edge) and ``button``."""
    if shape not in ("square", "lumbar", "round", "bolster"):
        raise ValueError(f"pillow: shape {shape!r}")
    b = MeshBuilder().group("cover", _colour(fabric, FABRICS)).group("piping", _colour(trim, FABRICS))
    b.group("button", _colour(trim, FABRICS))
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
        rim = [(r - half_t + half_t * math.cos(a), half_t * math.sin(a)) for a in np.linspace(-math.pi / 2, math.pi / 2, 9)]
        prof = [(0.0, -crown), (r * 0.6, -half_t - puff * r * 0.35), *rim, (r * 0.6, half_t + puff * r * 0.35),
                (0.0, crown)]
        part = transform(lathe(prof, 32), rot_x(90), translate=(0, r, 0))
        b.add("cover", part)
        if piping:
            b.add("piping", transform(torus((0, 0, 0), r, 0.008, 40), rot_x(90), translate=(0, r, 0)))
        if button:
            b.add("button", sphere((0, r, crown), 0.02, 10, scale=(1, 1, 0.5)))
        return b.build()
    # bolster: a roll along x
    length, r = size * 1.1, size * 0.2
    prof = [(0.0, -length / 2), (r * 0.75, -length / 2), (r, -length / 2 + 0.03), (r, length / 2 - 0.03),
            (r * 0.75, length / 2), (0.0, length / 2)]
    b.add("cover", transform(lathe(prof, 28), rot_z(-90), translate=(0, r, 0)))
    if piping:
        for sx in (-1, 1):
            b.add("piping", transform(torus((0, 0, 0), r * 0.9, 0.01, 28), rot_z(90),
                                      translate=(sx * (length / 2 - 0.015), r, 0)))
    if button:
        for sx in (-1, 1):
            b.add("button", sphere((sx * length / 2, r, 0), 0.022, 10, scale=(0.5, 1, 1)))
    return b.build()


# -------------------------------------------------------------------------------------------- plant and tv
def plant(pot: str = "taper", height: float = 0.9, foliage: str = "bush", pot_colour: str = "terracotta",
          leaves: str = "sage") -> ObjectMesh:
    """A potted plant: groups ``pot``, ``soil`` and ``foliage`` (a bush of blobs, a tall spiky plant, or a
    small tree with a trunk)."""
    b = MeshBuilder().group("pot", _colour(pot_colour, FABRICS, WOODS)).group("soil", (0.25, 0.18, 0.12))
    b.group("foliage", _colour(leaves, FABRICS) if leaves in FABRICS else (0.22, 0.45, 0.2))
    b.group("trunk", _colour("walnut", WOODS))
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
            leaf = cylinder((0, 0, 0), 0.03, crown * (0.7 + 0.3 * ((k * 7) % 5) / 4), 6, radius_top=0.0,
                            scale_z=0.3)
            leaf = transform(leaf, rot_y(math.degrees(a)) @ rot_x(tilt))
            b.add("foliage", (leaf[0] + np.array([0.0, top - 0.02, 0.0]), leaf[1]))
    else:  # tree
        b.add("trunk", cylinder((0, top - 0.02, 0), 0.02, crown * 0.55, 10, radius_top=0.012))
        for k in range(6):
            a = math.radians(60 * k)
            b.add("foliage", sphere((0.12 * math.cos(a), top + crown * 0.72 + 0.06 * (k % 2), 0.12 * math.sin(a)),
                                    crown * 0.2, 12))
        b.add("foliage", sphere((0, top + crown * 0.82, 0), crown * 0.22, 12))
    return b.build()


def tv(diagonal_inches: float = 55.0, stand: str = "feet", frame: str = "black metal") -> ObjectMesh:
    """A flat television, screen facing +Z: groups ``screen``, ``frame`` (bezel and back) and ``stand``
    (``feet``, ``pedestal`` or ``none`` for a wall-mounted set)."""
    b = MeshBuilder().group("screen", (0.04, 0.045, 0.05)).group("frame", _colour(frame, METALS, WOODS))
    b.group("stand", _colour(frame, METALS, WOODS))
    diag = diagonal_inches * 0.0254
    w, h = diag * 16 / math.hypot(16, 9), diag * 9 / math.hypot(16, 9)
    bottom = {"feet": 0.07, "pedestal": 0.09, "none": 0.0}[stand]
    b.add("frame", box((0, bottom + h / 2, 0), (w + 0.02, h + 0.02, 0.03)))
    b.add("frame", box((0, bottom + h / 2, -0.035), (w * 0.6, h * 0.6, 0.05)))
    b.add("screen", box((0, bottom + h / 2 + 0.002, 0.016), (w, h - 0.004, 0.004)))
    if stand == "feet":
        for sx in (-1, 1):
            x = sx * w * 0.38
            b.add("stand", tube((x, 0.0, 0.12), (x, bottom + 0.05, 0.0), 0.01, 8))
            b.add("stand", tube((x, 0.0, -0.1), (x, bottom + 0.05, 0.0), 0.01, 8))
    elif stand == "pedestal":
        b.add("stand", box((0, 0.01, 0), (w * 0.3, 0.02, 0.22)))
        b.add("stand", box((0, bottom / 2 + 0.02, -0.03), (0.06, bottom + 0.06, 0.03)))
    return b.build()


GENERATORS: dict[str, Callable[..., ObjectMesh]] = {
    "chair": chair, "table": table, "sofa": sofa, "bed": bed, "cabinet": cabinet, "shelf": shelf, "desk": desk,
    "lamp": lamp, "rug": rug, "pillow": pillow, "plant": plant, "tv": tv,
}
"""Generator of each category (an armchair is :func:`sofa` with one seat, in the ``chair`` category)."""


# ------------------------------------------------------------------------------------------------ catalogue
class Dice:
    """Deterministic 'random' parameter choices: a hash of (category, index, parameter name), so that the
    catalogue is the same on every machine and numpy version."""

    def __init__(self, category: str, index: int) -> None:
        self.key = f"{category}:{index}"
        self.index = index

    def unit(self, name: str) -> float:
        digest = hashlib.blake2b(f"{self.key}:{name}".encode(), digest_size=8).digest()
        return int.from_bytes(digest, "big") / 2.0 ** 64

    def uniform(self, name: str, lo: float, hi: float, step: float = 0.01) -> float:
        return round((lo + (hi - lo) * self.unit(name)) / step) * step

    def choice(self, name: str, options: Sequence[Any]) -> Any:
        return options[int(self.unit(name) * len(options))]

    def cycle(self, options: Sequence[Any], stride: int = 1) -> Any:
        """Options in turn (every one appears), for a category's main style parameter."""
        return options[(self.index * stride) % len(options)]

    def flag(self, name: str, p: float = 0.5) -> bool:
        return self.unit(name) < p


@dataclass(frozen=True)
class Variant:
    """One parametric model of the built-in library."""

    id: str
    category: str
    name: str
    generator: str
    params: dict[str, Any]

    def build(self) -> ObjectMesh:
        return GENERATORS[self.generator](**self.params)


WOOD_NAMES = ("oak", "walnut", "birch", "teak", "white", "black", "cherry")
FABRIC_NAMES = tuple(FABRICS)


def _chairs(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("dining", "dining", "dining", "stool", "office", "armchair", "dining"))
    wood, fabric = d.choice("wood", WOOD_NAMES), d.choice("fabric", FABRIC_NAMES)
    if kind == "armchair":
        arm = d.choice("arm", ("square", "rolled", "track", "rounded"))
        params = dict(seats=1, seat_width=d.uniform("w", 0.55, 0.66), depth=d.uniform("d", 0.78, 0.9),
                      back_height=d.uniform("bh", 0.76, 0.95), arm_style=arm, leg_style=d.choice("leg", SOFA_LEGS),
                      leg_height=d.uniform("lh", 0.08, 0.16), fabric=fabric, wood=wood,
                      back_cushions=d.flag("bc"))
        return "sofa", f"armchair, {arm} arms, {fabric}", params
    if kind == "stool":
        bar = d.flag("bar", 0.6)
        shape = d.choice("shape", ("round", "square"))
        params = dict(seat_height=d.uniform("h", 0.72, 0.78) if bar else d.uniform("h", 0.44, 0.5),
                      seat_width=d.uniform("w", 0.34, 0.4), seat_depth=0.36, back_style="none",
                      leg_style=d.choice("leg", ("round", "tapered", "splayed", "square")), seat_shape=shape,
                      cushion=d.flag("cushion"), wood=wood, fabric=fabric)
        params["seat_depth"] = params["seat_width"]
        return "chair", f"{'bar ' if bar else ''}stool, {shape} seat, {params['leg_style']} legs", params
    if kind == "office":
        params = dict(seat_height=0.48, seat_width=0.5, seat_depth=0.48, back_height=d.uniform("bh", 0.45, 0.6),
                      back_style="upholstered", leg_style="swivel", armrests=d.flag("arms", 0.7), cushion=True,
                      fabric=d.choice("fabric", ("charcoal", "grey", "navy", "leather")), wood="black metal")
        return "chair", "office chair, swivel base", params
    back = d.choice("back", ("slats", "solid", "rails", "spindles", "upholstered"))
    legs = d.choice("legs", ("square", "round", "tapered", "splayed", "sled"))
    params = dict(seat_height=d.uniform("h", 0.44, 0.48), seat_width=d.uniform("w", 0.42, 0.5),
                  seat_depth=d.uniform("d", 0.4, 0.48), back_height=d.uniform("bh", 0.36, 0.5), back_style=back,
                  leg_style=legs, armrests=d.flag("arms", 0.3), cushion=d.flag("cushion", 0.5) or back == "upholstered",
                  wood=wood, fabric=fabric, back_lean=d.uniform("lean", 4, 12, 1))
    return "chair", f"dining chair, {back} back, {legs} legs{', armrests' if params['armrests'] else ''}", params


def _sofas(d: Dice) -> tuple[str, str, dict[str, Any]]:
    seats = d.cycle((2, 3, 3, 4, 2, 3))
    arm = d.choice("arm", SOFA_ARMS)
    chaise = d.choice("chaise", ("none", "none", "none", "left", "right")) if seats >= 3 else "none"
    fabric = d.choice("fabric", FABRIC_NAMES)
    cushion_fabric = fabric if d.flag("same", 0.7) else d.choice("cf", FABRIC_NAMES)
    leg = d.choice("leg", SOFA_LEGS)
    params = dict(seats=seats, seat_width=d.uniform("w", 0.56, 0.7), depth=d.uniform("d", 0.86, 1.0),
                  seat_height=d.uniform("sh", 0.4, 0.47), back_height=d.uniform("bh", 0.72, 0.92), arm_style=arm,
                  arm_height=d.uniform("ah", 0.55, 0.68), cushion_thickness=d.uniform("ct", 0.1, 0.2),
                  leg_height=d.uniform("lh", 0.06, 0.18), leg_style=leg, back_cushions=d.flag("bc", 0.7),
                  chaise=chaise, fabric=fabric, cushion_fabric=cushion_fabric, wood=d.choice("wood", WOOD_NAMES))
    extra = f", {chaise} chaise" if chaise != "none" else ""
    return "sofa", f"{seats}-seat sofa, {arm} arms, {leg} legs{extra}, {fabric}", params


def _tables(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("dining", "coffee", "side", "dining", "coffee", "console"))
    shape = d.choice("shape", TABLE_SHAPES if kind != "console" else ("rect",))
    legs = d.choice("legs", TABLE_LEGS)
    if kind == "dining":
        w, dd, h = d.uniform("w", 1.2, 2.0), d.uniform("d", 0.8, 1.0), d.uniform("h", 0.73, 0.77)
        if shape in ("round", "square"):
            w = d.uniform("w", 0.9, 1.2)
    elif kind == "coffee":
        w, dd, h = d.uniform("w", 0.9, 1.3), d.uniform("d", 0.5, 0.7), d.uniform("h", 0.38, 0.46)
        if shape in ("round", "square"):
            w = d.uniform("w", 0.7, 0.95)
        legs = "pedestal" if legs == "trestle" else legs
    elif kind == "side":
        w, dd, h = d.uniform("w", 0.4, 0.55), d.uniform("d", 0.4, 0.5), d.uniform("h", 0.5, 0.6)
        legs = d.choice("slegs", ("square", "round", "tapered", "pedestal", "metal"))
    else:
        w, dd, h = d.uniform("w", 1.0, 1.4), d.uniform("d", 0.32, 0.4), d.uniform("h", 0.76, 0.82)
        legs = d.choice("clegs", ("square", "tapered", "metal"))
    material = d.choice("top", ("oak", "walnut", "birch", "white", "black", "teak", "grey"))
    leg_colour = material if d.flag("same", 0.6) else d.choice("legc", ("black metal", "steel", "brass", "walnut"))
    params = dict(shape=shape, width=w, depth=dd, height=h, top_thickness=d.uniform("t", 0.025, 0.05),
                  leg_style=legs, apron=d.flag("apron", 0.5), lower_shelf=kind == "coffee" and d.flag("shelf", 0.5),
                  top=material, legs=leg_colour)
    return "table", f"{kind} table, {shape} top, {legs} legs", params


def _beds(d: Dice) -> tuple[str, str, dict[str, Any]]:
    size = d.cycle(("double", "single", "king", "double", "queen"))
    width = {"single": 0.95, "double": 1.45, "queen": 1.6, "king": 1.85}[size]
    head = d.choice("head", BED_HEADBOARDS)
    params = dict(width=width, length=d.uniform("l", 2.0, 2.15), headboard=head,
                  headboard_height=d.uniform("hh", 0.9, 1.25), footboard=d.flag("foot", 0.3),
                  mattress_height=d.uniform("mh", 0.18, 0.28), frame_height=d.uniform("fh", 0.25, 0.4),
                  legs=d.flag("legs", 0.6), pillows=1 if size == "single" else 2, blanket=d.flag("blanket", 0.8),
                  wood=d.choice("wood", WOOD_NAMES), fabric=d.choice("fabric", FABRIC_NAMES),
                  bedding=d.choice("bedding", ("cream", "beige", "grey", "blush")),
                  blanket_colour=d.choice("blanket_c", FABRIC_NAMES))
    return "bed", f"{size} bed, {head} headboard", params


def _cabinets(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("nightstand", "dresser", "wardrobe", "sideboard", "tv stand", "cupboard"))
    sizes = {"nightstand": ((0.4, 0.55), (0.5, 0.65), (0.35, 0.45)), "dresser": ((0.9, 1.4), (0.75, 1.0), (0.45, 0.55)),
             "wardrobe": ((0.9, 1.5), (1.9, 2.2), (0.55, 0.62)), "sideboard": ((1.4, 1.9), (0.75, 0.9), (0.42, 0.5)),
             "tv stand": ((1.4, 1.9), (0.42, 0.55), (0.38, 0.45)), "cupboard": ((0.7, 1.0), (1.0, 1.5), (0.4, 0.5))}[kind]
    w, h, dd = (d.uniform(n, *r) for n, r in zip("whd", sizes))
    layout = {"nightstand": d.choice("l", ((2, 0, 1), (1, 1, 1), (3, 0, 1))),
              "dresser": d.choice("l", ((6, 0, 2), (4, 0, 1), (8, 0, 2))),
              "wardrobe": d.choice("l", ((0, 2, 1), (2, 2, 2), (0, 3, 1))),
              "sideboard": d.choice("l", ((0, 4, 1), (3, 3, 3), (0, 3, 1))),
              "tv stand": d.choice("l", ((2, 0, 2), (0, 2, 1), (3, 0, 3))),
              "cupboard": d.choice("l", ((1, 2, 1), (0, 2, 1)))}[kind]
    drawers, doors, columns = layout
    wood = d.choice("wood", WOOD_NAMES)
    params = dict(width=w, height=h, depth=dd, drawers=drawers, doors=doors, drawer_columns=columns,
                  base=d.choice("base", ("plinth", "legs", "none")), handle=d.choice("handle", ("bar", "knob", "none")),
                  wood=wood, fronts=wood if d.flag("same", 0.6) else d.choice("fronts", WOOD_NAMES),
                  metal=d.choice("metal", tuple(METALS)))
    return "cabinet", f"{kind}, {drawers} drawers, {doors} doors", params


def _shelves(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("bookcase", "low", "wide", "metal", "bookcase"))
    if kind == "bookcase":
        w, h, n, cols = d.uniform("w", 0.6, 0.9), d.uniform("h", 1.7, 2.0), d.choice("n", (4, 5, 6)), 1
    elif kind == "low":
        w, h, n, cols = d.uniform("w", 0.7, 1.1), d.uniform("h", 0.75, 1.0), 3, d.choice("c", (1, 2))
    elif kind == "wide":
        w, h, n, cols = d.uniform("w", 1.3, 1.6), d.uniform("h", 1.4, 1.9), d.choice("n", (4, 5)), d.choice("c", (2, 3, 4))
    else:
        w, h, n, cols = d.uniform("w", 0.8, 1.2), d.uniform("h", 1.5, 1.9), d.choice("n", (4, 5)), 1
    books = d.choice("books", (0.0, 0.5, 0.7, 0.9))
    params = dict(width=w, height=h, depth=d.uniform("d", 0.28, 0.38), shelves=n, columns=cols,
                  back_panel=d.flag("back", 0.6) and kind != "metal", sides="frame" if kind == "metal" else "solid",
                  books=books, wood=d.choice("wood", WOOD_NAMES), metal=d.choice("metal", tuple(METALS)),
                  book_colours=(d.choice("b1", FABRIC_NAMES), d.choice("b2", FABRIC_NAMES)))
    return "shelf", f"{kind} shelf, {n} levels{', books' if books else ''}", params


def _desks(d: Dice) -> tuple[str, str, dict[str, Any]]:
    side = d.cycle(("right", "left", "none", "both", "right"))
    legs = d.choice("legs", ("square", "tapered", "frame", "panel"))
    params = dict(width=d.uniform("w", 1.0, 1.6) if side != "both" else d.uniform("w", 1.4, 1.7),
                  depth=d.uniform("d", 0.55, 0.75), height=d.uniform("h", 0.73, 0.77), drawers_side=side,
                  leg_style=legs, modesty_panel=d.flag("mp", 0.5), hutch=d.flag("hutch", 0.25),
                  top=d.choice("top", WOOD_NAMES), body=d.choice("body", WOOD_NAMES),
                  metal=d.choice("metal", tuple(METALS)))
    return "desk", f"desk, drawers {side}, {legs} legs", params


def _lamps(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("table", "floor", "table", "floor", "arc", "table"))
    shade = d.choice("shade", LAMP_SHADES if kind != "arc" else ("dome",))
    base = d.choice("base", ("disk", "tripod", "square", "urn") if kind == "table" else ("disk", "tripod", "square"))
    params = dict(kind=kind, shade=shade, base=base,
                  height=d.uniform("h", 1.45, 1.75) if kind == "floor" else (None if kind == "arc" else d.uniform(
                      "h", 0.42, 0.68)),
                  shade_size=d.uniform("s", 0.35, 0.5) if kind != "table" else d.uniform("s", 0.24, 0.38),
                  shade_colour=d.choice("sc", ("cream", "beige", "grey", "charcoal", "sage", "white", "brass", "black metal")
                                        if shade != "globe" else ("cream",)),
                  body=d.choice("body", ("brass", "black metal", "steel", "oak", "walnut")),
                  base_colour=d.choice("bc", (None, None, "white", "terracotta", "teal", "black")))
    if params["shade_colour"] == "white":
        params["shade_colour"] = "cream"
    if params["base_colour"] in ("white", "black"):
        params["base_colour"] = {"white": "cream", "black": "charcoal"}[params["base_colour"]]
    return "lamp", f"{'arched floor' if kind == 'arc' else kind} lamp, {shade} shade, {base} base", params


def _rugs(d: Dice) -> tuple[str, str, dict[str, Any]]:
    shape = d.cycle(("rect", "round", "rect", "runner", "oval"))
    w, l = {"rect": (d.uniform("w", 1.6, 3.0), d.uniform("l", 1.2, 2.2)), "round": (d.uniform("w", 1.2, 2.2), 0.0),
            "runner": (d.uniform("w", 0.7, 0.9), d.uniform("l", 2.2, 3.2)),
            "oval": (d.uniform("w", 1.8, 2.6), d.uniform("l", 1.1, 1.6))}[shape]
    if shape == "round":
        l = w
    border = d.choice("border", (0.0, 0.08, 0.15, 0.22)) if shape != "runner" else d.choice("border", (0.0, 0.06, 0.1))
    params = dict(shape=shape, width=w, length=l, border=border, thickness=d.uniform("t", 0.008, 0.02, 0.001),
                  fringe=shape in ("rect", "runner") and d.flag("fringe", 0.4), field=d.choice("field", FABRIC_NAMES),
                  border_colour=d.choice("bcol", FABRIC_NAMES))
    return "rug", f"{shape} rug{', border' if border else ''}", params


def _pillows(d: Dice) -> tuple[str, str, dict[str, Any]]:
    shape = d.cycle(("square", "square", "lumbar", "round", "bolster", "square"))
    params = dict(shape=shape, size=d.uniform("s", 0.4, 0.55), thickness=d.uniform("t", 0.1, 0.16),
                  puff=d.uniform("p", 0.2, 0.45), piping=d.flag("piping", 0.4), button=d.flag("button", 0.3),
                  fabric=d.choice("fabric", FABRIC_NAMES), trim=d.choice("trim", FABRIC_NAMES))
    return "pillow", f"{shape} pillow{', piping' if params['piping'] else ''}", params


def _plants(d: Dice) -> tuple[str, str, dict[str, Any]]:
    foliage = d.cycle(("bush", "spiky", "tree", "bush"))
    params = dict(pot=d.choice("pot", ("taper", "cylinder", "bowl")),
                  height=d.uniform("h", 0.9, 1.6) if foliage == "tree" else d.uniform("h", 0.4, 1.0),
                  foliage=foliage, pot_colour=d.choice("pc", ("terracotta", "cream", "charcoal", "teal")),
                  leaves=d.choice("leaves", ("sage", "green")))
    return "plant", f"potted plant, {foliage}", params


def _tvs(d: Dice) -> tuple[str, str, dict[str, Any]]:
    stand = d.cycle(("feet", "pedestal", "none", "feet"))
    params = dict(diagonal_inches=d.choice("size", (32.0, 43.0, 50.0, 55.0, 65.0)), stand=stand,
                  frame=d.choice("frame", ("black metal", "steel", "black metal")))
    return "tv", f"{params['diagonal_inches']:.0f}-inch television, {stand}", params


CATALOGUE_COUNTS: dict[str, tuple[int, Callable[[Dice], tuple[str, str, dict[str, Any]]]]] = {
    "chair": (14, _chairs), "table": (12, _tables), "sofa": (12, _sofas), "bed": (10, _beds),
    "cabinet": (12, _cabinets), "shelf": (10, _shelves), "desk": (10, _desks), "lamp": (12, _lamps),
    "rug": (10, _rugs), "pillow": (12, _pillows), "plant": (4, _plants), "tv": (4, _tvs),
}
"""Variants per category in the built-in library, and the function choosing each one's parameters."""


def catalogue() -> list[Variant]:
    """Every parametric variant of the built-in library, in a fixed order with stable ids."""
    variants = []
    for category, (count, choose) in CATALOGUE_COUNTS.items():
        for index in range(count):
            generator, name, params = choose(Dice(category, index))
            variants.append(Variant(id=f"parametric/{category}_{index:03d}", category=category, name=name,
                                    generator=generator, params=params))
    return variants
