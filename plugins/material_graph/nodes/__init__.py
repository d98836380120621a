"""Node types of the procedural material graphs: what they take, what they return, how they are declared.

A node is a differentiable torch function on *tileable maps*: tensors ``[C, H, W]`` (C = 1 or 3, float32,
values in [0, 1] unless stated) covering the unit torus, so that every output repeats seamlessly. Node
types are declared with :func:`node`::

    @node("stripes", "generator", params={"count": Int(1, 64, 8), "width": Float(0, 1, 0.5)})
    def stripes(ctx, inputs, p):
        ...  # p["count"] is an int, p["width"] a 0-d tensor (differentiable)
        return out  # [C, H, W], or a dict {port: map} for nodes with several outputs

``inputs`` maps each declared input to a map converted to the declared channel count (luminance for 1,
grey repeated for 3) or None for an unconnected optional input. Generators work in tile-periodic
coordinates (integer frequencies on the unit torus); filters that move pixels sample with wrap-around
(:mod:`.ops`). Modules: :mod:`.noise`, :mod:`.patterns`, :mod:`.filters`; graph outputs are in
:mod:`..outputs`. Plugins add node types through the ``material_nodes`` hook.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import torch

from ..params import Continuous, ParamSpec


@dataclass(frozen=True)
class Input:
    """A node input: ``channels`` 1 or 3 (converted on the way in) or None (as given)."""

    channels: int | None = None
    required: bool = True
    doc: str = ""


@dataclass
class Context:
    """What a node evaluation knows besides its inputs and parameters: the map size, device and caches."""

    height: int
    width: int
    device: torch.device = field(default_factory=lambda: torch.device("cpu"))
    dtype: torch.dtype = torch.float32
    cache: dict[Any, Any] = field(default_factory=dict)

    @property
    def xs(self) -> torch.Tensor:
        """Pixel-centre x coordinates in [0, 1), shape [1, W]."""
        key = ("xs", self.width)
        if key not in self.cache:
            self.cache[key] = ((torch.arange(self.width, dtype=self.dtype) + 0.5) / self.width).to(self.device)[None]
        return self.cache[key]

    @property
    def ys(self) -> torch.Tensor:
        """Pixel-centre y coordinates in [0, 1) (row 0 at the top), shape [H, 1]."""
        key = ("ys", self.height)
        if key not in self.cache:
            self.cache[key] = ((torch.arange(self.height, dtype=self.dtype) + 0.5) / self.height).to(self.device)[
                :, None
            ]
        return self.cache[key]

    @property
    def pixel(self) -> float:
        """The size of a pixel in texture units (the larger side): edges are softened over it."""
        return 1.0 / min(self.height, self.width)


NodeFn = Callable[[Context, dict[str, Any], dict[str, Any]], "torch.Tensor | dict[str, torch.Tensor]"]


@dataclass(frozen=True)
class NodeType:
    """A kind of node: its function, parameters, inputs and output ports."""

    name: str
    kind: str
    """``generator`` (no map inputs), ``filter``."""
    fn: NodeFn
    params: dict[str, ParamSpec]
    inputs: dict[str, Input]
    outputs: tuple[str, ...] = ("out",)
    doc: str = ""
    check: Callable[[dict[str, Any]], str | None] | None = None
    """Cross-parameter validation of the discrete values: returns a problem or None."""
    normal_ports: tuple[str, ...] = ()
    """Output ports that hold unit normals (components in [−1, 1]) rather than values in [0, 1]."""
    inert: Callable[[dict[str, Any], set[str]], set[str]] | None = None
    """Continuous parameters without effect for these discrete values and used output ports (a disc's
    rotation, a single octave's persistence): a graph keeps them fixed instead of optimising them."""

    @property
    def continuous(self) -> list[str]:
        return [n for n, s in self.params.items() if isinstance(s, Continuous)]


NODE_TYPES: dict[str, NodeType] = {}
"""The built-in node types by name (filled when the node modules are imported)."""

KINDS = ("generator", "filter")


def node(
    name: str,
    kind: str,
    *,
    params: dict[str, ParamSpec] | None = None,
    inputs: dict[str, Input] | None = None,
    outputs: tuple[str, ...] = ("out",),
    check: Callable[[dict[str, Any]], str | None] | None = None,
    normal_ports: tuple[str, ...] = (),
    inert: Callable[[dict[str, Any], set[str]], set[str]] | None = None,
) -> Callable[[NodeFn], NodeFn]:
    """Declare a built-in node type (its docstring's first line is its description)."""
    if kind not in KINDS:
        raise ValueError(f"node kind must be one of {KINDS}, got {kind!r}")

    def register(fn: NodeFn) -> NodeFn:
        if name in NODE_TYPES:
            raise ValueError(f"node type {name!r} declared twice")
        doc = (fn.__doc__ or "").strip().split("\n")[0]
        NODE_TYPES[name] = NodeType(
            name,
            kind,
            fn,
            dict(params or {}),
            dict(inputs or {}),
            tuple(outputs),
            doc,
            check,
            tuple(normal_ports),
            inert,
        )
        return fn

    return register


def builtin_node_types() -> dict[str, NodeType]:
    """Every built-in node type (imports the node modules once)."""
    from . import filters, noise, patterns  # noqa: F401 - registers the node types

    return dict(NODE_TYPES)


def to_channels(x: torch.Tensor, channels: int | None) -> torch.Tensor:
    """``x`` ([C, H, W]) with ``channels`` channels: luminance (Rec. 709) for 1, grey repeated for 3."""
    if channels is None or x.shape[0] == channels:
        return x
    if channels == 1:
        if x.shape[0] == 3:
            w = torch.tensor([0.2126, 0.7152, 0.0722], dtype=x.dtype, device=x.device)
            return (x * w[:, None, None]).sum(0, keepdim=True)
        return x.mean(0, keepdim=True)
    if x.shape[0] == 1:
        return x.expand(channels, -1, -1)
    raise ValueError(f"cannot convert a {x.shape[0]}-channel map to {channels} channels")
