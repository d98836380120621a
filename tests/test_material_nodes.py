"""material_graph nodes: every node tiles seamlessly, passes gradients to each continuous parameter, and keeps
its outputs in range; plus the parameter reparameterisation and the tile-periodic helpers."""

from __future__ import annotations

import math

import pytest
import torch

from psdr_room_plugins.material_graph.nodes import Context, NodeType, builtin_node_types, to_channels
from psdr_room_plugins.material_graph.nodes.noise import fbm_sum
from psdr_room_plugins.material_graph.nodes.ops import fft_blur, hash01, sample_periodic, sample_tiled
from psdr_room_plugins.material_graph.params import (
    Choice,
    Color,
    Continuous,
    Float,
    Floats,
    Int,
    ParamError,
    Ramp,
    to_unconstrained,
)

torch.set_num_threads(1)

NODE_TYPES = builtin_node_types()
SIZE = 64
OVERRIDES = {
    # a disc is invariant to rotation and has no line thickness: test the shape that uses both
    "shape": {"shape": "cross"},
}
AROUND = {
    # clamp bounds at 0 and 1 clip nothing (a zero gradient is right there): test inside the value range
    "clamp": {"low": 0.3, "high": 0.7},
}


class ShiftedContext(Context):
    """The same pixel grid, one whole tile further along x and back along y: a periodic node must not notice."""

    @property
    def xs(self) -> torch.Tensor:
        return super().xs + 1.0

    @property
    def ys(self) -> torch.Tensor:
        return super().ys - 1.0


def _inputs(node_type: NodeType, ctx: Context) -> dict[str, torch.Tensor]:
    """A distinct tileable map per input (fBm of different seeds; colour inputs from three of them)."""
    plain = Context(ctx.height, ctx.width)
    out = {}
    for index, (slot, declared) in enumerate(node_type.inputs.items()):
        grey = fbm_sum(plain, "perlin", 3, 3, 4, 0.5, seed=100 + index)[None]
        colour = torch.stack([fbm_sum(plain, "value", 2, 2, 4, 0.5, seed=200 + 3 * index + c) for c in range(3)])
        out[slot] = to_channels(colour if declared.channels in (None, 3) else grey, declared.channels)
    return out


def _params(node_type: NodeType, u: dict[str, torch.Tensor] | None = None) -> dict[str, object]:
    values: dict[str, object] = {}
    for key, spec in node_type.params.items():
        if isinstance(spec, Continuous):
            bound = spec.default_bound()
            values[key] = bound.constrained(None if u is None else u[key])
        else:
            values[key] = OVERRIDES.get(node_type.name, {}).get(key, spec.default)
    return values


def _random_u(node_type: NodeType, seed: int = 0) -> dict[str, torch.Tensor]:
    """Unconstrained parameters at a random point around the defaults (so that no default is degenerate)."""
    generator = torch.Generator().manual_seed(seed)
    out = {}
    for key, spec in node_type.params.items():
        if isinstance(spec, Continuous):
            bound = spec.default_bound()
            u0 = bound.u0
            if key in AROUND.get(node_type.name, {}):
                u0 = to_unconstrained(torch.tensor(AROUND[node_type.name][key]), bound.lo, bound.hi)
            u0 = u0.clamp(-3.0, 3.0)  # defaults at a bound (0 or 1) would sit where the sigmoid is flat
            out[key] = (u0 + 0.7 * torch.randn(u0.shape, generator=generator)).requires_grad_(True)
    return out


def _evaluate(node_type: NodeType, ctx: Context, u: dict[str, torch.Tensor] | None = None) -> dict[str, torch.Tensor]:
    out = node_type.fn(ctx, _inputs(node_type, ctx), _params(node_type, u))
    return out if isinstance(out, dict) else {node_type.outputs[0]: out}


def seam_ratio(x: torch.Tensor, dim: int) -> tuple[float, float]:
    """(mean |first − last| line difference across the wrap-around seam, the largest mean difference between
    neighbouring interior lines) along ``dim`` (−1: columns, −2: rows)."""
    first, last = x.select(dim, 0), x.select(dim, x.shape[dim] - 1)
    seam = float((first - last).abs().mean())
    neighbours = (x.narrow(dim, 1, x.shape[dim] - 1) - x.narrow(dim, 0, x.shape[dim] - 1)).abs()
    reduce = [d for d in range(x.dim()) if d != x.dim() + dim]
    interior = neighbours.mean(dim=reduce)
    return seam, float(interior.max())


@pytest.mark.parametrize("name", sorted(NODE_TYPES))
def test_node_tiles_seamlessly(name: str) -> None:
    node_type = NODE_TYPES[name]
    outputs = _evaluate(node_type, Context(SIZE, SIZE))
    shifted = _evaluate(node_type, ShiftedContext(SIZE, SIZE))
    for port, x in outputs.items():
        for dim in (-1, -2):
            seam, interior = seam_ratio(x.detach(), dim)
            assert seam <= 1.5 * interior + 1e-3, (
                f"{name}.{port}: wrap-around difference {seam:.4f} vs interior neighbours at most {interior:.4f}"
            )
        # exact periodicity: the node evaluated one tile further is the same map
        difference = float((shifted[port] - x).abs().mean())
        assert difference < 1e-3, f"{name}.{port} changes by {difference:.4f} one tile over: not periodic"


@pytest.mark.parametrize("name", sorted(NODE_TYPES))
def test_node_outputs_stay_in_range(name: str) -> None:
    node_type = NODE_TYPES[name]
    for seed in range(2):
        u = _random_u(node_type, seed)
        for port, x in _evaluate(node_type, Context(SIZE, SIZE), u).items():
            x = x.detach()
            assert x.shape[-2:] == (SIZE, SIZE) and x.shape[0] in (1, 3) and x.dtype == torch.float32
            assert torch.isfinite(x).all(), f"{name}.{port} has non-finite values"
            if port in node_type.normal_ports:
                norm = torch.linalg.vector_norm(x, dim=0)
                assert torch.allclose(norm, torch.ones_like(norm), atol=1e-4), f"{name}.{port}: normals not unit"
                assert bool((x[2] > 0).all()), f"{name}.{port}: normals must face out of the surface"
            else:
                assert float(x.min()) >= -1e-5 and float(x.max()) <= 1 + 1e-5, (
                    f"{name}.{port} outside [0, 1]: [{float(x.min()):.4f}, {float(x.max()):.4f}]"
                )


@pytest.mark.parametrize("name", sorted(n for n, t in NODE_TYPES.items() if t.continuous))
def test_gradients_reach_every_continuous_parameter(name: str) -> None:
    node_type = NODE_TYPES[name]
    u = _random_u(node_type, seed=1)
    outputs = _evaluate(node_type, Context(SIZE, SIZE), u)
    generator = torch.Generator().manual_seed(2)
    loss = sum((x * torch.rand(x.shape, generator=generator)).sum() for x in outputs.values())
    loss.backward()
    for key, tensor in u.items():
        assert tensor.grad is not None, f"{name}.{key}: no gradient"
        assert torch.isfinite(tensor.grad).all(), f"{name}.{key}: non-finite gradient"
        assert float(tensor.grad.abs().sum()) > 1e-8, f"{name}.{key}: zero gradient"


def test_every_node_kind_of_the_issue_is_there() -> None:
    wanted = {
        "value_noise",
        "perlin_noise",
        "fbm",
        "cellular",
        "tiles",
        "hex_tiles",
        "planks",
        "herringbone",
        "parquet",
        "stripes",
        "wood_rings",
        "wood_grain",
        "weave",
        "knit",
        "gradient",
        "shape",
        "blend",
        "levels",
        "curves",
        "gradient_map",
        "hsl",
        "blur",
        "directional_warp",
        "slope_blur",
        "transform",
        "height_to_normal",
        "edge_detect",
        "clamp",
    }
    assert wanted <= set(NODE_TYPES)
    assert {t.kind for t in NODE_TYPES.values()} == {"generator", "filter"}
    assert all(t.doc for t in NODE_TYPES.values()), "every node type needs a one-line description"


def test_patterns_have_per_tile_variation_and_bevels() -> None:
    out = _evaluate(NODE_TYPES["tiles"], Context(128, 128))
    assert len(torch.unique(out["random"])) >= 16  # one value per tile (4 × 8 tiles by default)
    assert float(out["mask"].min()) < 0.2 and float(out["mask"].max()) > 0.99  # joints and tile faces
    herring = _evaluate(NODE_TYPES["herringbone"], Context(128, 128))
    assert set(torch.unique(herring["orient"]).tolist()) == {0.0, 1.0}  # both plank directions


# ------------------------------------------------------------------------------------------ params
def test_reparameterisation_keeps_values_in_range_and_round_trips() -> None:
    bound = Float(0.2, 0.9, 0.5).parse({"value": 0.3, "range": [0.25, 0.6]})
    assert float(bound.constrained(None)) == pytest.approx(0.3)
    assert float(bound.constrained(bound.u0)) == pytest.approx(0.3, abs=1e-5)
    for u in (-1e3, -5.0, 0.0, 5.0, 1e3):
        value = float(bound.constrained(torch.tensor(u)))
        assert 0.25 - 1e-6 <= value <= 0.6 + 1e-6
    u = torch.tensor(0.0, requires_grad=True)
    bound.constrained(u).backward()
    assert float(u.grad) == pytest.approx(0.35 * 0.25)  # (hi − lo)·sigmoid′(0)
    at_bound = Float(0.0, 1.0, 0.0).default_bound()
    assert torch.isfinite(at_bound.u0) and float(at_bound.constrained(at_bound.u0)) == pytest.approx(0.0, abs=0.011)
    assert float(at_bound.constrained(None)) == 0.0  # the graph's own value is exact until optimised
    assert torch.allclose(to_unconstrained(torch.tensor(0.5), torch.tensor(0.0), torch.tensor(1.0)), torch.tensor(0.0))


def test_parameter_specs_reject_bad_values() -> None:
    with pytest.raises(ParamError, match=r"outside \[0.0, 0.4\]"):
        Float(0.0, 0.4, 0.1).parse(0.9)
    with pytest.raises(ParamError, match="reaches outside"):
        Float(0.0, 0.4, 0.1).parse({"value": 0.1, "range": [0.0, 0.5]})
    with pytest.raises(ParamError, match="unknown key"):
        Float(0.0, 1.0, 0.1).parse({"value": 0.1, "rnage": [0.0, 0.5]})
    with pytest.raises(ParamError, match="integer"):
        Int(1, 8, 2).parse(2.5)
    with pytest.raises(ParamError, match="multiple of 2"):
        Int(2, 8, 2, step=2).parse(3)
    with pytest.raises(ParamError, match="one of"):
        Choice(("a", "b"), "a").parse("c")
    with pytest.raises(ParamError, match="#rrggbb"):
        Color().parse("#12345")
    with pytest.raises(ParamError, match="at least two"):
        Ramp().parse([[0.0, "#000000"]])
    assert Color().parse("#ff8000").value.tolist() == pytest.approx([1.0, 128 / 255, 0.0])
    assert Floats(0.0, 1.0, (0.0, 1.0)).parse({"value": [0.1, 0.5, 0.9], "fixed": True}).fixed
    spread = Color().parse({"value": "#808080", "spread": 0.1})
    assert torch.allclose(spread.hi - spread.lo, torch.full((3,), 0.2), atol=1e-6)


# ------------------------------------------------------------------------------------- helpers
def test_hash_is_deterministic_and_uniform() -> None:
    ids = torch.arange(20000)
    a, b = hash01(ids, seed=3), hash01(ids, seed=3)
    assert torch.equal(a, b) and not torch.equal(a, hash01(ids, seed=4))
    assert float(a.min()) >= 0.0 and float(a.max()) < 1.0 and abs(float(a.mean()) - 0.5) < 0.01


def test_periodic_sampling_and_blur_wrap_around() -> None:
    ctx = Context(32, 48)
    img = torch.stack([fbm_sum(ctx, "value", 2, 3, 3, 0.5, seed=s) for s in range(3)])
    same = sample_periodic(img, ctx.xs + 2.0, ctx.ys - 1.0)
    assert torch.allclose(same, img, atol=1e-5)
    shifted = sample_periodic(img, ctx.xs + 5.0 / 48, ctx.ys)  # five pixels along x, wrapping
    assert torch.allclose(shifted, torch.roll(img, -5, dims=-1), atol=1e-5)
    blurred = fft_blur(img, 0.05)
    assert torch.allclose(blurred.mean(dim=(1, 2)), img.mean(dim=(1, 2)), atol=1e-5)
    assert float(blurred.std()) < float(img.std())
    view = sample_tiled(img, (16, 16), scale=2.0, rotation_deg=30.0)
    assert view.shape == (3, 16, 16) and torch.isfinite(view).all()
    sigma = torch.tensor(0.02, requires_grad=True)
    fft_blur(img, sigma).pow(2).sum().backward()
    assert math.isfinite(float(sigma.grad)) and float(sigma.grad) != 0.0


def test_seam_check_catches_maps_that_do_not_tile() -> None:
    ctx = Context(64, 80)
    noise = fbm_sum(ctx, "perlin", 4, 4, 4, 0.5, seed=5)[None]
    seam, interior = seam_ratio(noise, -2)  # rows: 64 of 64, tileable
    assert seam <= 1.5 * interior + 1e-3
    seam, interior = seam_ratio(noise[..., :64], -1)  # the first 64 of 80 columns: a cut, not a tile
    assert seam > 1.5 * interior + 1e-3
    ramp = Context(8, 64).xs.expand(8, 64)[None]
    seam, interior = seam_ratio(ramp, -1)
    assert seam > 1.5 * interior + 1e-3
