"""Filters: blend modes, levels, curves, gradient map (colour ramp), HSL, blur, warps, slope blur, 2D
transform with tiling, height to normal, edge detection, clamp, invert, threshold, greyscale.

Filters that move or spread pixels sample with wrap-around (:func:`.ops.sample_periodic`, FFT blur), so a
tileable input gives a tileable output; the rest are pointwise.
"""

from __future__ import annotations

import math

import torch

from ..params import Choice, Float, Floats, Int, Ramp
from . import Context, Input, node
from .ops import fft_blur, gradient, sample_periodic, smoothstep

ANY = Input(None)
GREY = Input(1)
RGB = Input(3)

BLEND_MODES = (
    "normal",
    "multiply",
    "screen",
    "overlay",
    "soft_light",
    "add",
    "subtract",
    "darken",
    "lighten",
    "difference",
)


def _match(a: torch.Tensor, b: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    if a.shape[0] != b.shape[0]:
        a, b = a.expand(3, -1, -1), b.expand(3, -1, -1)
    return a, b


@node(
    "blend",
    "filter",
    params={
        "mode": Choice(BLEND_MODES, "normal"),
        "opacity": Float(0.0, 1.0, 1.0),
    },
    inputs={"background": ANY, "foreground": ANY, "mask": Input(1, required=False)},
)
def blend(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Blend a foreground over a background with a blend mode, an opacity and an optional mask."""
    a, b = _match(inputs["background"], inputs["foreground"])
    mode = p["mode"]
    if mode == "normal":
        f = b
    elif mode == "multiply":
        f = a * b
    elif mode == "screen":
        f = 1 - (1 - a) * (1 - b)
    elif mode == "overlay":
        f = torch.where(a < 0.5, 2 * a * b, 1 - 2 * (1 - a) * (1 - b))
    elif mode == "soft_light":
        f = (1 - 2 * b) * a * a + 2 * b * a
    elif mode == "add":
        f = a + b
    elif mode == "subtract":
        f = a - b
    elif mode == "darken":
        f = torch.minimum(a, b)
    elif mode == "lighten":
        f = torch.maximum(a, b)
    else:
        f = (a - b).abs()
    weight = p["opacity"]
    if inputs["mask"] is not None:
        weight = weight * inputs["mask"]
    return torch.lerp(a, f.clamp(0, 1), weight).clamp(0, 1)


@node(
    "levels",
    "filter",
    params={
        "in_low": Float(0.0, 1.0, 0.0),
        "in_high": Float(0.0, 1.0, 1.0),
        "gamma": Float(0.1, 10.0, 1.0, doc="mid-tone exponent (> 1 brightens)"),
        "out_low": Float(0.0, 1.0, 0.0),
        "out_high": Float(0.0, 1.0, 1.0),
    },
    inputs={"input": ANY},
)
def levels(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Levels: remap [in_low, in_high] to [out_low, out_high] with a gamma."""
    span = (p["in_high"] - p["in_low"]).clamp(min=1e-3)
    t = ((inputs["input"] - p["in_low"]) / span).clamp(1e-6, 1.0)
    t = t.pow(1.0 / p["gamma"])
    return (p["out_low"] + (p["out_high"] - p["out_low"]) * t).clamp(0, 1)


def _piecewise(x: torch.Tensor, values: torch.Tensor) -> torch.Tensor:
    """Piecewise-linear curve through ``values`` at evenly spaced x in [0, 1]."""
    n = values.shape[0]
    t = x.clamp(0, 1) * (n - 1)
    i = torch.floor(t).clamp(max=n - 2).to(torch.int64)
    f = t - i
    return torch.lerp(values[i], values[i + 1], f)


@node(
    "curves",
    "filter",
    params={
        "points": Floats(0.0, 1.0, (0.0, 0.25, 0.5, 0.75, 1.0), doc="output at evenly spaced inputs 0..1"),
    },
    inputs={"input": ANY},
)
def curves(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Tone curve through control values at evenly spaced inputs (piecewise linear)."""
    return _piecewise(inputs["input"], p["points"].to(ctx.dtype))


@node("gradient_map", "filter", params={"ramp": Ramp(0.0, 1.0)}, inputs={"input": GREY})
def gradient_map(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Colour ramp: map a greyscale map to colours through [position, colour] stops."""
    ramp = p["ramp"].to(ctx.dtype)
    pos, order = torch.sort(ramp[:, 0])
    colours = ramp[order, 1:]
    x = inputs["input"]  # [1, H, W]
    out = colours[0].reshape(3, 1, 1).expand(3, *x.shape[1:])
    for k in range(pos.shape[0] - 1):
        w = ((x - pos[k]) / (pos[k + 1] - pos[k]).clamp(min=1e-4)).clamp(0, 1)
        out = out + (colours[k + 1] - colours[k]).reshape(3, 1, 1) * w
    return out.clamp(0, 1)


_YIQ = torch.tensor([[0.299, 0.587, 0.114], [0.596, -0.274, -0.322], [0.211, -0.523, 0.312]])


@node(
    "hsl",
    "filter",
    params={
        "hue": Float(-0.5, 0.5, 0.0, doc="hue rotation, in turns"),
        "saturation": Float(0.0, 2.0, 1.0, doc="chroma scale"),
        "lightness": Float(-1.0, 1.0, 0.0, doc="added to the luma"),
    },
    inputs={"input": RGB},
)
def hsl(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Hue / saturation / lightness adjustment (a rotation and scaling of chroma in YIQ)."""
    m = _YIQ.to(ctx.dtype)
    yiq = torch.einsum("ij,jhw->ihw", m, inputs["input"])
    angle = 2 * math.pi * p["hue"]
    c, s = torch.cos(angle), torch.sin(angle)
    i = (yiq[1] * c - yiq[2] * s) * p["saturation"]
    q = (yiq[1] * s + yiq[2] * c) * p["saturation"]
    y = yiq[0] + p["lightness"]
    return torch.einsum("ij,jhw->ihw", torch.linalg.inv(m), torch.stack([y, i, q])).clamp(0, 1)


@node(
    "blur",
    "filter",
    params={
        "sigma": Float(0.0, 0.1, 0.005, doc="Gaussian standard deviation, in tile widths"),
    },
    inputs={"input": ANY},
)
def blur(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Gaussian blur with wrap-around (FFT; cost independent of sigma)."""
    return fft_blur(inputs["input"], p["sigma"]).clamp(0, 1)


@node(
    "directional_warp",
    "filter",
    params={
        "angle": Float(-1.0, 1.0, 0.0, doc="direction, in turns (0: +x)"),
        "amount": Float(0.0, 0.5, 0.05, doc="displacement at intensity 1, in tile widths"),
    },
    inputs={"input": ANY, "intensity": GREY},
)
def directional_warp(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Shift each pixel along a fixed direction by an amount scaled by the intensity map."""
    a = 2 * math.pi * p["angle"]
    d = p["amount"] * inputs["intensity"][0]
    return sample_periodic(inputs["input"], ctx.xs + d * torch.cos(a), ctx.ys + d * torch.sin(a))


def _unit_slope(slope: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The slope map's gradient divided by its mean magnitude (so amounts are in tile widths)."""
    dx, dy = gradient(slope[0])
    scale = torch.sqrt(dx * dx + dy * dy + 1e-12).mean() + 1e-6
    return dx / scale, dy / scale


@node(
    "warp",
    "filter",
    params={
        "amount": Float(0.0, 0.3, 0.03, doc="displacement at average slope, in tile widths"),
    },
    inputs={"input": ANY, "intensity": GREY},
)
def warp(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Displace pixels along the gradient of an intensity map (Substance's Warp)."""
    dx, dy = _unit_slope(inputs["intensity"])
    return sample_periodic(inputs["input"], ctx.xs + p["amount"] * dx, ctx.ys + p["amount"] * dy)


@node(
    "slope_blur",
    "filter",
    params={
        "samples": Int(2, 32, 6, doc="samples along the slope"),
        "amount": Float(0.0, 0.2, 0.02, doc="length of the smear at average slope, in tile widths"),
    },
    inputs={"input": ANY, "slope": GREY},
)
def slope_blur(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Smear the input along the gradient of a slope map (eroded, streaky looks)."""
    dx, dy = _unit_slope(inputs["slope"])
    out = torch.zeros_like(inputs["input"])
    n = p["samples"]
    for k in range(n):
        t = p["amount"] * (k / (n - 1))
        out = out + sample_periodic(inputs["input"], ctx.xs + t * dx, ctx.ys + t * dy)
    return out / n


@node(
    "transform",
    "filter",
    params={
        "repeat_x": Int(1, 64, 1, doc="copies across"),
        "repeat_y": Int(1, 64, 1, doc="copies down"),
        "rotate90": Int(0, 3, 0, doc="quarter turns"),
        "offset_x": Float(-1.0, 1.0, 0.0, doc="shift, in tile widths"),
        "offset_y": Float(-1.0, 1.0, 0.0),
    },
    inputs={"input": ANY},
)
def transform(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """2D transform that keeps tiling: integer repeats, quarter turns and a (continuous) offset."""
    x, y = ctx.xs.expand(ctx.height, ctx.width), ctx.ys.expand(ctx.height, ctx.width)
    for _ in range(p["rotate90"]):
        x, y = y, 1.0 - x
    u = x * p["repeat_x"] + p["offset_x"]
    v = y * p["repeat_y"] + p["offset_y"]
    return sample_periodic(inputs["input"], u, v)


@node(
    "height_to_normal",
    "filter",
    params={
        "strength": Float(0.0, 20.0, 2.0, doc="relief depth for height 1, in % of the tile width"),
    },
    inputs={"height": GREY},
    normal_ports=("out",),
)
def height_to_normal(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Tangent-space unit normals from a height map (OpenGL convention: +x right, +y up the image)."""
    dx, dy = gradient(inputs["height"][0])
    k = p["strength"] * 0.01
    n = torch.stack([-k * dx, k * dy, torch.ones_like(dx)])
    return n / torch.linalg.vector_norm(n, dim=0, keepdim=True)


@node(
    "edge_detect",
    "filter",
    params={
        "width": Float(0.0005, 0.05, 0.003, doc="edge width, in tile widths"),
        "contrast": Float(0.0, 4.0, 1.0),
    },
    inputs={"input": GREY},
)
def edge_detect(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Edges: gradient magnitude of the input smoothed at the edge width."""
    smooth = fft_blur(inputs["input"], p["width"])
    dx, dy = gradient(smooth[0])
    magnitude = torch.sqrt(dx * dx + dy * dy + 1e-12) * p["width"] * 4.0
    return (p["contrast"] * magnitude).clamp(0, 1)[None]


@node("clamp", "filter", params={"low": Float(0.0, 1.0, 0.0), "high": Float(0.0, 1.0, 1.0)}, inputs={"input": ANY})
def clamp(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Clamp values to [low, high]."""
    return torch.maximum(torch.minimum(inputs["input"], p["high"]), p["low"])


@node("invert", "filter", inputs={"input": ANY})
def invert(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """1 − input."""
    return 1.0 - inputs["input"]


@node(
    "threshold",
    "filter",
    params={
        "position": Float(0.0, 1.0, 0.5, doc="the value that maps to 0.5"),
        "contrast": Float(0.0, 1.0, 0.8, doc="1: a hard step, 0: the identity ramp"),
    },
    inputs={"input": GREY},
)
def threshold(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Histogram scan: a soft step around ``position`` (masks from noise)."""
    half = (1.0 - p["contrast"]) / 2.0 + 1e-3
    return smoothstep(p["position"] - half, p["position"] + half, inputs["input"])


@node("grayscale", "filter", inputs={"input": GREY})
def grayscale(ctx: Context, inputs: dict, p: dict) -> torch.Tensor:
    """Luminance of a colour map (Rec. 709 weights)."""
    return inputs["input"]
