"""Storage: cabinets (nightstands, dressers, wardrobes, sideboards, TV stands), shelves, kitchen units, boxes and
baskets."""

from __future__ import annotations

import math

import numpy as np

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, lathe, rounded_box, sphere
from .common import FABRICS, METALS, WOODS, add_legs, colour


def cabinet(
    width: float = 1.0,
    height: float = 0.85,
    depth: float = 0.45,
    drawers: int = 0,
    doors: int = 2,
    drawer_columns: int = 1,
    base: str = "plinth",
    handle: str = "bar",
    top_overhang: float = 0.01,
    wood: str = "oak",
    fronts: str | None = None,
    metal: str = "steel",
) -> ObjectMesh:
    """A cabinet, dresser, nightstand, wardrobe, sideboard or TV stand: drawers (in ``drawer_columns``)
    above ``doors``; groups ``body``, ``fronts`` (doors and drawer fronts), ``handles`` and ``legs``;
    ``base`` is plinth/legs/none."""
    if base not in ("plinth", "legs", "none") or handle not in ("bar", "knob", "none"):
        raise ValueError(f"cabinet: base {base!r} / handle {handle!r}")
    b = MeshBuilder().group("body", colour(wood, WOODS)).group("fronts", colour(fronts or wood, WOODS))
    b.group("handles", colour(metal, METALS)).group("legs", colour(wood if base == "plinth" else metal, WOODS, METALS))
    base_h = {"plinth": 0.08, "legs": 0.16, "none": 0.0}[base]
    if base == "plinth":
        b.add("legs", box((0, base_h / 2, -0.02), (width - 0.04, base_h, depth - 0.06)))
    elif base == "legs":
        add_legs(
            b,
            "legs",
            [(sx * (width / 2 - 0.05), sz * (depth / 2 - 0.05)) for sz in (1, -1) for sx in (-1, 1)],
            base_h,
            "tapered",
            0.05,
            top=base_h + 0.01,
        )
    body_h = height - base_h - 0.03
    b.add("body", box((0, base_h + body_h / 2, 0), (width, body_h, depth)))
    b.add(
        "body",
        rounded_box(
            (0, height - 0.015, top_overhang / 2), (width + 2 * top_overhang, 0.03, depth + top_overhang), 0.006
        ),
    )
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


def shelf(
    width: float = 0.8,
    height: float = 1.8,
    depth: float = 0.32,
    shelves: int = 5,
    columns: int = 1,
    back_panel: bool = True,
    sides: str = "solid",
    books: float = 0.6,
    wood: str = "white",
    metal: str = "black metal",
    book_colours: tuple[str, str] = ("terracotta", "navy"),
) -> ObjectMesh:
    """A bookcase or shelving unit: groups ``frame`` (sides, top, bottom, dividers), ``shelves``, ``back`` and
    ``books`` / ``books_alt`` (``books`` is the fraction of each compartment filled). ``sides="frame"`` is
    an open metal frame."""
    if sides not in ("solid", "frame"):
        raise ValueError(f"shelf: sides {sides!r}")
    b = MeshBuilder().group("frame", colour(metal if sides == "frame" else wood, METALS, WOODS))
    b.group("shelves", colour(wood, WOODS)).group("back", colour(wood, WOODS))
    b.group("books", colour(book_colours[0], FABRICS)).group("books_alt", colour(book_colours[1], FABRICS))
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
                b.add(
                    "frame",
                    box((sx * (width / 2 - 0.012), height / 2, sz * (depth / 2 - 0.012)), (0.024, height, 0.024)),
                )
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


def kitchen_unit(
    kind: str = "base",
    width: float = 1.8,
    height: float | None = None,
    depth: float | None = None,
    modules: int = 3,
    drawers: bool = True,
    counter: str = "granite",
    wood: str = "white",
    fronts: str | None = None,
    metal: str = "steel",
) -> ObjectMesh:
    """A run of kitchen cabinets: ``base`` (plinth, drawers over doors, a worktop), ``wall`` (hung doors) or
    ``tall`` (a pantry). Groups ``body``, ``fronts``, ``handles``, ``plinth`` and ``counter`` (the worktop of
    a base run); ``modules`` door columns share the width."""
    if kind not in ("base", "wall", "tall"):
        raise ValueError(f"kitchen_unit: kind {kind!r}")
    counters = {
        "granite": (0.22, 0.21, 0.21),
        "marble": (0.88, 0.87, 0.85),
        "oak": WOODS["oak"],
        "white": (0.93, 0.93, 0.91),
        "black": (0.08, 0.08, 0.09),
        "concrete": (0.6, 0.59, 0.57),
    }
    height = height or {"base": 0.9, "wall": 0.72, "tall": 2.1}[kind]
    depth = depth or {"base": 0.6, "wall": 0.34, "tall": 0.6}[kind]
    b = MeshBuilder().group("body", colour(wood, WOODS)).group("fronts", colour(fronts or wood, WOODS))
    b.group("handles", colour(metal, METALS)).group("plinth", (0.12, 0.12, 0.12)).group("counter", counters[counter])
    plinth = 0.1 if kind != "wall" else 0.0
    top = 0.04 if kind == "base" else 0.0
    carcass = height - plinth - top
    if plinth:
        b.add("plinth", box((0, plinth / 2, -0.04), (width, plinth, depth - 0.1)))
    b.add("body", box((0, plinth + carcass / 2, -0.01), (width, carcass, depth - 0.03)))
    if top:
        b.add("counter", box((0, height - top / 2, 0.01), (width + 0.02, top, depth + 0.02)))
    zf, gap, cell = depth / 2 - 0.015, 0.004, width / modules
    y0, y1 = plinth + 0.005, plinth + carcass - 0.005
    drawer_h = 0.16 if kind == "base" and drawers else 0.0
    for m in range(modules):
        cx = -width / 2 + cell * (m + 0.5)
        if drawer_h:
            b.add("fronts", box((cx, y1 - drawer_h / 2, zf), (cell - gap, drawer_h - gap, 0.02)))
            b.add("handles", box((cx, y1 - drawer_h / 2, zf + 0.02), (min(0.3, cell * 0.5), 0.012, 0.02)))
        door_top = y1 - drawer_h
        b.add("fronts", box((cx, (y0 + door_top) / 2, zf), (cell - gap, door_top - y0 - gap, 0.02)))
        hx = cx + (cell / 2 - 0.04) * (1 if m % 2 == 0 else -1)
        hy = door_top - 0.08 if kind != "wall" else y0 + 0.08
        b.add("handles", box((hx, hy, zf + 0.02), (0.012, 0.12, 0.02)))
    return b.build()


def container(
    kind: str = "box",
    width: float = 0.5,
    depth: float = 0.35,
    height: float = 0.3,
    lid: bool = False,
    body: str = "cardboard",
    trim: str = "cream",
) -> ObjectMesh:
    """A cardboard box, a plastic storage bin, a woven basket or a wooden crate: groups ``body``, ``lid`` (a
    lid or a box's taped flaps) and ``trim`` (tape, handles, a basket's rim)."""
    if kind not in ("box", "bin", "basket", "crate"):
        raise ValueError(f"container: kind {kind!r}")
    colours = {
        "cardboard": (0.66, 0.5, 0.33),
        "white": (0.9, 0.9, 0.88),
        "clear": (0.78, 0.8, 0.82),
        "blue": (0.2, 0.38, 0.62),
        "grey": (0.5, 0.5, 0.5),
        "wicker": (0.62, 0.47, 0.28),
        "pine": WOODS["birch"],
        "black": (0.1, 0.1, 0.11),
    }
    b = MeshBuilder().group("body", colours[body]).group("lid", colours[body]).group("trim", colour(trim, FABRICS))
    if kind == "box":
        b.add("body", box((0, height / 2, 0), (width, height, depth)))
        b.add("lid", box((0, height + 0.002, 0), (width, 0.004, depth)))
        b.add("trim", box((0, height + 0.004, 0), (0.05, 0.004, depth + 0.002)))
    elif kind == "bin":
        corner = width / math.sqrt(2.0)  # a square frustum: four lathe segments turned by 45 degrees
        b.add("body", lathe([(0.88 * corner, 0.0), (corner, height)], 4, twist=math.pi / 4, scale_z=depth / width))
        b.add("trim", box((0, height - 0.02, 0), (width, 0.04, depth)))
        if lid:
            b.add("lid", rounded_box((0, height + 0.02, 0), (width + 0.01, 0.04, depth + 0.01), 0.01))
        for sx in (-1, 1):
            b.add("trim", box((sx * (width / 2 + 0.005), height - 0.06, 0), (0.02, 0.03, depth * 0.35)))
    elif kind == "basket":
        r = width / 2
        b.add("body", lathe([(r * 0.8, 0.0), (r, height)], 32, scale_z=depth / width))
        rim = [(r, height - 0.025), (r * 1.03, height - 0.01), (r * 1.03, height), (r, height + 0.01)]
        b.add("trim", lathe(rim, 32, scale_z=depth / width, caps=False))
    else:  # crate: slats with gaps on every side
        slats = 3
        for k in range(slats):
            y = height * (k + 0.5) / slats
            for sz in (-1, 1):
                b.add("body", box((0, y, sz * (depth / 2 - 0.01)), (width, height / slats * 0.7, 0.02)))
            for sx in (-1, 1):
                b.add("body", box((sx * (width / 2 - 0.01), y, 0), (0.02, height / slats * 0.7, depth)))
        b.add("body", box((0, 0.01, 0), (width, 0.02, depth)))
        for sx in (-1, 1):
            for sz in (-1, 1):
                b.add("trim", box((sx * (width / 2 - 0.02), height / 2, sz * (depth / 2 - 0.02)), (0.04, height, 0.04)))
    return b.build()
