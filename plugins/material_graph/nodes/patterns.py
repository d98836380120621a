"""Pattern generators: tiles and bricks, hexagonal tiles, planks, herringbone, basket-weave parquet, stripes,
wood rings and grain, woven cloth, knit stitches, gradients, shapes and uniform colour.

Counts (tiles per row, threads, ...) are discrete parameters chosen so that the pattern repeats an integer
number of times per tile; per-tile variation comes from hashing the integer tile id (reduced modulo the
pattern's period) with the seed, so neighbouring copies of the map agree at the border. Tile-like patterns
return ``height`` (bevelled, with per-tile height variation), ``mask`` (bevelled, no variation), ``random``
(one uniform value per tile) and, for wood, ``along`` / ``across`` (coordinates in the plank, 0..1) and
``orient`` (0: plank along x, 1: along y).
"""

from __future__ import annotations

import math
from typing import Any

import torch

from ..params import Bound, Choice, Color, Float, Int, Seed
from . import Context, Input, node
from .noise import FBM_STD, fbm_sum, voronoi
from .ops import bevel_profile, hash_table, sample_periodic, smoothstep

GAP = Float(0.0, 0.4, 0.05, doc="joint (mortar/gap) width, in tile heights")
BEVEL = Float(0.0, 0.5, 0.08, doc="bevel width, in tile heights")
VARIATION = Float(0.0, 1.0, 0.2, doc="random per-tile height variation")
TILE_OUTPUTS = ("height", "mask", "random")
WOOD_OUTPUTS = ("height", "mask", "random", "along", "across", "orient")


def _unfixed_or_nonzero(value: Any) -> bool:
    return not isinstance(value, Bound) or not value.fixed or bool((value.value.abs() > 1e-9).any())


def _even_rows_if_offset(p: dict[str, Any]) -> str | None:
    if p["rows"] % 2 and _unfixed_or_nonzero(p["offset"]):
        return "rows must be even when offset is non-zero or optimised (alternate rows are shifted)"
    return None


def _tile_maps(
    ctx: Context, distance: torch.Tensor, rand: torch.Tensor, unit: float, p: dict
) -> dict[str, torch.Tensor]:
    """height/mask/random from the distance to the tile edge (texture units) and a per-tile random value."""
    mask = bevel_profile(distance, p["gap"] * unit / 2.0, p["bevel"] * unit, ctx.pixel)
    height = mask * (1.0 - p["height_variation"] * rand)
    return {"height": height[None], "mask": mask[None], "random": rand.expand_as(mask)[None]}


def _rect_grid(ctx: Context, cols: int, rows: int, shift: torch.Tensor) -> tuple[torch.Tensor, ...]:
    """Row-major rectangular cells with each row shifted by ``shift`` [H, 1] cells: (col, row, tx, ty)."""
    y = ctx.ys * rows
    row = torch.floor(y)
    ty = (y - row).expand(ctx.height, ctx.width)
    x = ctx.xs * cols - shift
    col = torch.floor(x)
    tx = x - col
    return (
        (col.to(torch.int64) % cols).expand(ctx.height, ctx.width),
        row.to(torch.int64).expand(ctx.height, ctx.width),
        tx,
        ty,
    )


@node(
    "tiles",
    "generator",
    params={
        "cols": Int(1, 256, 4, doc="tiles per row"),
        "rows": Int(1, 256, 8, doc="rows of tiles"),
        "seed": Seed(),
        "offset": Float(0.0, 1.0, 0.5, doc="shift of every other row, in tile widths (0.5: running bond)"),
        "random_offset": Float(0.0, 1.0, 0.0, doc="random shift per row, in tile widths"),
        "gap": GAP,
        "bevel": BEVEL,
        "height_variation": VARIATION,
    },
    outputs=TILE_OUTPUTS,
    check=_even_rows_if_offset,
)
def tiles(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Rectangular tiles or bricks with mortar joints, bevels, running-bond offset and per-tile variation."""
    cols, rows, seed = p["cols"], p["rows"], p["seed"]
    row_index = torch.floor(ctx.ys * rows).to(torch.int64)
    shift = (
        p["offset"] * (row_index % 2).to(ctx.dtype) + p["random_offset"] * hash_table(rows, seed, 3)[row_index % rows]
    )
    col, row, tx, ty = _rect_grid(ctx, cols, rows, shift)
    distance = torch.minimum(torch.minimum(tx, 1 - tx) / cols, torch.minimum(ty, 1 - ty) / rows)
    rand = hash_table(rows * cols, seed)[(row % rows) * cols + col]
    return _tile_maps(ctx, distance, rand, 1.0 / rows, p)


@node(
    "hex_tiles",
    "generator",
    params={
        "cols": Int(1, 128, 7, doc="hexagons per row"),
        "rows": Int(2, 128, 8, step=2, doc="rows (even)"),
        "seed": Seed(),
        "gap": GAP,
        "bevel": BEVEL,
        "height_variation": VARIATION,
    },
    outputs=TILE_OUTPUTS,
)
def hex_tiles(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Hexagonal tiles (odd rows shifted by half a tile; rows ≈ 1.15 × cols gives regular hexagons)."""
    cols, rows = p["cols"], p["rows"]
    j0 = torch.floor(ctx.ys * rows).to(torch.int64)  # [H, 1]
    candidates = []
    for dj in (-1, 0, 1):
        j = j0 + dj
        half = 0.5 * (j % 2).to(ctx.dtype)
        i_near = torch.round(ctx.xs * cols - 0.5 - half).to(torch.int64)  # [H, W]
        cy = (j.to(ctx.dtype) + 0.5) / rows
        for di in (-1, 0, 1):
            i = i_near + di
            candidates.append(((i.to(ctx.dtype) + 0.5 + half) / cols, cy, (j % rows) * cols + i % cols))
    _, _, border, nearest = voronoi(candidates, ctx.xs, ctx.ys, 1.0)
    return _tile_maps(ctx, border, hash_table(rows * cols, p["seed"])[nearest], 1.0 / rows, p)


@node(
    "planks",
    "generator",
    params={
        "rows": Int(1, 128, 6, doc="rows of planks per tile"),
        "count": Int(1, 32, 2, doc="planks per row"),
        "seed": Seed(),
        "stagger": Float(0.0, 1.0, 1.0, doc="random end-joint offset per row, in plank lengths"),
        "gap": GAP,
        "bevel": BEVEL,
        "height_variation": VARIATION,
    },
    outputs=WOOD_OUTPUTS,
)
def planks(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Floor boards along x: rows of planks with randomly staggered end joints."""
    rows, count, seed = p["rows"], p["count"], p["seed"]
    row_index = torch.floor(ctx.ys * rows).to(torch.int64)
    shift = p["stagger"] * hash_table(rows, seed, 5)[row_index % rows]
    col, row, tx, ty = _rect_grid(ctx, count, rows, shift)
    distance = torch.minimum(torch.minimum(tx, 1 - tx) / count, torch.minimum(ty, 1 - ty) / rows)
    rand = hash_table(rows * count, seed)[(row % rows) * count + col]
    out = _tile_maps(ctx, distance, rand, 1.0 / rows, p)
    out.update(along=tx[None], across=ty[None], orient=torch.zeros_like(tx)[None])
    return out


@node(
    "herringbone",
    "generator",
    params={
        "ratio": Int(2, 16, 4, doc="plank length / width"),
        "repeats": Int(1, 32, 2, doc="zig-zag columns per tile"),
        "seed": Seed(),
        "gap": GAP,
        "bevel": BEVEL,
        "height_variation": VARIATION,
    },
    outputs=WOOD_OUTPUTS,
)
def herringbone(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Herringbone parquet: 1 × ratio planks at ±45°, in zig-zag columns along y.

    In plank-width units (frame P) the pattern is the lattice a = (1, 1), b = (k, −k) (k = ratio) of one
    plank [0, k)×[0, 1) and one [k, k+1)×[1−k, 1). Turned by 45°, a and b become (0, √2) and (k√2, 0): with
    plank width w = 1/(√2·n·k) the tile holds n·k copies of a along y and n of b along x, so it repeats
    exactly and a plank's lattice index (i, j) is periodic modulo (n·k, n).
    """
    k, n, seed = p["ratio"], p["repeats"], p["seed"]
    w = 1.0 / (math.sqrt(2.0) * n * k)
    c = math.sqrt(0.5) / w
    px = ((ctx.xs + ctx.ys) * c).expand(ctx.height, ctx.width)  # P = R(−45°)·t / w
    py = ((ctx.ys - ctx.xs) * c).expand(ctx.height, ctx.width)
    # plank along P's x: its lattice translate has i − j·k = floor(py), then j from px
    m_a = torch.floor(py)
    j_a = torch.floor((px - m_a) / (2 * k))
    qx_a = px - m_a - 2 * k * j_a
    in_a = qx_a < k
    # plank along P's y: i + j·k = floor(px) − k, then j from py
    m_b = torch.floor(px) - k
    j_b = torch.ceil((1 - py + m_b) / (2 * k)) - 1
    qy_b = py - m_b + 2 * k * j_b
    along = torch.where(in_a, qx_a / k, (qy_b - (1 - k)) / k)
    across = torch.where(in_a, py - m_a, px - m_b - k)
    orient = (~in_a).to(ctx.dtype)
    plank_j = torch.where(in_a, j_a, j_b).to(torch.int64)
    plank_i = torch.where(in_a, m_a + k * j_a, m_b - k * j_b).to(torch.int64)
    plank = ((plank_i % (n * k)) * n + plank_j % n) * 2 + orient.to(torch.int64)
    rand = hash_table(2 * n * n * k, seed)[plank]
    distance = torch.minimum(torch.minimum(along, 1 - along) * k, torch.minimum(across, 1 - across)) * w
    out = _tile_maps(ctx, distance, rand, w, p)
    out.update(along=along[None], across=across[None], orient=orient[None])
    return out


@node(
    "parquet",
    "generator",
    params={
        "cells": Int(2, 64, 4, step=2, doc="squares per tile side (even)"),
        "planks": Int(1, 16, 3, doc="planks per square"),
        "seed": Seed(),
        "gap": GAP,
        "bevel": BEVEL,
        "height_variation": VARIATION,
    },
    outputs=WOOD_OUTPUTS,
)
def parquet(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Basket-weave parquet: squares of parallel planks, alternating direction like a chessboard."""
    cells, count, seed = p["cells"], p["planks"], p["seed"]
    x = (ctx.xs * cells).expand(ctx.height, ctx.width)
    y = (ctx.ys * cells).expand(ctx.height, ctx.width)
    cx, cy = torch.floor(x), torch.floor(y)
    tx, ty = x - cx, y - cy
    vertical = ((cx + cy) % 2) == 1
    slot = torch.where(vertical, tx, ty) * count
    index = torch.floor(slot)
    across = slot - index
    along = torch.where(vertical, ty, tx)
    cell_id = (cy.to(torch.int64) % cells) * cells + cx.to(torch.int64) % cells
    rand = hash_table(cells * cells * count, seed)[cell_id * count + index.to(torch.int64).clamp(0, count - 1)]
    unit = 1.0 / (cells * count)
    distance = torch.minimum(torch.minimum(across, 1 - across) * unit, torch.minimum(along, 1 - along) / cells)
    out = _tile_maps(ctx, distance, rand, unit, p)
    out.update(along=along[None], across=across[None], orient=vertical.to(ctx.dtype)[None])
    return out


def _direction_coord(ctx: Context, direction: str) -> torch.Tensor:
    xs, ys = ctx.xs, ctx.ys
    coord = {"horizontal": ys, "vertical": xs, "diagonal": xs + ys, "antidiagonal": xs - ys}[direction]
    return coord.expand(ctx.height, ctx.width)


DIRECTIONS = ("horizontal", "vertical", "diagonal", "antidiagonal")


@node(
    "stripes",
    "generator",
    params={
        "count": Int(1, 512, 8, doc="stripes per tile"),
        "direction": Choice(DIRECTIONS, "vertical", doc="horizontal stripes vary along y"),
        "width": Float(0.0, 1.0, 0.5, doc="stripe width, as a fraction of the period"),
        "softness": Float(0.001, 0.5, 0.05, doc="edge softness, as a fraction of the period"),
        "phase": Float(-1.0, 1.0, 0.0, doc="shift, in periods"),
    },
)
def stripes(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Parallel stripes (1 inside a stripe, 0 between)."""
    t = _direction_coord(ctx, p["direction"]) * p["count"] + p["phase"]
    d = (t - torch.floor(t) - 0.5).abs()
    footprint = p["count"] * ctx.pixel * (2.0 if p["direction"] in ("diagonal", "antidiagonal") else 1.0)
    half, soft = p["width"] / 2.0, (p["softness"] + footprint) / 2.0
    return (1.0 - smoothstep(half - soft, half + soft, d))[None]


@node(
    "wood_rings",
    "generator",
    params={
        "count": Int(1, 256, 12, doc="growth rings across the tile (along y)"),
        "noise_x": Int(1, 64, 2, doc="distortion noise cells along x"),
        "noise_y": Int(1, 64, 1, doc="... along y"),
        "seed": Seed(),
        "distortion": Float(0.0, 6.0, 1.0, doc="how far rings wander (standard deviation), in ring spacings"),
        "irregularity": Float(0.0, 1.0, 0.5, doc="random variation of the ring widths"),
        "sharpness": Float(0.5, 8.0, 2.5, doc="exponent of the ramp from early to late wood (higher: thinner lines)"),
        "phase": Float(-1.0, 1.0, 0.0, doc="shift, in rings"),
    },
)
def wood_rings(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Flat-sawn growth rings: lines along x displaced by low-frequency noise, with uneven widths; 0 in the
    early wood rising to 1 at each ring's late wood."""
    count = p["count"]
    n = fbm_sum(ctx, "perlin", p["noise_x"], p["noise_y"], 3, 0.5, p["seed"])
    t = ctx.ys * count + p["distortion"] * (n - 0.5) / FBM_STD + p["phase"]
    t = t + p["irregularity"] * 1.2 * (_noise1d(t, p["seed"] + 1, period=count) - 0.5)
    f = t - torch.floor(t)
    return (f.clamp(min=1e-6).pow(p["sharpness"]) * (1.0 - smoothstep(0.88, 1.0, f)))[None]


def _noise1d(t: torch.Tensor, seed: int, period: int = 4096) -> torch.Tensor:
    """Smooth 1D value noise at real coordinates, periodic with an integer ``period`` (pointwise, so
    tileable inputs stay tileable)."""
    table = hash_table(period, seed, 11)
    i = torch.floor(t)
    f = t - i
    i = i.to(torch.int64) % period
    s = f * f * (3 - 2 * f)
    return torch.lerp(table[i], table[(i + 1) % period], s)


@node(
    "wood_grain",
    "filter",
    params={
        "lines": Float(1.0, 64.0, 8.0, doc="growth rings across a plank"),
        "waviness": Float(0.0, 2.0, 0.4, doc="how far lines meander along the plank, in ring spacings"),
        "cathedral": Float(0.0, 3.0, 0.6, doc="curvature of the arches of flat-sawn boards"),
        "contrast": Float(0.0, 1.0, 0.7, doc="darkness of the late-wood lines"),
        "seed": Seed(),
    },
    inputs={"along": Input(1), "across": Input(1), "random": Input(1, required=False)},
)
def wood_grain(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Growth-ring grain inside planks, from their along/across coordinates and a per-plank random value
    (1: light early wood, darker towards each ring's late wood). Pointwise, so it tiles as its inputs do."""
    along, across = inputs["along"][0], inputs["across"][0]
    rand = inputs["random"][0] if inputs["random"] is not None else torch.zeros_like(along)
    seed, lines = p["seed"], p["lines"]
    meander = _noise1d(along * 1.3 + rand * 97.0, seed) - 0.5
    apex = 0.5 + 0.6 * (rand - 0.5)  # where along the board the arches turn
    t = across * lines + rand * 17.0 + p["waviness"] * 2.0 * meander
    t = t + p["cathedral"] * lines * 0.5 * (along - apex) ** 2
    t = t + 0.6 * (_noise1d(t * 0.8 + rand * 13.0, seed + 1) - 0.5)  # uneven ring widths
    f = t - torch.floor(t)
    late = f.pow(2.5) * (1.0 - smoothstep(0.9, 1.0, f))  # darkens through the ring, resets sharply
    pores = _noise1d(along * 80.0 + torch.floor(t) * 7.0, seed + 2)
    grain = 1.0 - p["contrast"] * (0.85 * late + 0.15 * pores)
    return grain.clamp(0, 1)[None]


WEAVES = {"plain": 2, "twill": 4, "basket": 4, "satin": 5}


def _weave_top(i: torch.Tensor, j: torch.Tensor, pattern: str) -> torch.Tensor:
    """1 where the warp (the thread along y, column i) passes over the weft in cell (i, j)."""
    if pattern == "plain":
        top = (i + j) % 2 == 0
    elif pattern == "twill":
        top = (i + j) % 4 < 2
    elif pattern == "basket":
        top = (i // 2 + j // 2) % 2 == 0
    else:  # satin: the weft floats over four warps
        top = (2 * i + j) % 5 == 0
    return top.to(torch.float32)


def _weave_check(p: dict[str, Any]) -> str | None:
    period = WEAVES[p["pattern"]]
    if p["threads"] % period:
        return f"threads must be a multiple of {period} for the {p['pattern']} weave (so that it tiles)"
    return None


@node(
    "weave",
    "generator",
    params={
        "threads": Int(2, 512, 32, doc="threads per tile in each direction"),
        "pattern": Choice(tuple(WEAVES), "plain"),
        "thread_width": Float(0.2, 1.0, 0.8, doc="thread width, as a fraction of the thread spacing"),
        "lift": Float(0.0, 1.0, 0.6, doc="how much a crossing thread rises above one passing under"),
    },
    outputs=("height", "warp", "mask"),
    check=_weave_check,
)
def weave(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Woven cloth: warp threads along y, weft along x, crossing over and under (plain, twill, basket, satin)."""
    n, pattern = p["threads"], p["pattern"]
    x = (ctx.xs * n).expand(ctx.height, ctx.width)
    y = (ctx.ys * n).expand(ctx.height, ctx.width)
    i, j = torch.floor(x), torch.floor(y)
    tx, ty = x - i, y - j
    i, j = i.to(torch.int64), j.to(torch.int64)
    half = p["thread_width"] / 2.0
    warp_profile = torch.sqrt((1.0 - ((tx - 0.5) / half) ** 2).clamp(min=0.0) + 1e-6)
    weft_profile = torch.sqrt((1.0 - ((ty - 0.5) / half) ** 2).clamp(min=0.0) + 1e-6)
    # level of each thread along its length: interpolate over/under between neighbouring crossings
    up = ty >= 0.5
    j_other = torch.where(up, j + 1, j - 1)
    w = smoothstep(0.0, 1.0, (ty - 0.5).abs())
    warp_level = torch.lerp(_weave_top(i % n, j % n, pattern), _weave_top(i % n, j_other % n, pattern), 0.5 * w)
    right = tx >= 0.5
    i_other = torch.where(right, i + 1, i - 1)
    w = smoothstep(0.0, 1.0, (tx - 0.5).abs())
    weft_level = 1.0 - torch.lerp(_weave_top(i % n, j % n, pattern), _weave_top(i_other % n, j % n, pattern), 0.5 * w)
    lift = p["lift"]
    warp_h = warp_profile * (1.0 - lift + lift * warp_level)
    weft_h = weft_profile * (1.0 - lift + lift * weft_level)
    warp_on_top = torch.sigmoid((warp_h - weft_h) * 40.0)
    height = torch.lerp(weft_h, warp_h, warp_on_top)
    mask = torch.maximum(warp_profile, weft_profile).clamp(0, 1)
    return {"height": height.clamp(0, 1)[None], "warp": warp_on_top[None], "mask": mask[None]}


@node(
    "knit",
    "generator",
    params={
        "cols": Int(1, 256, 12, doc="stitches per row"),
        "rows": Int(1, 256, 16, doc="rows of stitches"),
        "seed": Seed(),
        "loop_width": Float(0.1, 0.8, 0.38, doc="width of a stitch leg, in stitch widths"),
        "slant": Float(0.0, 1.0, 0.5, doc="lean of the legs (0: upright, 1: 60°)"),
        "length": Float(0.3, 2.0, 1.2, doc="leg length, in stitch heights"),
    },
    outputs=("height", "mask", "random"),
)
def knit(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Stockinette knit: columns of V-shaped stitches, each two slanted rounded legs."""
    cols, rows = p["cols"], p["rows"]
    # Every stitch has the same shape: evaluate one cell (with its neighbours' legs) into a lookup table
    # at about twice the pixel density, then sample it at each pixel's position in its cell.
    res = int(min(256, max(32, 2 * math.ceil(max(ctx.width / cols, ctx.height / rows)))))
    t = (torch.arange(res, dtype=ctx.dtype) + 0.5) / res
    lut, owner = _knit_cell(t[None, :].expand(res, res), t[:, None].expand(res, res), rows / cols, p)
    x = (ctx.xs * cols).expand(ctx.height, ctx.width)
    y = (ctx.ys * rows).expand(ctx.height, ctx.width)
    ci, cj = torch.floor(x), torch.floor(y)
    tx, ty = x - ci, y - cj
    height = sample_periodic(lut[None], tx, ty)[0].clamp(0, 1)
    code = owner[(ty * res).to(torch.int64).clamp(0, res - 1), (tx * res).to(torch.int64).clamp(0, res - 1)]
    di, dj = code % 3 - 1, code // 3 - 1
    stitch = ((cj.to(torch.int64) + dj) % rows) * cols + (ci.to(torch.int64) + di) % cols
    return {
        "height": height[None],
        "mask": smoothstep(0.0, 0.15, height)[None],
        "random": hash_table(rows * cols, p["seed"])[stitch][None],
    }


def _knit_cell(tx: torch.Tensor, ty: torch.Tensor, aspect: float, p: dict) -> tuple[torch.Tensor, torch.Tensor]:
    """Height of the stitch legs covering positions (tx, ty) of a cell, and which neighbour (code
    (dj+1)·3 + di+1) owns each position. ``aspect``: a stitch's width in stitch heights (the unit here)."""
    angle = p["slant"] * (math.pi / 3.0)
    ca, sa = torch.cos(angle), torch.sin(angle)
    a = p["length"] / 2.0
    b = p["loop_width"] / 2.0 * aspect
    best = torch.zeros_like(tx)
    owner = torch.full_like(tx, 4, dtype=torch.int64)
    for dj in (-1, 0, 1):
        v = ty - (dj + 0.5)
        for s, dis in ((1.0, (0, 1)), (-1.0, (-1, 0))):  # left legs (down to the right), right legs
            for di in dis:
                uc = (tx - (di + 0.5)) * aspect + s * 0.22 * aspect
                lv = s * uc * sa + v * ca
                lu = uc * ca - s * v * sa
                e = (lv / a) ** 2 + (lu / b) ** 2
                h = torch.sqrt((1.0 - e).clamp(min=0.0) + 1e-6) * (1.0 - 0.2 * (lv / a).clamp(-1, 1))
                better = h > best
                best = torch.where(better, h, best)
                owner = torch.where(better, torch.full_like(owner, (dj + 1) * 3 + di + 1), owner)
    return best, owner


@node(
    "gradient",
    "generator",
    params={
        "direction": Choice(
            ("horizontal", "vertical", "diagonal", "radial"),
            "vertical",
            doc="horizontal: varies along y; radial: from each repeat's centre",
        ),
        "count": Int(1, 256, 1, doc="repeats per tile (mirrored, so it tiles)"),
        "position": Float(-1.0, 1.0, 0.0, doc="shift, in repeats"),
        "gamma": Float(0.2, 5.0, 1.0, doc="exponent of the ramp"),
    },
)
def gradient(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Mirrored (triangle-wave) linear or radial gradient, 0..1, repeated ``count`` times."""
    if p["direction"] == "radial":
        u = ctx.xs * p["count"] + p["position"]
        v = ctx.ys * p["count"] + p["position"]
        du, dv = u - torch.floor(u) - 0.5, v - torch.floor(v) - 0.5
        t = (2.0 * torch.sqrt(du * du + dv * dv + 1e-9)).clamp(0, 1)
    else:
        c = _direction_coord(
            ctx, {"horizontal": "horizontal", "vertical": "vertical", "diagonal": "diagonal"}[p["direction"]]
        )
        s = c * p["count"] + p["position"]
        t = 1.0 - (2.0 * (s - torch.floor(s)) - 1.0).abs()
    return t.clamp(1e-6, 1.0).pow(p["gamma"])[None]


SHAPES = ("disc", "square", "diamond", "hexagon", "ring", "cross")


def _shape_check(p: dict[str, Any]) -> str | None:
    if p["stagger"] == "yes" and p["rows"] % 2:
        return "rows must be even when stagger is yes"
    return None


@node(
    "shape",
    "generator",
    params={
        "shape": Choice(SHAPES, "disc"),
        "cols": Int(1, 256, 4),
        "rows": Int(1, 256, 4),
        "seed": Seed(),
        "stagger": Choice(("no", "yes"), "no", doc="shift every other row by half a cell"),
        "size": Float(0.0, 1.5, 0.6, doc="shape size, in cell sizes"),
        "softness": Float(0.001, 0.5, 0.03, doc="edge softness, in cell sizes"),
        "rotation": Float(-0.5, 0.5, 0.0, doc="rotation of each shape, in turns"),
        "thickness": Float(0.02, 0.5, 0.15, doc="line thickness of ring and cross"),
    },
    outputs=("out", "random"),
    check=_shape_check,
    inert=lambda p, ports: (
        ({"rotation"} if p["shape"] in ("disc", "ring") else set())
        | (set() if p["shape"] in ("ring", "cross") else {"thickness"})
    ),
)
def shape(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """A grid of shapes (disc, square, diamond, hexagon, ring, cross), optionally staggered."""
    cols, rows = p["cols"], p["rows"]
    y = (ctx.ys * rows).expand(ctx.height, ctx.width)
    cj = torch.floor(y)
    shift = 0.5 * (cj % 2) if p["stagger"] == "yes" else torch.zeros_like(cj)
    x = ctx.xs * cols - shift
    ci = torch.floor(x)
    u, v = x - ci - 0.5, y - cj - 0.5
    angle = 2 * math.pi * p["rotation"]
    ca, sa = torch.cos(angle), torch.sin(angle)
    u, v = u * ca - v * sa, u * sa + v * ca
    au, av = u.abs(), v.abs()
    kind, size, t = p["shape"], p["size"], p["thickness"]
    if kind == "disc":
        d = 2 * torch.sqrt(u * u + v * v + 1e-9)
    elif kind == "square":
        d = 2 * torch.maximum(au, av)
    elif kind == "diamond":
        d = au + av
    elif kind == "hexagon":
        d = 2 * torch.maximum(au * 0.866 + av * 0.5, av)
    elif kind == "ring":
        d = size + (2 * torch.sqrt(u * u + v * v + 1e-9) - size).abs() - t  # inside: |diameter − size| < t
    else:  # cross: two bars
        bar = torch.minimum(torch.maximum(2 * au / t, 2 * av / size), torch.maximum(2 * av / t, 2 * au / size))
        d = bar * size
    soft = p["softness"] + max(cols, rows) * ctx.pixel
    out = 1.0 - smoothstep(size - soft, size + soft, d)
    rand = hash_table(rows * cols, p["seed"])[(cj.to(torch.int64) % rows) * cols + ci.to(torch.int64) % cols]
    return {"out": out[None], "random": rand[None]}


@node(
    "checker",
    "generator",
    params={
        "count": Int(2, 256, 8, step=2, doc="squares per tile side (even)"),
        "softness": Float(0.0, 0.5, 0.01, doc="edge softness, in square sizes"),
    },
)
def checker(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """A chessboard of 0 and 1 squares."""
    n = p["count"]
    x, y = ctx.xs * n, ctx.ys * n
    soft = p["softness"] + n * ctx.pixel

    def square_wave(t: torch.Tensor) -> torch.Tensor:  # +1 / −1 with soft transitions at integers
        f = t - torch.floor(t)
        d = torch.minimum(f, 1 - f)  # distance to the nearest edge, in squares
        sign = torch.where((torch.floor(t) % 2) == 0, 1.0, -1.0)
        return sign * smoothstep(0.0, soft, d)

    return (0.5 + 0.5 * square_wave(x) * square_wave(y))[None]


@node("uniform", "generator", params={"color": Color(0.0, 1.0, "#808080")})
def uniform(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """A constant colour."""
    return p["color"].to(ctx.dtype).reshape(3, 1, 1).expand(3, ctx.height, ctx.width)
