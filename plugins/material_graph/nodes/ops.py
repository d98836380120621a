"""Tile-periodic building blocks the nodes share: integer hashing, lattice noise, wrap-around sampling,
FFT blur and periodic derivatives. Everything here keeps maps seamless on the unit torus."""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F

_M32 = 0xFFFFFFFF


def hash_u32(*keys: torch.Tensor | int, seed: int = 0) -> torch.Tensor:
    """A 32-bit integer hash (int64 tensor) of integer tensors (broadcast) and a seed.

    Used for per-cell / per-tile random values: the same integer cell id and seed always give the same
    value, which is what makes patterns repeat exactly across the tile border.
    """
    h: torch.Tensor | int = (seed * 0x9E3779B1 + 0x7F4A7C15) & _M32
    for k in keys:
        k = torch.as_tensor(k, dtype=torch.int64) if not isinstance(k, torch.Tensor) else k.to(torch.int64)
        h = (h ^ ((k & _M32) * 0x85EBCA6B & _M32)) & _M32
        h = ((h ^ (h >> 13)) * 0xC2B2AE35) & _M32
        h = (h ^ (h >> 16)) & _M32
    h = torch.as_tensor(h, dtype=torch.int64)
    h = ((h ^ (h >> 15)) * 0x2C1B3C6D) & _M32
    h = ((h ^ (h >> 12)) * 0x297A2D39) & _M32
    return h ^ (h >> 15)


def hash01(*keys: torch.Tensor | int, seed: int = 0) -> torch.Tensor:
    """Uniform pseudo-random floats in [0, 1) from integer keys (see :func:`hash_u32`)."""
    return hash_u32(*keys, seed=seed).to(torch.float32) / 4294967296.0


def hash_table(n: int, seed: int, salt: int = 0) -> torch.Tensor:
    """``hash01(i, salt, seed)`` for i in 0..n-1: per-tile random values, looked up by integer tile id
    (cheaper than hashing every pixel)."""
    return hash01(torch.arange(n), salt, seed=seed)


def lattice(fx: int, fy: int, seed: int, salt: int = 0) -> torch.Tensor:
    """A [fy, fx] table of uniform random values in [0, 1) for a period-(fx, fy) lattice."""
    iy = torch.arange(fy)[:, None]
    ix = torch.arange(fx)[None, :]
    return hash01(ix, iy, salt, seed=seed)


def cell_coords(coord: torch.Tensor, freq: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(cell index mod freq, next cell index mod freq, fraction in the cell) of coordinates in [0, 1)."""
    scaled = coord * freq
    cell = torch.floor(scaled)
    frac = scaled - cell
    i0 = cell.to(torch.int64) % freq
    return i0, (i0 + 1) % freq, frac


def fade(t: torch.Tensor) -> torch.Tensor:
    """Quintic fade 6t⁵ − 15t⁴ + 10t³ (C² continuous lattice interpolation)."""
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def gather2(table: torch.Tensor, iy: torch.Tensor, ix: torch.Tensor) -> torch.Tensor:
    """``table[iy, ix]`` for a row index [H, 1] and a column index [1, W] → [H, W] (two cheap selects)."""
    return table.index_select(0, iy.flatten()).index_select(1, ix.flatten())


def value_noise(
    xs: torch.Tensor, ys: torch.Tensor, fx: int, fy: int, seed: int, disorder: torch.Tensor | float = 0.0, salt: int = 0
) -> torch.Tensor:
    """Periodic value noise in [0, 1] on an [H, W] grid (xs [1, W], ys [H, 1]) with fx × fy lattice cells.

    Lattice values are ``0.5 + 0.5·sin(2π(r₁ + disorder·r₂))``: ``disorder`` moves them continuously
    (Substance's "disorder"), so it can be optimised while the frequencies stay fixed.
    """
    r1 = lattice(fx, fy, seed, salt)
    r2 = lattice(fx, fy, seed, salt + 7919)
    table = 0.5 + 0.5 * torch.sin(2 * math.pi * (r1.to(xs) + disorder * r2.to(xs)))
    ix0, ix1, tx = cell_coords(xs, fx)
    iy0, iy1, ty = cell_coords(ys, fy)
    sx, sy = fade(tx), fade(ty)
    top = torch.lerp(gather2(table, iy0, ix0), gather2(table, iy0, ix1), sx)
    bottom = torch.lerp(gather2(table, iy1, ix0), gather2(table, iy1, ix1), sx)
    return torch.lerp(top, bottom, sy)


def perlin_noise(
    xs: torch.Tensor, ys: torch.Tensor, fx: int, fy: int, seed: int, disorder: torch.Tensor | float = 0.0, salt: int = 0
) -> torch.Tensor:
    """Periodic Perlin (gradient) noise, centred on 0.5 and scaled to about [0, 1], on an [H, W] grid."""
    r1 = lattice(fx, fy, seed, salt)
    r2 = lattice(fx, fy, seed, salt + 7919)
    angle = 2 * math.pi * (r1.to(xs) + disorder * r2.to(xs))
    gx, gy = torch.cos(angle), torch.sin(angle)
    ix0, ix1, tx = cell_coords(xs, fx)
    iy0, iy1, ty = cell_coords(ys, fy)

    def corner(iy: torch.Tensor, ix: torch.Tensor, dx: torch.Tensor, dy: torch.Tensor) -> torch.Tensor:
        return gather2(gx, iy, ix) * dx + gather2(gy, iy, ix) * dy

    sx, sy = fade(tx), fade(ty)
    top = torch.lerp(corner(iy0, ix0, tx, ty), corner(iy0, ix1, tx - 1, ty), sx)
    bottom = torch.lerp(corner(iy1, ix0, tx, ty - 1), corner(iy1, ix1, tx - 1, ty - 1), sx)
    return 0.5 + 0.75 * torch.lerp(top, bottom, sy)


# ----------------------------------------------------------------------------------- periodic sampling
def sample_periodic(img: torch.Tensor, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Bilinear samples of a tileable map ``img`` [C, H, W] at texture coordinates ``x``, ``y`` (broadcast
    to one [H', W'] shape; 1 = one tile, wrapped), differentiable with respect to the map and coordinates.

    The map is padded by one pixel with wrap-around and sampled with ``grid_sample``, so samples between
    the last and the first pixel interpolate across the tile border.
    """
    c, h, w = img.shape
    shape = torch.broadcast_shapes(x.shape, y.shape)
    px = torch.remainder(torch.broadcast_to(x, shape), 1.0) * w + 0.5  # padded-pixel coordinates
    py = torch.remainder(torch.broadcast_to(y, shape), 1.0) * h + 0.5
    grid = torch.stack([px * (2.0 / (w + 1)) - 1.0, py * (2.0 / (h + 1)) - 1.0], dim=-1)
    padded = F.pad(img[None], (1, 1, 1, 1), mode="circular")
    return F.grid_sample(padded, grid[None].to(img.dtype), mode="bilinear", padding_mode="border", align_corners=True)[
        0
    ]


def sample_tiled(
    img: torch.Tensor,
    size: tuple[int, int],
    scale: float = 1.0,
    rotation_deg: float = 0.0,
    offset: tuple[float, float] = (0.0, 0.0),
) -> torch.Tensor:
    """An ``size`` = (H, W) view of the infinitely tiled map: ``scale`` tiles across the view's width,
    rotated by ``rotation_deg`` and shifted by ``offset`` (tiles). Used for texture transforms (§4.4)."""
    h, w = size
    ys = ((torch.arange(h, dtype=img.dtype, device=img.device) + 0.5) / w)[:, None] - 0.5 * h / w
    xs = ((torch.arange(w, dtype=img.dtype, device=img.device) + 0.5) / w)[None, :] - 0.5
    a = math.radians(rotation_deg)
    ca, sa = math.cos(a), math.sin(a)
    u = scale * (ca * xs - sa * ys) + offset[0]
    v = scale * (sa * xs + ca * ys) + offset[1]
    return sample_periodic(img, u, v)


def fft_blur(img: torch.Tensor, sigma: torch.Tensor | float) -> torch.Tensor:
    """Gaussian blur with wrap-around (a circular convolution via the FFT); ``sigma`` in texture units.

    The cost does not depend on sigma, and the result is differentiable with respect to sigma.
    """
    c, h, w = img.shape
    fy = torch.fft.fftfreq(h, device=img.device, dtype=img.dtype)[:, None] * h  # cycles per tile
    fx = torch.fft.rfftfreq(w, device=img.device, dtype=img.dtype)[None, :] * w
    sigma = torch.as_tensor(sigma, dtype=img.dtype, device=img.device)
    gain = torch.exp(-2.0 * math.pi**2 * sigma**2 * (fx**2 + fy**2))
    return torch.fft.irfft2(torch.fft.rfft2(img) * gain, s=(h, w))


def gradient(img: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Periodic central differences (d/dx, d/dy) in units per texture width/height (y grows downwards)."""
    h, w = img.shape[-2:]
    dx = (torch.roll(img, -1, -1) - torch.roll(img, 1, -1)) * (w / 2.0)
    dy = (torch.roll(img, -1, -2) - torch.roll(img, 1, -2)) * (h / 2.0)
    return dx, dy


def smoothstep(e0: torch.Tensor | float, e1: torch.Tensor | float, x: torch.Tensor) -> torch.Tensor:
    """Hermite step from 0 at ``e0`` to 1 at ``e1`` (differentiable in the edges too)."""
    t = ((x - e0) / (torch.as_tensor(e1) - e0 + 1e-6)).clamp(0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def bevel_profile(distance: torch.Tensor, gap: torch.Tensor, bevel: torch.Tensor, pixel: float) -> torch.Tensor:
    """Height of a tile at ``distance`` from its edge: 0 in the gap (half-width ``gap``), rising over
    ``bevel`` to 1 (all in texture units); the ramp is widened by a pixel so that edges are anti-aliased."""
    return smoothstep(gap - 0.5 * pixel, gap + bevel + 0.5 * pixel, distance)
