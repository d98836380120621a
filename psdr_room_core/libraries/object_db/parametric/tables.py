"""Tables (dining, coffee, side, console) and desks."""

from __future__ import annotations

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, cylinder, lathe, rounded_box
from .common import METALS, WOODS, add_legs, colour

TABLE_SHAPES = ("rect", "square", "round", "oval")
TABLE_LEGS = ("square", "round", "tapered", "splayed", "pedestal", "trestle", "metal")


def table(
    shape: str = "rect",
    width: float = 1.6,
    depth: float = 0.9,
    height: float = 0.75,
    top_thickness: float = 0.04,
    leg_style: str = "square",
    apron: bool = True,
    lower_shelf: bool = False,
    top: str = "oak",
    legs: str = "oak",
) -> ObjectMesh:
    """A dining, coffee, side or console table: groups ``top``, ``legs`` and ``frame`` (apron, stretchers,
    shelf). ``shape`` is rect/square/round/oval; ``leg_style="pedestal"`` is a central column."""
    if shape not in TABLE_SHAPES or leg_style not in TABLE_LEGS:
        raise ValueError(f"table: shape {shape!r} / leg_style {leg_style!r}")
    b = MeshBuilder().group("top", colour(top, WOODS, METALS)).group("legs", colour(legs, WOODS, METALS))
    b.group("frame", colour(legs, WOODS, METALS))
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
        add_legs(b, "legs", corners, leg_top, leg_style, size)
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


def desk(
    width: float = 1.3,
    depth: float = 0.65,
    height: float = 0.75,
    drawers_side: str = "right",
    leg_style: str = "square",
    modesty_panel: bool = True,
    hutch: bool = False,
    top: str = "oak",
    body: str = "white",
    metal: str = "black metal",
) -> ObjectMesh:
    """A desk: groups ``top``, ``legs``, ``drawers`` (pedestal and drawer fronts) and ``handles``;
    ``drawers_side`` is left/right/both/none (seen from the front, +Z, where the user sits)."""
    if drawers_side not in ("left", "right", "both", "none") or leg_style not in (
        "square",
        "tapered",
        "frame",
        "panel",
    ):
        raise ValueError(f"desk: drawers_side {drawers_side!r} / leg_style {leg_style!r}")
    b = (
        MeshBuilder()
        .group("top", colour(top, WOODS))
        .group("legs", colour(metal if leg_style == "frame" else body, METALS, WOODS))
    )
    b.group("drawers", colour(body, WOODS)).group("handles", colour("steel", METALS))
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
            add_legs(b, "legs", [(x, sz * (depth / 2 - 0.04)) for sz in (-1, 1)], under, leg_style, 0.045)
    if modesty_panel:
        b.add("legs", box((0, under * 0.6, -depth / 2 + 0.05), (width - 0.1, under * 0.55, 0.015)))
    if hutch:
        hh = 0.35
        for sx in (-1, 1):
            b.add("drawers", box((sx * (width / 2 - 0.01), height + hh / 2, -depth / 2 + 0.12), (0.02, hh, 0.24)))
        b.add("drawers", box((0, height + hh, -depth / 2 + 0.12), (width, 0.02, 0.24)))
        b.add("drawers", box((0, height + hh / 2, -depth / 2 + 0.005), (width, hh, 0.01)))
    return b.build()
