"""The parametric part of the built-in library: which variants of each generator it ships, with stable ids.

A *series* is a run of variants of one kind (``chair``, ``kitchen``, ``frame``, ...) in one database category;
variant ``k`` of series ``s`` is ``parametric/<s>_<kkk>``, its parameters chosen by ``Dice(s, k)``.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from psdr_room_core.method.artifacts import ObjectMesh

from .appliances import FINISHES, microwave, oven, refrigerator, washer
from .beds import BED_HEADBOARDS, bed
from .common import FABRICS, METALS
from .decor import frame, plant
from .electronics import monitor, tv
from .lighting import LAMP_SHADES, lamp
from .seating import SOFA_ARMS, SOFA_LEGS, chair, ottoman, sofa
from .storage import cabinet, container, kitchen_unit, shelf
from .tables import TABLE_LEGS, TABLE_SHAPES, desk, table
from .textiles import pillow, rug

GENERATORS: dict[str, Callable[..., ObjectMesh]] = {
    "chair": chair,
    "table": table,
    "sofa": sofa,
    "bed": bed,
    "cabinet": cabinet,
    "shelf": shelf,
    "desk": desk,
    "lamp": lamp,
    "rug": rug,
    "pillow": pillow,
    "plant": plant,
    "tv": tv,
    "ottoman": ottoman,
    "kitchen_unit": kitchen_unit,
    "container": container,
    "frame": frame,
    "monitor": monitor,
    "refrigerator": refrigerator,
    "microwave": microwave,
    "oven": oven,
    "washer": washer,
}
"""Every generator by name (an armchair is :func:`sofa` with one seat, in the ``chair`` category)."""


class Dice:
    """Deterministic 'random' parameter choices: a hash of (series, index, parameter name), so that the
    catalogue is the same on every machine and numpy version."""

    def __init__(self, series: str, index: int) -> None:
        self.key = f"{series}:{index}"
        self.index = index

    def unit(self, name: str) -> float:
        digest = hashlib.blake2b(f"{self.key}:{name}".encode(), digest_size=8).digest()
        return int.from_bytes(digest, "big") / 2.0**64

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
        params = dict(
            seats=1,
            seat_width=d.uniform("w", 0.55, 0.66),
            depth=d.uniform("d", 0.78, 0.9),
            back_height=d.uniform("bh", 0.76, 0.95),
            arm_style=arm,
            leg_style=d.choice("leg", SOFA_LEGS),
            leg_height=d.uniform("lh", 0.08, 0.16),
            fabric=fabric,
            wood=wood,
            back_cushions=d.flag("bc"),
        )
        return "sofa", f"armchair, {arm} arms, {fabric}", params
    if kind == "stool":
        bar = d.flag("bar", 0.6)
        shape = d.choice("shape", ("round", "square"))
        params = dict(
            seat_height=d.uniform("h", 0.72, 0.78) if bar else d.uniform("h", 0.44, 0.5),
            seat_width=d.uniform("w", 0.34, 0.4),
            seat_depth=0.36,
            back_style="none",
            leg_style=d.choice("leg", ("round", "tapered", "splayed", "square")),
            seat_shape=shape,
            cushion=d.flag("cushion"),
            wood=wood,
            fabric=fabric,
        )
        params["seat_depth"] = params["seat_width"]
        return "chair", f"{'bar ' if bar else ''}stool, {shape} seat, {params['leg_style']} legs", params
    if kind == "office":
        params = dict(
            seat_height=0.48,
            seat_width=0.5,
            seat_depth=0.48,
            back_height=d.uniform("bh", 0.45, 0.6),
            back_style="upholstered",
            leg_style="swivel",
            armrests=d.flag("arms", 0.7),
            cushion=True,
            fabric=d.choice("fabric", ("charcoal", "grey", "navy", "leather")),
            wood="black metal",
        )
        return "chair", "office chair, swivel base", params
    back = d.choice("back", ("slats", "solid", "rails", "spindles", "upholstered"))
    legs = d.choice("legs", ("square", "round", "tapered", "splayed", "sled"))
    params = dict(
        seat_height=d.uniform("h", 0.44, 0.48),
        seat_width=d.uniform("w", 0.42, 0.5),
        seat_depth=d.uniform("d", 0.4, 0.48),
        back_height=d.uniform("bh", 0.36, 0.5),
        back_style=back,
        leg_style=legs,
        armrests=d.flag("arms", 0.3),
        cushion=d.flag("cushion", 0.5) or back == "upholstered",
        wood=wood,
        fabric=fabric,
        back_lean=d.uniform("lean", 4, 12, 1),
    )
    return "chair", f"dining chair, {back} back, {legs} legs{', armrests' if params['armrests'] else ''}", params


def _sofas(d: Dice) -> tuple[str, str, dict[str, Any]]:
    seats = d.cycle((2, 3, 3, 4, 2, 3))
    arm = d.choice("arm", SOFA_ARMS)
    chaise = d.choice("chaise", ("none", "none", "none", "left", "right")) if seats >= 3 else "none"
    fabric = d.choice("fabric", FABRIC_NAMES)
    cushion_fabric = fabric if d.flag("same", 0.7) else d.choice("cf", FABRIC_NAMES)
    leg = d.choice("leg", SOFA_LEGS)
    params = dict(
        seats=seats,
        seat_width=d.uniform("w", 0.56, 0.7),
        depth=d.uniform("d", 0.86, 1.0),
        seat_height=d.uniform("sh", 0.4, 0.47),
        back_height=d.uniform("bh", 0.72, 0.92),
        arm_style=arm,
        arm_height=d.uniform("ah", 0.55, 0.68),
        cushion_thickness=d.uniform("ct", 0.1, 0.2),
        leg_height=d.uniform("lh", 0.06, 0.18),
        leg_style=leg,
        back_cushions=d.flag("bc", 0.7),
        chaise=chaise,
        fabric=fabric,
        cushion_fabric=cushion_fabric,
        wood=d.choice("wood", WOOD_NAMES),
    )
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
    params = dict(
        shape=shape,
        width=w,
        depth=dd,
        height=h,
        top_thickness=d.uniform("t", 0.025, 0.05),
        leg_style=legs,
        apron=d.flag("apron", 0.5),
        lower_shelf=kind == "coffee" and d.flag("shelf", 0.5),
        top=material,
        legs=leg_colour,
    )
    return "table", f"{kind} table, {shape} top, {legs} legs", params


def _beds(d: Dice) -> tuple[str, str, dict[str, Any]]:
    size = d.cycle(("double", "single", "king", "double", "queen"))
    width = {"single": 0.95, "double": 1.45, "queen": 1.6, "king": 1.85}[size]
    head = d.choice("head", BED_HEADBOARDS)
    foot = d.choice("footboard", ("none", "none", "rail", "panel")) if head != "none" else "none"
    params = dict(
        width=width,
        length=d.uniform("l", 2.0, 2.15),
        headboard=head,
        headboard_height=d.uniform("hh", 0.9, 1.25),
        footboard=foot,
        footboard_height=d.uniform("fbh", 0.7, 1.0),
        mattress_height=d.uniform("mh", 0.18, 0.28),
        frame_height=d.uniform("fh", 0.25, 0.4),
        legs=d.flag("legs", 0.6),
        pillows=1 if size == "single" else 2,
        blanket=d.flag("blanket", 0.8),
        wood=d.choice("wood", WOOD_NAMES),
        fabric=d.choice("fabric", FABRIC_NAMES),
        bedding=d.choice("bedding", ("cream", "beige", "grey", "blush")),
        blanket_colour=d.choice("blanket_c", FABRIC_NAMES),
    )
    return "bed", f"{size} bed, {head} headboard" + (f", {foot} footboard" if foot != "none" else ""), params


def _cabinets(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("nightstand", "dresser", "wardrobe", "sideboard", "tv stand", "cupboard"))
    sizes = {
        "nightstand": ((0.4, 0.55), (0.5, 0.65), (0.35, 0.45)),
        "dresser": ((0.9, 1.4), (0.75, 1.0), (0.45, 0.55)),
        "wardrobe": ((0.9, 1.5), (1.9, 2.2), (0.55, 0.62)),
        "sideboard": ((1.4, 1.9), (0.75, 0.9), (0.42, 0.5)),
        "tv stand": ((1.4, 1.9), (0.42, 0.55), (0.38, 0.45)),
        "cupboard": ((0.7, 1.0), (1.0, 1.5), (0.4, 0.5)),
    }[kind]
    w, h, dd = (d.uniform(n, *r) for n, r in zip("whd", sizes))
    layout = {
        "nightstand": d.choice("l", ((2, 0, 1), (1, 1, 1), (3, 0, 1))),
        "dresser": d.choice("l", ((6, 0, 2), (4, 0, 1), (8, 0, 2))),
        "wardrobe": d.choice("l", ((0, 2, 1), (2, 2, 2), (0, 3, 1))),
        "sideboard": d.choice("l", ((0, 4, 1), (3, 3, 3), (0, 3, 1))),
        "tv stand": d.choice("l", ((2, 0, 2), (0, 2, 1), (3, 0, 3))),
        "cupboard": d.choice("l", ((1, 2, 1), (0, 2, 1))),
    }[kind]
    drawers, doors, columns = layout
    wood = d.choice("wood", WOOD_NAMES)
    params = dict(
        width=w,
        height=h,
        depth=dd,
        drawers=drawers,
        doors=doors,
        drawer_columns=columns,
        base=d.choice("base", ("plinth", "legs", "none")),
        handle=d.choice("handle", ("bar", "knob", "none")),
        wood=wood,
        fronts=wood if d.flag("same", 0.6) else d.choice("fronts", WOOD_NAMES),
        metal=d.choice("metal", tuple(METALS)),
    )
    return "cabinet", f"{kind}, {drawers} drawers, {doors} doors", params


def _shelves(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("bookcase", "low", "wide", "metal", "bookcase"))
    if kind == "bookcase":
        w, h, n, cols = d.uniform("w", 0.6, 0.9), d.uniform("h", 1.7, 2.0), d.choice("n", (4, 5, 6)), 1
    elif kind == "low":
        w, h, n, cols = d.uniform("w", 0.7, 1.1), d.uniform("h", 0.75, 1.0), 3, d.choice("c", (1, 2))
    elif kind == "wide":
        w, h, n, cols = (
            d.uniform("w", 1.3, 1.6),
            d.uniform("h", 1.4, 1.9),
            d.choice("n", (4, 5)),
            d.choice("c", (2, 3, 4)),
        )
    else:
        w, h, n, cols = d.uniform("w", 0.8, 1.2), d.uniform("h", 1.5, 1.9), d.choice("n", (4, 5)), 1
    books = d.choice("books", (0.0, 0.5, 0.7, 0.9))
    params = dict(
        width=w,
        height=h,
        depth=d.uniform("d", 0.28, 0.38),
        shelves=n,
        columns=cols,
        back_panel=d.flag("back", 0.6) and kind != "metal",
        sides="frame" if kind == "metal" else "solid",
        books=books,
        wood=d.choice("wood", WOOD_NAMES),
        metal=d.choice("metal", tuple(METALS)),
        book_colours=(d.choice("b1", FABRIC_NAMES), d.choice("b2", FABRIC_NAMES)),
    )
    return "shelf", f"{kind} shelf, {n} levels{', books' if books else ''}", params


def _desks(d: Dice) -> tuple[str, str, dict[str, Any]]:
    side = d.cycle(("right", "left", "none", "both", "right"))
    legs = d.choice("legs", ("square", "tapered", "frame", "panel"))
    params = dict(
        width=d.uniform("w", 1.0, 1.6) if side != "both" else d.uniform("w", 1.4, 1.7),
        depth=d.uniform("d", 0.55, 0.75),
        height=d.uniform("h", 0.73, 0.77),
        drawers_side=side,
        leg_style=legs,
        modesty_panel=d.flag("mp", 0.5),
        hutch=d.flag("hutch", 0.25),
        top=d.choice("top", WOOD_NAMES),
        body=d.choice("body", WOOD_NAMES),
        metal=d.choice("metal", tuple(METALS)),
    )
    return "desk", f"desk, drawers {side}, {legs} legs", params


def _lamps(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("table", "floor", "table", "floor", "arc", "table"))
    shade = d.choice("shade", LAMP_SHADES if kind != "arc" else ("dome",))
    base = d.choice("base", ("disk", "tripod", "square", "urn") if kind == "table" else ("disk", "tripod", "square"))
    params = dict(
        kind=kind,
        shade=shade,
        base=base,
        height=d.uniform("h", 1.45, 1.75)
        if kind == "floor"
        else (None if kind == "arc" else d.uniform("h", 0.42, 0.68)),
        shade_size=d.uniform("s", 0.35, 0.5) if kind != "table" else d.uniform("s", 0.24, 0.38),
        shade_colour=d.choice(
            "sc",
            ("cream", "beige", "grey", "charcoal", "sage", "white", "brass", "black metal")
            if shade != "globe"
            else ("cream",),
        ),
        body=d.choice("body", ("brass", "black metal", "steel", "oak", "walnut")),
        base_colour=d.choice("bc", (None, None, "white", "terracotta", "teal", "black")),
    )
    if params["shade_colour"] == "white":
        params["shade_colour"] = "cream"
    if params["base_colour"] in ("white", "black"):
        params["base_colour"] = {"white": "cream", "black": "charcoal"}[params["base_colour"]]
    return "lamp", f"{'arched floor' if kind == 'arc' else kind} lamp, {shade} shade, {base} base", params


def _rugs(d: Dice) -> tuple[str, str, dict[str, Any]]:
    shape = d.cycle(("rect", "round", "rect", "runner", "oval"))
    w, l = {
        "rect": (d.uniform("w", 1.6, 3.0), d.uniform("l", 1.2, 2.2)),
        "round": (d.uniform("w", 1.2, 2.2), 0.0),
        "runner": (d.uniform("w", 0.7, 0.9), d.uniform("l", 2.2, 3.2)),
        "oval": (d.uniform("w", 1.8, 2.6), d.uniform("l", 1.1, 1.6)),
    }[shape]
    if shape == "round":
        l = w
    border = d.choice("border", (0.0, 0.08, 0.15, 0.22)) if shape != "runner" else d.choice("border", (0.0, 0.06, 0.1))
    params = dict(
        shape=shape,
        width=w,
        length=l,
        border=border,
        thickness=d.uniform("t", 0.008, 0.02, 0.001),
        fringe=shape in ("rect", "runner") and d.flag("fringe", 0.4),
        field=d.choice("field", FABRIC_NAMES),
        border_colour=d.choice("bcol", FABRIC_NAMES),
    )
    return "rug", f"{shape} rug{', border' if border else ''}", params


def _pillows(d: Dice) -> tuple[str, str, dict[str, Any]]:
    shape = d.cycle(("square", "square", "lumbar", "round", "bolster", "square"))
    params = dict(
        shape=shape,
        size=d.uniform("s", 0.4, 0.55),
        thickness=d.uniform("t", 0.1, 0.16),
        puff=d.uniform("p", 0.2, 0.45),
        piping=d.flag("piping", 0.4),
        button=d.flag("button", 0.3),
        fabric=d.choice("fabric", FABRIC_NAMES),
        trim=d.choice("trim", FABRIC_NAMES),
    )
    return "pillow", f"{shape} pillow{', piping' if params['piping'] else ''}", params


def _plants(d: Dice) -> tuple[str, str, dict[str, Any]]:
    foliage = d.cycle(("bush", "spiky", "tree", "bush"))
    params = dict(
        pot=d.choice("pot", ("taper", "cylinder", "bowl")),
        height=d.uniform("h", 0.9, 1.6) if foliage == "tree" else d.uniform("h", 0.4, 1.0),
        foliage=foliage,
        pot_colour=d.choice("pc", ("terracotta", "cream", "charcoal", "teal")),
        leaves=d.choice("leaves", ("sage", "green")),
    )
    return "plant", f"potted plant, {foliage}", params


def _tvs(d: Dice) -> tuple[str, str, dict[str, Any]]:
    stand = d.cycle(("feet", "pedestal", "none", "feet"))
    params = dict(
        diagonal_inches=d.choice("size", (32.0, 43.0, 50.0, 55.0, 65.0)),
        stand=stand,
        frame=d.choice("frame", ("black metal", "steel", "black metal")),
    )
    return "tv", f"{params['diagonal_inches']:.0f}-inch television, {stand}", params


def _ottomans(d: Dice) -> tuple[str, str, dict[str, Any]]:
    shape = d.cycle(("square", "round", "rect"))
    legs = d.flag("legs", 0.5) and shape != "round"
    width = d.uniform("w", 0.45, 0.6) if shape == "round" else d.uniform("w", 0.5, 1.1)
    params = dict(
        shape=shape,
        width=width,
        depth=width if shape != "rect" else d.uniform("d", 0.45, 0.65),
        height=d.uniform("h", 0.36, 0.46),
        legs_height=d.uniform("lh", 0.06, 0.14) if legs else 0.0,
        tufted=d.flag("tufted", 0.4),
        fabric=d.choice("fabric", FABRIC_NAMES),
        wood=d.choice("wood", WOOD_NAMES),
    )
    return "ottoman", f"{'pouf' if shape == 'round' else shape + ' ottoman'}{', legs' if legs else ''}", params


def _kitchen(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("base", "wall", "base", "tall"))
    modules = 1 if kind == "tall" else d.choice("m", (1, 2, 3, 4))
    width = modules * d.uniform("w", 0.4, 0.6) if kind != "tall" else d.uniform("w", 0.5, 0.7)
    wood = d.choice("wood", ("white", "oak", "grey", "walnut", "black", "birch"))
    params = dict(
        kind=kind,
        width=width,
        modules=modules,
        drawers=d.flag("drawers", 0.7),
        counter=d.choice("counter", ("granite", "marble", "oak", "white", "black", "concrete")),
        wood=wood,
        fronts=wood if d.flag("same", 0.7) else d.choice("fronts", WOOD_NAMES),
        metal=d.choice("metal", tuple(METALS)),
    )
    return "kitchen_unit", f"kitchen {kind} unit, {modules} module{'s' * (modules > 1)}", params


def _containers(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("box", "bin", "basket", "crate", "box", "bin"))
    body = {
        "box": "cardboard",
        "bin": d.choice("b", ("white", "clear", "blue", "grey", "black")),
        "basket": "wicker",
        "crate": "pine",
    }[kind]
    params = dict(
        kind=kind,
        width=d.uniform("w", 0.3, 0.7),
        depth=d.uniform("d", 0.25, 0.5),
        height=d.uniform("h", 0.2, 0.5),
        lid=d.flag("lid", 0.6),
        body=body,
        trim=d.choice("trim", ("cream", "beige", "charcoal")),
    )
    name = f"{'cardboard ' if kind == 'box' else ''}{kind}{', lid' if params['lid'] and kind == 'bin' else ''}"
    return "container", name, params


def _frames(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("picture", "picture", "mirror", "whiteboard", "picture", "poster"))
    landscape = d.flag("landscape", 0.5)
    w, h = d.uniform("w", 0.4, 1.0), d.uniform("h", 0.5, 1.2)
    if kind == "whiteboard":
        w, h = d.uniform("w", 1.2, 2.4), d.uniform("h", 0.9, 1.2)
    elif landscape:
        w, h = max(w, h), min(w, h)
    params = dict(
        kind=kind,
        width=w,
        height=h,
        border=d.uniform("b", 0.02, 0.07) if kind != "whiteboard" else 0.02,
        depth=d.uniform("dp", 0.02, 0.05),
        mat=d.choice("mat", (0.0, 0.0, 0.05, 0.08)) if kind == "picture" else 0.0,
        moulding=d.choice("moulding", ("black", "white", "oak", "walnut", "brass", "steel")),
        picture=(d.uniform("r", 0.2, 0.8), d.uniform("g", 0.2, 0.8), d.uniform("bl", 0.2, 0.8)),
    )
    return "frame", f"{kind} frame {'landscape' if w > h else 'portrait'}", params


def _monitors(d: Dice) -> tuple[str, str, dict[str, Any]]:
    params = dict(
        diagonal_inches=d.cycle((22.0, 24.0, 27.0, 32.0)),
        stand=("arm", "disc")[d.index % 2],
        frame=d.choice("frame", ("black metal", "steel", "black metal")),
    )
    return "monitor", f"{params['diagonal_inches']:.0f}-inch monitor, {params['stand']} stand", params


def _refrigerators(d: Dice) -> tuple[str, str, dict[str, Any]]:
    style = d.cycle(("top_freezer", "side_by_side", "bottom_freezer", "single"))
    width = d.uniform("w", 0.85, 0.95) if style == "side_by_side" else d.uniform("w", 0.55, 0.75)
    height = d.uniform("h", 0.8, 0.9) if style == "single" and d.flag("mini", 0.5) else d.uniform("h", 1.6, 1.9)
    params = dict(
        width=width,
        height=height,
        depth=d.uniform("d", 0.6, 0.72),
        style=style,
        finish=d.choice("finish", tuple(FINISHES)),
    )
    return "refrigerator", f"{style.replace('_', ' ')} refrigerator{' (compact)' if height < 1.0 else ''}", params


def _appliances(d: Dice) -> tuple[str, str, dict[str, Any]]:
    kind = d.cycle(("microwave", "range", "washer", "wall oven", "microwave", "washer"))
    finish = d.choice("finish", tuple(FINISHES))
    if kind == "microwave":
        params = dict(
            width=d.uniform("w", 0.45, 0.55),
            height=d.uniform("h", 0.27, 0.33),
            depth=d.uniform("d", 0.34, 0.42),
            finish=finish,
        )
        return "microwave", "microwave oven", params
    if kind == "washer":
        return "washer", "front-loading washing machine", dict(height=d.uniform("h", 0.82, 0.9), finish=finish)
    params = dict(
        kind="range" if kind == "range" else "wall",
        width=d.choice("w", (0.6, 0.76)),
        height=d.uniform("h", 0.88, 0.92) if kind == "range" else d.uniform("h", 0.58, 0.62),
        burners=4,
        finish=finish,
    )
    return "oven", kind, params


@dataclass(frozen=True)
class Series:
    """A run of parametric variants: their database category, how many, and the function choosing each one's
    generator, description and parameters."""

    category: str
    count: int
    choose: Callable[[Dice], tuple[str, str, dict[str, Any]]]


SERIES: dict[str, Series] = {
    "chair": Series("chair", 14, _chairs),
    "table": Series("table", 12, _tables),
    "sofa": Series("sofa", 12, _sofas),
    "bed": Series("bed", 10, _beds),
    "cabinet": Series("cabinet", 12, _cabinets),
    "shelf": Series("shelf", 10, _shelves),
    "desk": Series("desk", 10, _desks),
    "lamp": Series("lamp", 12, _lamps),
    "rug": Series("rug", 10, _rugs),
    "pillow": Series("pillow", 12, _pillows),
    "plant": Series("plant", 4, _plants),
    "tv": Series("tv", 4, _tvs),
    "ottoman": Series("ottoman", 6, _ottomans),
    "kitchen": Series("cabinet", 8, _kitchen),
    "container": Series("box", 8, _containers),
    "frame": Series("frame", 8, _frames),
    "monitor": Series("tv", 4, _monitors),
    "refrigerator": Series("refrigerator", 4, _refrigerators),
    "appliance": Series("appliance", 6, _appliances),
}
"""The series of the built-in library, by id prefix (the first twelve are the original library's)."""


def catalogue() -> list[Variant]:
    """Every parametric variant of the built-in library, in a fixed order with stable ids."""
    variants = []
    for name, series in SERIES.items():
        for index in range(series.count):
            generator, description, params = series.choose(Dice(name, index))
            variants.append(
                Variant(
                    id=f"parametric/{name}_{index:03d}",
                    category=series.category,
                    name=description,
                    generator=generator,
                    params=params,
                )
            )
    return variants
