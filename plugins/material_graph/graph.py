"""The material graph format: loading and validating graph files, and evaluating them with torch.

A graph file (YAML or JSON) is a mapping::

    name: oak_planks                  # optional, defaults to the file's stem
    category: wood floor              # what the material is (shown by `psdr-room-materials list`)
    description: light oak boards, satin finish
    tags: [wood, floor]
    tile_size: 1.2                    # metres one repeat of the maps covers in a room (initial UV scale)
    nodes:                            # node name -> type, parameters, inputs (the edges)
      boards:
        type: planks
        params:
          rows: 6                     # discrete: a plain value (fixed during optimisation)
          gap: {value: 0.04, range: [0.02, 0.08]}   # continuous: a value, optionally its plausible range
      grain:
        type: wood_grain
        inputs: {along: boards.along, across: boards.across, random: boards.random}   # node[.port]
      colour:
        type: gradient_map
        inputs: {input: grain}
        params: {ramp: [[0.0, "#8a5a32"], [1.0, "#c89a64"]]}
    outputs:                          # base_color, roughness, metallic, height, normal: node[.port] or a constant
      base_color: colour
      roughness: 0.45
      height: boards.height

Continuous parameters take ``V`` or ``{value: V, range: [lo, hi] | spread: s, fixed: bool}`` (a range must
lie inside the node type's bounds); colours are ``"#rrggbb"`` or ``[r, g, b]``. Loading checks every field
and raises :class:`GraphError` naming the file, the node and the field. :class:`ProceduralMaterial` is the
loaded graph: :meth:`~ProceduralMaterial.parameters` gives the unconstrained tensors an optimiser updates,
:meth:`~ProceduralMaterial.evaluate` the output maps at any resolution.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch

from psdr_room_core.engine.errors import PsdrRoomError

from .nodes import Context, NodeType, to_channels
from .outputs import OUTPUTS, flat_normal, normal_from_height
from .params import Bound, Continuous, ParamError, parse_color

GRAPH_SUFFIXES = (".yaml", ".yml", ".json")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_TOP_KEYS = ("name", "category", "description", "tags", "tile_size", "nodes", "outputs")
_NODE_KEYS = ("type", "params", "inputs", "comment")


class GraphError(PsdrRoomError):
    """An invalid graph file: the message names the file, the node and the field."""


@dataclass(frozen=True)
class Ref:
    """An edge's source: a node's output port."""

    node: str
    port: str

    def __str__(self) -> str:
        return f"{self.node}.{self.port}"


@dataclass
class NodeSpec:
    """One node of a loaded graph."""

    name: str
    type: NodeType
    params: dict[str, Any]
    """Discrete parameters as Python values, continuous ones as :class:`Bound`."""
    inputs: dict[str, Ref]


@dataclass
class ProceduralMaterial:
    """A loaded, validated material graph (see the module docstring)."""

    name: str
    category: str
    description: str
    tags: list[str]
    nodes: dict[str, NodeSpec]
    """In evaluation (topological) order; only the nodes the outputs need."""
    outputs: dict[str, Ref | torch.Tensor]
    tile_size: float = 1.0
    """Metres one repeat of the maps covers in a room (the texture transform search starts there)."""
    source: str = ""
    _bounds: dict[str, Bound] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self._bounds = {
            f"{n.name}.{k}": v for n in self.nodes.values() for k, v in n.params.items() if isinstance(v, Bound)
        }

    # ------------------------------------------------------------------------------- parameters
    @property
    def bounds(self) -> dict[str, Bound]:
        """Every continuous parameter (``node.param``) with its value and range, fixed ones included."""
        return dict(self._bounds)

    def parameters(self, requires_grad: bool = True) -> dict[str, torch.Tensor]:
        """Fresh unconstrained tensors ``u`` (one per optimisable parameter, ``node.param``) at the graph's
        values; the node sees ``lo + (hi − lo)·sigmoid(u)``. Fixed parameters are not included."""
        return {k: b.u0.clone().requires_grad_(requires_grad) for k, b in self._bounds.items() if not b.fixed}

    def values(self, params: Mapping[str, torch.Tensor] | None = None) -> dict[str, torch.Tensor]:
        """The constrained value of every continuous parameter for unconstrained ``params``."""
        params = params or {}
        return {k: b.constrained(params.get(k)) for k, b in self._bounds.items()}

    def unconstrained(self, values: Mapping[str, Any]) -> dict[str, torch.Tensor]:
        """``u`` tensors for the given constrained values (``node.param`` → value), clamped to their ranges."""
        from .params import to_unconstrained

        out = {}
        for key, value in values.items():
            if key not in self._bounds:
                raise GraphError(
                    f"{self.source}: material '{self.name}' has no continuous parameter '{key}'; "
                    f"known: {', '.join(self._bounds)}"
                )
            b = self._bounds[key]
            out[key] = to_unconstrained(torch.as_tensor(value, dtype=b.value.dtype).clamp(b.lo, b.hi), b.lo, b.hi)
        return out

    # ------------------------------------------------------------------------------- evaluation
    def evaluate(
        self,
        size: int | tuple[int, int],
        params: Mapping[str, torch.Tensor] | None = None,
        *,
        device: str | torch.device | None = None,
        outputs: tuple[str, ...] = tuple(OUTPUTS),
    ) -> dict[str, torch.Tensor]:
        """The output maps at ``size`` (side or (H, W)) for unconstrained ``params`` (default: the graph's
        values), differentiable with respect to those tensors. See :mod:`.outputs` for the maps."""
        height, width = (size, size) if isinstance(size, int) else size
        if device is None:
            device = next((t.device for t in (params or {}).values()), torch.device("cpu"))
        ctx = Context(int(height), int(width), torch.device(device))
        params = params or {}
        results: dict[str, dict[str, torch.Tensor]] = {}
        for spec in self.nodes.values():
            inputs = {}
            for slot, declared in spec.type.inputs.items():
                ref = spec.inputs.get(slot)
                inputs[slot] = None if ref is None else to_channels(results[ref.node][ref.port], declared.channels)
            values = {
                k: (v.constrained(params.get(f"{spec.name}.{k}")).to(device) if isinstance(v, Bound) else v)
                for k, v in spec.params.items()
            }
            out = spec.type.fn(ctx, inputs, values)
            results[spec.name] = out if isinstance(out, dict) else {spec.type.outputs[0]: out}
        maps: dict[str, torch.Tensor] = {}
        for name in OUTPUTS:
            if name == "normal":
                continue
            source = self.outputs.get(name, _constant(name, OUTPUTS[name].default))
            if isinstance(source, Ref):
                x = results[source.node][source.port]
            else:
                x = source.to(device).reshape(-1, 1, 1).expand(source.numel(), ctx.height, ctx.width)
            maps[name] = OUTPUTS[name].finalise(x)
        normal = self.outputs.get("normal")
        if isinstance(normal, Ref):
            maps["normal"] = OUTPUTS["normal"].finalise(results[normal.node][normal.port])
        elif "height" in self.outputs:
            maps["normal"] = normal_from_height(ctx, maps["height"])
        else:
            maps["normal"] = flat_normal(ctx)
        return {k: maps[k] for k in outputs}


def _constant(output: str, raw: Any) -> torch.Tensor:
    if OUTPUTS[output].channels == 3:
        return torch.tensor(parse_color(raw))
    if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not 0.0 <= raw <= 1.0:
        raise ParamError(f"must be a number in [0, 1] or a node reference, got {raw!r}")
    return torch.tensor([float(raw)])


# ------------------------------------------------------------------------------------------ loading
def read_graph_file(path: Path) -> dict[str, Any]:
    """The raw mapping of a YAML or JSON graph file (one-line errors for unreadable files)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise GraphError(f"{path}: cannot read the material graph ({exc})") from None
    try:
        if path.suffix == ".json":
            data = json.loads(text)
        else:
            import yaml

            data = yaml.safe_load(text)
    except json.JSONDecodeError as exc:
        raise GraphError(f"{path}: not valid JSON (line {exc.lineno}: {exc.msg}); fix the graph file") from None
    except Exception as exc:  # yaml.YAMLError and its subclasses
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise GraphError(f"{path}: not valid YAML{where}: {getattr(exc, 'problem', exc)}; fix the graph file") from None
    if not isinstance(data, dict):
        raise GraphError(f"{path}: a material graph is a mapping with 'nodes' and 'outputs'")
    return data


def load_graph(path: Path, node_types: Mapping[str, NodeType]) -> ProceduralMaterial:
    """Load and validate one graph file."""
    path = Path(path)
    return parse_graph(read_graph_file(path), node_types, source=str(path), default_name=path.stem)


def parse_graph(
    data: Mapping[str, Any], node_types: Mapping[str, NodeType], *, source: str = "<graph>", default_name: str = "graph"
) -> ProceduralMaterial:
    """Validate a graph mapping (see the module docstring) into a :class:`ProceduralMaterial`."""

    def fail(message: str) -> GraphError:
        return GraphError(f"{source}: {message}")

    unknown = sorted(set(data) - set(_TOP_KEYS))
    if unknown:
        raise fail(f"unknown key(s) {', '.join(map(str, unknown))}; a graph has {', '.join(_TOP_KEYS)}")
    name = data.get("name", default_name)
    if not isinstance(name, str) or not _NAME.match(name):
        raise fail(f"name must be letters, digits and '_', got {name!r}")
    for key in ("category", "description"):
        if not isinstance(data.get(key, ""), str):
            raise fail(f"{key} must be a string")
    tags = data.get("tags", [])
    if not isinstance(tags, list) or not all(isinstance(t, str) for t in tags):
        raise fail("tags must be a list of strings")
    tile_size = data.get("tile_size", 1.0)
    if isinstance(tile_size, bool) or not isinstance(tile_size, (int, float)) or tile_size <= 0:
        raise fail(f"tile_size must be a positive number of metres, got {tile_size!r}")
    raw_nodes = data.get("nodes")
    if not isinstance(raw_nodes, dict) or not raw_nodes:
        raise fail("'nodes' must be a non-empty mapping of node name -> {type, params, inputs}")

    nodes: dict[str, NodeSpec] = {}
    for node_name, raw in raw_nodes.items():
        nodes[str(node_name)] = _parse_node(str(node_name), raw, node_types, fail)
    for spec in nodes.values():
        spec.inputs = {
            slot: _check_ref(ref, nodes, fail, f"node '{spec.name}' ({spec.type.name}): input '{slot}'")
            for slot, ref in spec.inputs.items()
        }

    raw_outputs = data.get("outputs")
    if not isinstance(raw_outputs, dict) or "base_color" not in raw_outputs:
        raise fail(f"'outputs' must be a mapping with at least base_color (outputs: {', '.join(OUTPUTS)})")
    outputs: dict[str, Ref | torch.Tensor] = {}
    for out_name, raw in raw_outputs.items():
        if out_name not in OUTPUTS:
            raise fail(f"outputs: unknown output '{out_name}'; known: {', '.join(OUTPUTS)}")
        where = f"outputs: {out_name}"
        if isinstance(raw, str) and not raw.startswith("#"):
            ref = _check_ref(_parse_ref(raw, fail, where), nodes, fail, where)
            port_is_normal = ref.port in nodes[ref.node].type.normal_ports
            if (out_name == "normal") != port_is_normal:
                want = "a normal map (height_to_normal)" if out_name == "normal" else "a [0, 1] map, not a normal map"
                raise fail(f"{where}: '{raw}' must be {want}")
            outputs[out_name] = ref
        elif out_name == "normal":
            raise fail(f"{where}: must name a node (height_to_normal); omit it to derive the normal from the height")
        else:
            try:
                outputs[out_name] = _constant(out_name, raw)
            except ParamError as exc:
                raise fail(f"{where}: {exc}") from None

    used: dict[str, set[str]] = {name: set() for name in nodes}
    for ref in [r for spec in nodes.values() for r in spec.inputs.values()] + [
        r for r in outputs.values() if isinstance(r, Ref)
    ]:
        used[ref.node].add(ref.port)
    for spec in nodes.values():
        if spec.type.inert is not None:
            for key in spec.type.inert(spec.params, used[spec.name]):
                if isinstance(spec.params.get(key), Bound):
                    spec.params[key] = spec.params[key].frozen()
    order = _topological(nodes, fail)
    needed = _needed(nodes, [r for r in outputs.values() if isinstance(r, Ref)])
    ordered = {n: nodes[n] for n in order if n in needed}
    return ProceduralMaterial(
        name=name,
        category=data.get("category", ""),
        description=data.get("description", ""),
        tags=list(tags),
        nodes=ordered,
        outputs=outputs,
        tile_size=float(tile_size),
        source=source,
    )


def _parse_node(name: str, raw: Any, node_types: Mapping[str, NodeType], fail: Any) -> NodeSpec:
    if not _NAME.match(name):
        raise fail(f"node name '{name}' must be letters, digits and '_' (no dots)")
    if not isinstance(raw, dict):
        raise fail(f"node '{name}' must be a mapping with 'type' (and 'params', 'inputs')")
    unknown = sorted(set(raw) - set(_NODE_KEYS))
    if unknown:
        raise fail(f"node '{name}': unknown key(s) {', '.join(map(str, unknown))}; a node has {', '.join(_NODE_KEYS)}")
    type_name = raw.get("type")
    if type_name not in node_types:
        raise fail(f"node '{name}': unknown type {type_name!r}; known: {', '.join(sorted(node_types))}")
    node_type = node_types[str(type_name)]
    where = f"node '{name}' ({type_name})"
    raw_params = _field(raw, "params", "a mapping", "parameter", node_type.params, "(none)", where, fail)
    params: dict[str, Any] = {}
    for key, spec in node_type.params.items():
        try:
            if key in raw_params:
                params[key] = spec.parse(raw_params[key])
            else:
                params[key] = spec.default_bound() if isinstance(spec, Continuous) else spec.default  # type: ignore[attr-defined]  # every discrete spec has one
        except ParamError as exc:
            raise fail(f"{where}: parameter '{key}': {exc}") from None
    if node_type.check is not None:
        problem = node_type.check(params)
        if problem:
            raise fail(f"{where}: {problem}")
    raw_inputs = _field(
        raw,
        "inputs",
        "a mapping of input -> node[.port]",
        "input",
        node_type.inputs,
        "(none: a generator)",
        where,
        fail,
    )
    inputs: dict[str, Ref] = {}
    for slot, declared in node_type.inputs.items():
        if slot in raw_inputs:
            inputs[slot] = _parse_ref(raw_inputs[slot], fail, f"{where}: input '{slot}'")
        elif declared.required:
            raise fail(f"{where}: input '{slot}' is not connected; set inputs: {{{slot}: NODE}}")
    return NodeSpec(name, node_type, params, inputs)


def _field(
    raw: Mapping[str, Any],
    field: str,
    shape: str,
    noun: str,
    known: Mapping[str, Any],
    none: str,
    where: str,
    fail: Any,
) -> dict[str, Any]:
    """A node's ``field`` mapping (empty when absent), refusing any other shape and any key not in ``known``."""
    value = raw.get(field) or {}
    if not isinstance(value, dict):
        raise fail(f"{where}: '{field}' must be {shape}")
    unknown = sorted(set(value) - set(known))
    if unknown:
        raise fail(f"{where}: unknown {noun}(s) {', '.join(map(str, unknown))}; known: {', '.join(known) or none}")
    return value


def _parse_ref(raw: Any, fail: Any, where: str) -> Ref:
    if not isinstance(raw, str) or not raw:
        raise fail(f"{where}: must be a node name or node.port, got {raw!r}")
    node, _, port = raw.partition(".")
    return Ref(node, port)


def _check_ref(ref: Ref, nodes: Mapping[str, NodeSpec], fail: Any, where: str) -> Ref:
    """``ref`` with its port resolved (a bare node name means its first output)."""
    if ref.node not in nodes:
        raise fail(f"{where}: no node named '{ref.node}'; nodes: {', '.join(nodes)}")
    ports = nodes[ref.node].type.outputs
    if not ref.port:
        return Ref(ref.node, ports[0])
    if ref.port not in ports:
        raise fail(
            f"{where}: node '{ref.node}' ({nodes[ref.node].type.name}) has no output '{ref.port}'; "
            f"outputs: {', '.join(ports)}"
        )
    return ref


def _topological(nodes: Mapping[str, NodeSpec], fail: Any) -> list[str]:
    order: list[str] = []
    state: dict[str, int] = {}

    def visit(name: str, path: list[str]) -> None:
        if state.get(name) == 2:
            return
        if state.get(name) == 1:
            cycle = path[path.index(name) :] + [name]
            raise fail(f"node '{name}': the edges form a cycle ({' -> '.join(cycle)})")
        state[name] = 1
        for ref in nodes[name].inputs.values():
            visit(ref.node, path + [name])
        state[name] = 2
        order.append(name)

    for name in nodes:
        visit(name, [])
    return order


def _needed(nodes: Mapping[str, NodeSpec], refs: list[Ref]) -> set[str]:
    needed: set[str] = set()
    stack = [r.node for r in refs]
    while stack:
        name = stack.pop()
        if name not in needed:
            needed.add(name)
            stack.extend(r.node for r in nodes[name].inputs.values())
    return needed
