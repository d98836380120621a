"""Beds."""

from __future__ import annotations

import numpy as np

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, lathe, rot_x, rounded_box, transform
from .common import FABRICS, METALS, WOODS, add_legs, colour

BED_HEADBOARDS = ("panel", "upholstered", "slats", "tall", "rounded", "none")
BED_FOOTBOARDS = ("none", "rail", "panel")


def bed(
    width: float = 1.6,
    length: float = 2.05,
    headboard: str = "panel",
    headboard_height: float = 1.0,
    footboard: str = "none",
    footboard_height: float = 0.85,
    mattress_height: float = 0.22,
    frame_height: float = 0.32,
    legs: bool = True,
    pillows: int = 2,
    blanket: bool = True,
    wood: str = "oak",
    fabric: str = "grey",
    bedding: str = "cream",
    blanket_colour: str = "navy",
) -> ObjectMesh:
    """A bed: groups ``frame``, ``headboard``, ``mattress``, ``bedding`` (duvet), ``pillow`` and ``legs``;
    the headboard is at the back (-Z), the foot at the front (+Z)."""
    if headboard not in BED_HEADBOARDS:
        raise ValueError(f"bed: headboard {headboard!r}")
    if footboard not in BED_FOOTBOARDS:
        raise ValueError(f"bed: footboard {footboard!r}")
    b = MeshBuilder().group("frame", colour(wood, WOODS, FABRICS))
    upholstered = headboard in ("upholstered", "rounded")
    b.group("headboard", colour(fabric if upholstered else wood, FABRICS, WOODS))
    b.group("mattress", colour("cream", FABRICS)).group("bedding", colour(blanket_colour, FABRICS))
    b.group("pillow", colour(bedding, FABRICS)).group("legs", colour(wood, WOODS, METALS))
    leg_h = 0.12 if legs else 0.0
    W, L = width, length
    b.add("frame", rounded_box((0, (leg_h + frame_height) / 2, 0), (W + 0.08, frame_height - leg_h, L + 0.06), 0.015))
    if legs:
        add_legs(
            b,
            "legs",
            [(sx * (W / 2 - 0.02), sz * (L / 2 - 0.04)) for sz in (1, -1) for sx in (-1, 1)],
            leg_h,
            "square",
            0.06,
            top=leg_h + 0.01,
        )
    top = frame_height + mattress_height
    b.add(
        "mattress",
        rounded_box(
            (0, frame_height + mattress_height / 2, 0.02), (W, mattress_height, L - 0.04), 0.05, flat=(2, 1, 3)
        ),
    )
    if blanket:
        cover = L * 0.66
        drop = mattress_height * 0.75
        b.add(
            "bedding",
            rounded_box(
                (0, top + 0.02 - (drop + 0.04) / 2, L / 2 - cover / 2 + 0.01),
                (W + 0.05, drop + 0.04, cover),
                0.03,
                flat=(4, 1, 4),
                puff=0.08,
            ),
        )
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
        b.add(
            "headboard",
            rounded_box(
                (0, (hb + frame_height) / 2, z - 0.02),
                (W + 0.12, hb - frame_height, 0.1),
                0.04,
                flat=(6, 4, 1),
                puff=0.12,
            ),
        )
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
    if footboard == "rail":  # a low board at the mattress's top
        fb = frame_height + 0.22
        b.add("frame", box((0, fb / 2, L / 2 + 0.03), (W + 0.1, fb, 0.05)))
    elif footboard == "panel":  # a panel or sleigh bed's board, ``footboard_height`` above the floor
        b.add("headboard", box((0, footboard_height / 2, L / 2 + 0.03), (W + 0.1, footboard_height, 0.06)))
    return b.build()
