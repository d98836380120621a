"""Seating: chairs and stools, sofas and armchairs."""

from __future__ import annotations

import math

import numpy as np

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import (
    MeshBuilder,
    box,
    cylinder,
    lathe,
    polyline_tube,
    rot_x,
    rounded_box,
    sphere,
    torus,
    transform,
    tube,
)
from .common import FABRICS, METALS, WOODS, add_legs, colour

CHAIR_BACKS = ("slats", "solid", "rails", "spindles", "upholstered", "none")
CHAIR_LEGS = ("square", "round", "tapered", "splayed", "sled", "swivel")


def chair(
    seat_height: float = 0.46,
    seat_width: float = 0.44,
    seat_depth: float = 0.42,
    back_height: float = 0.42,
    back_style: str = "slats",
    leg_style: str = "square",
    armrests: bool = False,
    cushion: bool = False,
    seat_shape: str = "square",
    back_lean: float = 8.0,
    wood: str = "oak",
    fabric: str = "grey",
    metal: str = "black metal",
) -> ObjectMesh:
    """A chair or stool (``back_style="none"``): groups ``frame`` (seat and back), ``cushion`` (seat pad,
    upholstered back) and ``legs``. ``leg_style="swivel"`` is an office base on a five-star foot."""
    if back_style not in CHAIR_BACKS or leg_style not in CHAIR_LEGS:
        raise ValueError(f"chair: back_style {back_style!r} / leg_style {leg_style!r}")
    b = MeshBuilder().group("frame", colour(wood, WOODS, METALS)).group("cushion", colour(fabric, FABRICS))
    leg_metal = leg_style in ("sled", "swivel")
    b.group("legs", colour(metal if leg_metal else wood, METALS, WOODS))
    w, d, h, t = seat_width, seat_depth, seat_height, 0.035
    if seat_shape == "round":
        b.add("frame", cylinder((0, h - t, 0), w / 2, t, 28))
        if cushion:
            b.add(
                "cushion",
                lathe([(w / 2 - 0.01, 0), (w / 2 - 0.005, 0.03), (w / 2 - 0.06, 0.055), (0.0, 0.06)], 28, (0, h, 0)),
            )
    else:
        b.add("frame", rounded_box((0, h - t / 2, 0), (w, t, d), 0.008))
        if cushion:
            b.add(
                "cushion",
                rounded_box((0, h + 0.03, 0.01), (w - 0.03, 0.06, d - 0.04), 0.025, flat=(3, 1, 3), puff=0.15),
            )
    inset = 0.035
    corners = [(sx * (w / 2 - inset), sz * (d / 2 - inset)) for sz in (1, -1) for sx in (-1, 1)]
    if seat_shape == "round":
        corners = [(sx * w * 0.3, sz * w * 0.3) for sz in (1, -1) for sx in (-1, 1)]
    if leg_style == "sled":
        for sx in (-1, 1):
            x = sx * (w / 2 - 0.03)
            b.add_all(
                "legs",
                polyline_tube(
                    [
                        (x, h - t, d / 2 - 0.04),
                        (x, 0.012, d / 2 - 0.02),
                        (x, 0.012, -d / 2 + 0.02),
                        (x, h - t, -d / 2 + 0.04),
                    ],
                    0.011,
                ),
            )
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
        add_legs(b, "legs", corners, h - t, leg_style, 0.04)
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
            parts.append(
                (
                    "cushion",
                    rounded_box(
                        (0, h + back_height / 2, z + 0.02), (w, back_height, 0.08), 0.03, flat=(3, 3, 1), puff=0.1
                    ),
                )
            )
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


SOFA_ARMS = ("square", "rolled", "track", "rounded", "none")
SOFA_LEGS = ("block", "tapered", "round", "metal", "plinth")


def sofa(
    seats: int = 3,
    seat_width: float = 0.62,
    depth: float = 0.92,
    seat_height: float = 0.44,
    back_height: float = 0.84,
    arm_style: str = "square",
    arm_height: float = 0.62,
    cushion_thickness: float = 0.14,
    leg_height: float = 0.1,
    leg_style: str = "tapered",
    back_cushions: bool = True,
    chaise: str = "none",
    fabric: str = "grey",
    cushion_fabric: str | None = None,
    wood: str = "walnut",
) -> ObjectMesh:
    """A sofa (``seats=1`` is an armchair): groups ``frame`` (base, back, arms), ``cushion`` (seat and back
    cushions) and ``legs``; ``chaise="left"/"right"`` extends one end forward into a chaise longue."""
    if arm_style not in SOFA_ARMS or leg_style not in SOFA_LEGS or chaise not in ("none", "left", "right"):
        raise ValueError(f"sofa: arm_style {arm_style!r} / leg_style {leg_style!r} / chaise {chaise!r}")
    b = MeshBuilder().group("frame", colour(fabric, FABRICS))
    b.group("cushion", colour(cushion_fabric or fabric, FABRICS))
    b.group("legs", colour(wood, WOODS, METALS))
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
    b.add(
        "frame",
        rounded_box(
            (0, (leg_h + back_height) / 2, -depth / 2 + back_t / 2), (width, back_height - leg_h, back_t), 0.05
        ),
    )
    if chaise_len:
        cx = chaise_sign * (width / 2 - (seat_width + arm_w) / 2)
        b.add(
            "frame",
            rounded_box(
                (cx, (leg_h + base_top) / 2, depth / 2 + chaise_len / 2 - 0.03),
                (seat_width + arm_w, base_top - leg_h, chaise_len + 0.06),
                0.03,
            ),
        )
    # arms
    for sx in (-1, 1):
        if arm_style == "none" or (chaise_len and sx == chaise_sign):
            continue
        x = sx * (width / 2 - arm_w / 2)
        if arm_style == "rolled":
            r = arm_w * 0.62
            b.add(
                "frame",
                rounded_box((x, (leg_h + arm_height - r) / 2, 0.0), (arm_w, arm_height - r - leg_h, depth), 0.02),
            )
            b.add(
                "frame",
                tube(
                    (x + sx * 0.02, arm_height - r, -depth / 2 + 0.01),
                    (x + sx * 0.02, arm_height - r, depth / 2),
                    r,
                    20,
                ),
            )
        else:
            radius = {"square": 0.04, "track": 0.02, "rounded": 0.08}[arm_style]
            b.add("frame", rounded_box((x, (leg_h + arm_height) / 2, 0.0), (arm_w, arm_height - leg_h, depth), radius))
    # cushions
    seat_d = depth - back_t - 0.02
    for k in range(seats):
        x = -inner / 2 + seat_width * (k + 0.5)
        extra = (
            chaise_len if chaise_len and ((chaise_sign > 0 and k == seats - 1) or (chaise_sign < 0 and k == 0)) else 0.0
        )
        b.add(
            "cushion",
            rounded_box(
                (x, seat_height - cushion_thickness / 2, depth / 2 - seat_d / 2 + extra / 2),
                (seat_width - 0.012, cushion_thickness, seat_d + extra),
                0.04,
                flat=(3, 1, 3),
                puff=0.12,
            ),
        )
        if back_cushions:
            bh = back_height - seat_height - 0.02
            part = rounded_box(
                (x, seat_height + bh / 2, -depth / 2 + back_t + 0.08),
                (seat_width - 0.02, bh, 0.16),
                0.05,
                flat=(3, 3, 1),
                puff=0.15,
            )
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
        add_legs(b, "legs", corners, leg_h, "metal" if leg_style == "metal" else leg_style, 0.05, top=leg_h + 0.01)
    return b.build()


def ottoman(
    shape: str = "square",
    width: float = 0.6,
    depth: float = 0.6,
    height: float = 0.42,
    legs_height: float = 0.0,
    tufted: bool = False,
    fabric: str = "beige",
    wood: str = "walnut",
) -> ObjectMesh:
    """An ottoman, footstool or pouf: groups ``cushion`` (the upholstered top), ``base`` (the upholstered body)
    and ``legs`` (none when ``legs_height`` is 0). ``shape`` is square/rect/round (a round one without legs
    is a pouf); ``tufted`` adds buttons on a grid."""
    if shape not in ("square", "rect", "round"):
        raise ValueError(f"ottoman: shape {shape!r}")
    b = MeshBuilder().group("cushion", colour(fabric, FABRICS)).group("base", colour(fabric, FABRICS))
    b.group("legs", colour(wood, WOODS, METALS)).group("buttons", colour(fabric, FABRICS))
    if shape == "square":
        depth = width
    top_t = min(0.1, 0.3 * (height - legs_height))
    body_h = height - legs_height - top_t
    if shape == "round":
        r = width / 2
        y = legs_height + body_h
        b.add(
            "base",
            lathe([(r * 0.96, legs_height), (r, legs_height + body_h * 0.5), (r * 0.98, y)], 40, scale_z=depth / width),
        )
        b.add(
            "cushion",
            lathe(
                [(r * 0.98, y), (r, y + top_t * 0.5), (r * 0.8, y + top_t * 0.95), (0.0, height)],
                40,
                scale_z=depth / width,
            ),
        )
        foot = [(sx * r * 0.6, sz * r * 0.6 * depth / width) for sz in (1, -1) for sx in (-1, 1)]
    else:
        b.add("base", rounded_box((0, legs_height + body_h / 2, 0), (width, body_h, depth), 0.03))
        b.add(
            "cushion",
            rounded_box(
                (0, legs_height + body_h + top_t / 2, 0), (width, top_t, depth), 0.04, flat=(4, 1, 4), puff=0.12
            ),
        )
        foot = [(sx * (width / 2 - 0.05), sz * (depth / 2 - 0.05)) for sz in (1, -1) for sx in (-1, 1)]
    if legs_height > 0:
        add_legs(b, "legs", foot, legs_height, "tapered", 0.05, top=legs_height + 0.01)
    if tufted and shape != "round":
        for i in (-1, 0, 1):
            for k in (-1, 1):
                b.add("buttons", sphere((i * width / 4, height - 0.005, k * depth / 5), 0.014, 8, scale=(1, 0.5, 1)))
    return b.build()
