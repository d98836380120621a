"""Noise generators: value, Perlin, fBm (fractal sums of either) and cellular/Voronoi noise.

Frequencies are integers (lattice cells per tile) so that every noise is periodic on the unit torus; they
are discrete parameters, fixed during optimisation. The continuous parameters (``disorder``, ``persistence``,
``jitter``, ...) change the pattern smoothly.
"""

from __future__ import annotations

from typing import cast

import torch

from ..params import Choice, Float, Int, Seed
from . import Context, node
from .ops import gather2, hash_table, lattice, perlin_noise, smoothstep, value_noise

FBM_STD = 0.17
"""Standard deviation of fBm maps (about [0, 1] within 3 sigma)."""

SCALE = Int(1, 512, 4, doc="lattice cells per tile")


def _noise(kind: str):  # noqa: ANN202
    return perlin_noise if kind == "perlin" else value_noise


@node(
    "value_noise",
    "generator",
    params={
        "scale_x": SCALE,
        "scale_y": SCALE,
        "seed": Seed(),
        "disorder": Float(-1.0, 1.0, 0.0, doc="moves the lattice values continuously"),
    },
)
def value_noise_node(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Smooth periodic value noise (random values on a lattice, quintic interpolation)."""
    return value_noise(ctx.xs, ctx.ys, p["scale_x"], p["scale_y"], p["seed"], p["disorder"])[None]


@node(
    "perlin_noise",
    "generator",
    params={
        "scale_x": SCALE,
        "scale_y": SCALE,
        "seed": Seed(),
        "disorder": Float(-1.0, 1.0, 0.0, doc="rotates the lattice gradients continuously"),
    },
)
def perlin_noise_node(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Periodic Perlin gradient noise, about [0, 1] around 0.5."""
    return perlin_noise(ctx.xs, ctx.ys, p["scale_x"], p["scale_y"], p["seed"], p["disorder"]).clamp(0, 1)[None]


def fbm_sum(
    ctx: Context,
    kind: str,
    sx: int,
    sy: int,
    octaves: int,
    persistence: torch.Tensor | float,
    seed: int,
    disorder: torch.Tensor | float = 0.0,
    lacunarity: int = 2,
) -> torch.Tensor:
    """0.5 + Σ persistenceᵒ·(noise(scale·lacunarityᵒ) − 0.5), scaled to a std of :data:`FBM_STD`, [H, W].
    Octaves finer than the pixel grid (Nyquist) are left out (they would alias), so a map looks the same at
    any resolution apart from its finest detail."""
    fn = _noise(kind)
    unit_std = 0.165 if kind == "perlin" else 0.27  # std of one octave
    total = torch.zeros((), dtype=ctx.dtype, device=ctx.device)
    persistence = torch.as_tensor(persistence, dtype=ctx.dtype)
    amplitude = torch.ones((), dtype=ctx.dtype)
    for octave in range(octaves):
        fx, fy = sx * lacunarity**octave, sy * lacunarity**octave
        if fx * 2 <= ctx.width and fy * 2 <= ctx.height:
            total = total + amplitude * (fn(ctx.xs, ctx.ys, fx, fy, seed, disorder, salt=octave * 101) - 0.5)
        amplitude = amplitude * persistence
    # normalised to a standard deviation of FBM_STD whatever the persistence and octave count
    out = 0.5 + total * (FBM_STD / unit_std) / torch.sqrt(_sum_sq(persistence, octaves))
    return out.clamp(0.0, 1.0).expand(ctx.height, ctx.width)


def _sum_sq(persistence: torch.Tensor, octaves: int) -> torch.Tensor:
    return cast(torch.Tensor, sum(persistence ** (2 * o) for o in range(octaves)))  # octaves >= 1: a tensor


@node(
    "fbm",
    "generator",
    params={
        "scale_x": SCALE,
        "scale_y": SCALE,
        "seed": Seed(),
        "octaves": Int(1, 10, 5, doc="number of octaves (each twice the frequency)"),
        "noise": Choice(("value", "perlin"), "perlin", doc="noise of each octave"),
        "persistence": Float(0.05, 0.95, 0.5, doc="amplitude ratio between octaves (roughness)"),
        "disorder": Float(-1.0, 1.0, 0.0, doc="moves every octave's lattice continuously"),
    },
    inert=lambda p, ports: {"persistence"} if p["octaves"] == 1 else set(),
)
def fbm_node(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Fractional Brownian motion: a fractal sum of periodic noise octaves."""
    return fbm_sum(
        ctx, p["noise"], p["scale_x"], p["scale_y"], p["octaves"], p["persistence"], p["seed"], p["disorder"]
    )[None]


@node(
    "ridged_noise",
    "generator",
    params={
        "scale_x": SCALE,
        "scale_y": SCALE,
        "seed": Seed(),
        "octaves": Int(1, 10, 4),
        "persistence": Float(0.05, 0.95, 0.5),
        "sharpness": Float(0.5, 32.0, 2.0, doc="exponent that thins the ridges"),
        "disorder": Float(-1.0, 1.0, 0.0),
    },
    inert=lambda p, ports: {"persistence"} if p["octaves"] == 1 else set(),
)
def ridged_noise(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Ridged fractal noise, (1 − |2·fbm − 1|)^sharpness: thin branching veins (marble, cracks)."""
    n = fbm_sum(ctx, "perlin", p["scale_x"], p["scale_y"], p["octaves"], p["persistence"], p["seed"], p["disorder"])
    ridge = (1.0 - (2.0 * n - 1.0).abs()).clamp(1e-6, 1.0)
    return ridge.pow(p["sharpness"])[None]


# ---------------------------------------------------------------------------------------- cellular
Candidate = tuple[torch.Tensor, torch.Tensor, torch.Tensor]
"""A candidate cell centre per pixel: (x, y) in texture units and its integer id (broadcastable to [H, W])."""


def voronoi(
    candidates: list[Candidate], px: torch.Tensor, py: torch.Tensor, unit: float
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """Nearest two of the candidate centres per pixel (a running minimum, cheaper than sorting).

    ``px``, ``py``: pixel positions (texture units, broadcastable to [H, W]). Returns (F1, F2, distance to
    the cell border (F2² − F1²)/(2|c₂ − c₁|), id of the nearest centre), distances divided by ``unit``.
    """
    inf = torch.tensor(float("inf"), dtype=px.dtype)
    d1 = d2 = inf
    c1x = c1y = c2x = c2y = torch.zeros((), dtype=px.dtype)
    id1 = torch.zeros((), dtype=torch.int64)
    for cx, cy, cid in candidates:
        d = (cx - px) ** 2 + (cy - py) ** 2
        closer = d < d1
        second = d < d2
        d2 = torch.where(closer, d1, torch.where(second, d, d2))
        c2x = torch.where(closer, c1x, torch.where(second, cx, c2x))
        c2y = torch.where(closer, c1y, torch.where(second, cy, c2y))
        d1 = torch.where(closer, d, d1)
        c1x = torch.where(closer, cx, c1x)
        c1y = torch.where(closer, cy, c1y)
        id1 = torch.where(closer, cid, id1)
    sep = torch.sqrt((c2x - c1x) ** 2 + (c2y - c1y) ** 2 + 1e-12)
    border = (d2 - d1) / (2.0 * sep)
    return torch.sqrt(d1 + 1e-12) / unit, torch.sqrt(d2 + 1e-12) / unit, border / unit, id1


def cellular_candidates(ctx: Context, fx: int, fy: int, seed: int, jitter: torch.Tensor | float) -> list[Candidate]:
    """Jittered feature points of the 3×3 cells around each pixel (texture units) with their cell ids."""
    ox = lattice(fx, fy, seed, 1).to(ctx.dtype)
    oy = lattice(fx, fy, seed, 2).to(ctx.dtype)
    cx = torch.floor(ctx.xs * fx).to(torch.int64)  # [1, W]
    cy = torch.floor(ctx.ys * fy).to(torch.int64)  # [H, 1]
    candidates = []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            nx, ny = cx + dx, cy + dy
            wx, wy = nx % fx, ny % fy
            jx = 0.5 + jitter * (gather2(ox, wy, wx) - 0.5)
            jy = 0.5 + jitter * (gather2(oy, wy, wx) - 0.5)
            candidates.append(((nx.to(ctx.dtype) + jx) / fx, (ny.to(ctx.dtype) + jy) / fy, wy * fx + wx))
    return candidates


@node(
    "cellular",
    "generator",
    params={
        "scale_x": SCALE,
        "scale_y": SCALE,
        "seed": Seed(),
        "jitter": Float(0.0, 1.0, 0.9, doc="how far feature points wander from the cell centres"),
        "border_width": Float(0.005, 0.5, 0.08, doc="width of the border lines, in cell sizes"),
    },
    outputs=("distance", "border", "cells", "random"),
    inert=lambda p, ports: (
        (set() if ports & {"border", "cells"} else {"border_width"}) | ({"jitter"} if ports <= {"random"} else set())
    ),
)  # per-cell values do not move with the points
def cellular(ctx: Context, inputs: dict, p: dict) -> dict[str, torch.Tensor]:
    """Cellular (Worley/Voronoi) noise: distance to the nearest feature point, cell borders, cell heights
    and a random value per cell."""
    fx, fy = p["scale_x"], p["scale_y"]
    unit = 1.0 / (fx * fy) ** 0.5
    f1, _, border, nearest = voronoi(cellular_candidates(ctx, fx, fy, p["seed"], p["jitter"]), ctx.xs, ctx.ys, unit)
    width = p["border_width"] + ctx.pixel / unit
    return {
        "distance": (f1 / 1.1).clamp(0.0, 1.0)[None],
        "border": (1.0 - smoothstep(0.0, width, border))[None],
        "cells": smoothstep(0.0, width, border)[None],
        "random": hash_table(fx * fy, p["seed"], 17)[nearest][None],
    }
