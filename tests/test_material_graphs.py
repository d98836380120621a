"""material_graph=torch_graph: the graph format and its validation, the library, plugins adding graphs and node
types, and fitting a graph's parameters to a target made by the same graph (the appearance stage's job)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch
import yaml
from test_material_nodes import seam_ratio

from conftest import REPO
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.plugins import load_plugins
from psdr_room_core.engine.registry import Origin
from psdr_room_plugins.material_graph.graph import GraphError, load_graph, parse_graph
from psdr_room_plugins.material_graph.library import TorchGraphLibrary
from psdr_room_plugins.material_graph.nodes import Input, NodeType, builtin_node_types
from psdr_room_plugins.material_graph.params import Float
from psdr_room_plugins.material_graph.thumbnails import shade
from psdr_room_plugins.texture.random_cnn import RandomCnnDescriptor

torch.set_num_threads(1)

LIBRARY = TorchGraphLibrary(use_plugins=False)
NODES = builtin_node_types()

GOOD = {
    "category": "test",
    "nodes": {
        "bricks": {"type": "tiles", "params": {"cols": 2, "rows": 4, "gap": {"value": 0.1, "range": [0.05, 0.2]}}},
        "colour": {
            "type": "gradient_map",
            "inputs": {"input": "bricks.random"},
            "params": {"ramp": [[0.0, "#803020"], [1.0, "#c06040"]]},
        },
        "normal": {"type": "height_to_normal", "inputs": {"height": "bricks.height"}},
    },
    "outputs": {"base_color": "colour", "roughness": 0.8, "height": "bricks.height", "normal": "normal"},
}


def broken(**changes: object) -> dict:
    """GOOD with nested keys replaced (``"nodes.bricks.params.cols": 0``); a value of None deletes the key."""
    data = json.loads(json.dumps(GOOD))
    for path, value in changes.items():
        *parents, last = path.split("/")
        target = data
        for key in parents:
            target = target[key]
        if value is None:
            del target[last]
        else:
            target[last] = value
    return data


# ------------------------------------------------------------------------------------------ format
def test_a_valid_graph_evaluates_to_the_five_maps() -> None:
    material = parse_graph(GOOD, NODES, source="good.yaml")
    params = material.parameters()
    assert set(params) == {
        "bricks.offset",
        "bricks.random_offset",
        "bricks.gap",
        "bricks.bevel",
        "bricks.height_variation",
        "colour.ramp",
        "normal.strength",
    }
    assert all(t.requires_grad and t.is_leaf for t in params.values())
    maps = material.evaluate((48, 64), params)
    assert {k: tuple(v.shape) for k, v in maps.items()} == {
        "base_color": (3, 48, 64),
        "roughness": (1, 48, 64),
        "metallic": (1, 48, 64),
        "height": (1, 48, 64),
        "normal": (3, 48, 64),
    }
    assert float(maps["roughness"].mean()) == pytest.approx(0.8) and float(maps["metallic"].max()) == 0.0
    assert 0.05 <= float(material.values(params)["bricks.gap"].detach()) <= 0.2
    maps["base_color"].sum().backward()
    assert params["colour.ramp"].grad is not None and float(params["colour.ramp"].grad.abs().sum()) > 0


@pytest.mark.parametrize(
    "change, message",
    [
        ({"nodes/bricks/type": "bricks"}, r"node 'bricks': unknown type 'bricks'; known: .*tiles"),
        ({"nodes/bricks/params/colums": 3}, r"node 'bricks' \(tiles\): unknown parameter\(s\) colums; known: cols"),
        (
            {"nodes/bricks/params/cols": 0},
            r"node 'bricks' \(tiles\): parameter 'cols': must be an integer in \[1, 256\]",
        ),
        (
            {"nodes/bricks/params/gap": 0.9},
            r"node 'bricks' \(tiles\): parameter 'gap': value 0.9 is outside \[0.0, 0.4\]",
        ),
        (
            {"nodes/bricks/params/gap": {"value": 0.1, "range": [0.0, 0.9]}},
            r"parameter 'gap': range .* reaches outside",
        ),
        ({"nodes/bricks/params/rows": 3}, r"node 'bricks' \(tiles\): rows must be even when offset"),
        ({"nodes/colour/inputs": {}}, r"node 'colour' \(gradient_map\): input 'input' is not connected"),
        (
            {"nodes/colour/inputs": {"input": "brick.random"}},
            r"node 'colour' \(gradient_map\): input 'input': no node named 'brick'",
        ),
        (
            {"nodes/colour/inputs": {"input": "bricks.rnd"}},
            r"input 'input': node 'bricks' \(tiles\) has no output 'rnd'; outputs: height, mask, random",
        ),
        (
            {"nodes/colour/inputs": {"img": "bricks"}},
            r"node 'colour' \(gradient_map\): unknown input\(s\) img; known: input",
        ),
        (
            {"nodes/colour/params/ramp": [[0.0, "red"], [1.0, "#ffffff"]]},
            r"parameter 'ramp': colour 'red' is not '#rrggbb'",
        ),
        ({"nodes/colour/colour": 1}, r"node 'colour': unknown key\(s\) colour"),
        (
            {"nodes/bricks/inputs": {"seed": "colour"}},
            r"node 'bricks' \(tiles\): unknown input\(s\) seed; known: \(none: a generator\)",
        ),
        ({"outputs/base_color": None}, r"'outputs' must be a mapping with at least base_color"),
        ({"outputs/albedo": "colour"}, r"outputs: unknown output 'albedo'; known: base_color"),
        ({"outputs/roughness": 1.5}, r"outputs: roughness: must be a number in \[0, 1\]"),
        ({"outputs/normal": "bricks.height"}, r"outputs: normal: 'bricks.height' must be a normal map"),
        ({"outputs/height": "normal"}, r"outputs: height: 'normal' must be a \[0, 1\] map, not a normal map"),
        ({"nodes/bricks.x": {"type": "uniform"}}, r"node name 'bricks.x' must be letters"),
        ({"tile_size": -1}, r"tile_size must be a positive number"),
        ({"colour": "red"}, r"unknown key\(s\) colour; a graph has name, category"),
    ],
)
def test_invalid_graphs_name_the_node_and_field(change: dict, message: str) -> None:
    with pytest.raises(GraphError, match=message) as info:
        parse_graph(broken(**change), NODES, source="my_graph.yaml")
    text = str(info.value)
    assert text.startswith("my_graph.yaml: ") and "\n" not in text


def test_cycles_are_reported_with_the_loop() -> None:
    data = broken(
        **{
            "nodes/blurred": {"type": "blur", "inputs": {"input": "mixed"}},
            "nodes/mixed": {"type": "blend", "inputs": {"background": "colour", "foreground": "blurred"}},
            "outputs/base_color": "mixed",
        }
    )
    with pytest.raises(GraphError, match=r"cycle \((blurred -> mixed -> blurred|mixed -> blurred -> mixed)\)"):
        parse_graph(data, NODES, source="loop.yaml")


def test_graph_files_in_yaml_and_json(tmp_path: Path) -> None:
    (tmp_path / "a.json").write_text(json.dumps(GOOD))
    (tmp_path / "b.yaml").write_text(yaml.safe_dump(GOOD))
    a, b = load_graph(tmp_path / "a.json", NODES), load_graph(tmp_path / "b.yaml", NODES)
    assert (a.name, b.name) == ("a", "b")
    assert torch.equal(a.evaluate(32)["base_color"], b.evaluate(32)["base_color"])
    (tmp_path / "bad.yaml").write_text("nodes: {a: [\n")
    with pytest.raises(GraphError, match=r"bad.yaml: not valid YAML"):
        load_graph(tmp_path / "bad.yaml", NODES)
    (tmp_path / "bad.json").write_text('{"nodes": }')
    with pytest.raises(GraphError, match=r"bad.json: not valid JSON \(line 1"):
        load_graph(tmp_path / "bad.json", NODES)


def test_fixed_parameters_are_not_optimised_and_values_round_trip() -> None:
    data = broken(**{"nodes/bricks/params/bevel": {"value": 0.1, "fixed": True}})
    material = parse_graph(data, NODES)
    assert "bricks.bevel" not in material.parameters() and "bricks.bevel" in material.bounds
    u = material.unconstrained({"bricks.gap": 0.15})
    assert float(material.values(u)["bricks.gap"]) == pytest.approx(0.15, abs=1e-5)
    with pytest.raises(GraphError, match="no continuous parameter 'bricks.cols'"):
        material.unconstrained({"bricks.cols": 3})


# ----------------------------------------------------------------------------------------- library
def test_library_covers_the_rooms_materials() -> None:
    names = LIBRARY.names()
    assert len(names) >= 40
    for wanted in (
        "oak_planks",
        "walnut_planks",
        "herringbone_oak",
        "parquet_basketweave",
        "oak_wood",
        "walnut_wood",
        "painted_wood_white",
        "white_square_tiles",
        "subway_tiles",
        "hex_tiles",
        "white_marble",
        "terrazzo",
        "concrete",
        "white_plaster",
        "beige_paint",
        "wallpaper_stripes",
        "wallpaper_damask",
        "red_brick",
        "linen_weave",
        "velvet",
        "denim_twill",
        "chunky_knit",
        "brown_leather",
        "plush_carpet",
        "rug_diamond",
        "brushed_steel",
        "painted_metal_black",
        "clear_glass",
    ):
        assert wanted in names
    categories = {m.category for m in LIBRARY.materials()}
    assert {
        "wood floor",
        "wood furniture",
        "tiles",
        "stone",
        "wall",
        "wallpaper",
        "brick",
        "fabric",
        "knit",
        "leather",
        "carpet",
        "rug",
        "metal",
        "glass",
    } <= categories
    assert all(m.description and m.tags for m in LIBRARY.materials())


@pytest.mark.parametrize("name", LIBRARY.names())
def test_library_graph_evaluates_in_range_tiles_and_passes_gradients(name: str) -> None:
    material = LIBRARY.material(name)
    params = material.parameters()
    maps = material.evaluate(256, params)  # fine enough for every octave the graphs use
    for key, x in maps.items():
        x = x.detach()
        assert torch.isfinite(x).all()
        if key == "normal":
            assert torch.allclose(torch.linalg.vector_norm(x, dim=0), torch.ones(256, 256), atol=1e-4)
        else:
            assert float(x.min()) >= 0.0 and float(x.max()) <= 1.0
        for dim in (-1, -2):
            seam, interior = seam_ratio(x, dim)
            assert seam <= 1.5 * interior + 1e-3, f"{name}.{key} has a seam ({seam:.4f} vs {interior:.4f})"
    if params:
        generator = torch.Generator().manual_seed(0)
        loss = sum((x * torch.rand(x.shape, generator=generator)).sum() for x in maps.values())
        loss.backward()
        reached = [k for k, t in params.items() if t.grad is not None and float(t.grad.abs().sum()) > 0]
        assert all(torch.isfinite(t.grad).all() for t in params.values() if t.grad is not None)
        assert len(reached) == len(params), f"{name}: no gradient to {sorted(set(params) - set(reached))}"


def test_maps_look_alike_at_any_resolution() -> None:
    material = LIBRARY.material("red_brick")
    small, large = material.evaluate(64), material.evaluate(256)
    for key in ("base_color", "roughness"):
        assert torch.allclose(small[key].mean(dim=(1, 2)), large[key].mean(dim=(1, 2)), atol=0.03)


@pytest.mark.parametrize("name", ["herringbone_oak", "red_brick", "terrazzo"])
def test_fitting_parameters_recovers_a_target_made_by_the_same_graph(name: str) -> None:
    """The target: the graph shaded at other (random) parameter values. Adam on the unconstrained
    parameters from the graph's own values must cut the texture-descriptor loss by at least 80%."""
    material = LIBRARY.material(name)
    descriptor = RandomCnnDescriptor(size=None)
    start = material.parameters()
    generator = torch.Generator().manual_seed(0)
    with torch.no_grad():
        other = {k: v + torch.randn(v.shape, generator=generator) for k, v in start.items()}
        target = descriptor.describe(shade(material.evaluate(96, other)))
    optimiser = torch.optim.Adam(list(start.values()), lr=0.1)
    losses = []
    for _ in range(100):
        optimiser.zero_grad()
        loss = descriptor.distance(descriptor.describe(shade(material.evaluate(96, start))), target)
        loss.backward()
        optimiser.step()
        losses.append(float(loss.detach()))
    assert losses[-1] <= 0.2 * losses[0], f"{name}: loss {losses[0]:.4f} -> {losses[-1]:.4f}"


# ----------------------------------------------------------------------------------------- plugins
def _plugin(**hooks: object) -> SimpleNamespace:
    return SimpleNamespace(**{name: hookimpl(fn) for name, fn in hooks.items()})


def test_plugins_add_graphs_and_node_types(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    def noise_free(ctx, inputs, p):  # noqa: ANN001, ANN202 - a node function
        return (inputs["input"] * p["gain"]).clamp(0, 1)

    gain = NodeType(
        "gain", "filter", noise_free, {"gain": Float(0.0, 2.0, 1.0)}, {"input": Input(None)}, doc="multiply by a gain"
    )
    graph = broken(
        **{
            "nodes/brighter": {"type": "gain", "inputs": {"input": "colour"}, "params": {"gain": 1.2}},
            "outputs/base_color": "brighter",
        }
    )
    (tmp_path / "plugin_bricks.yaml").write_text(yaml.safe_dump(graph))
    (tmp_path / "oak_planks.yaml").write_text(yaml.safe_dump(GOOD))  # a name already taken: left out
    system = load_plugins(
        extra=[
            (
                _plugin(material_graphs=lambda: [str(tmp_path)], material_nodes=lambda: [gain]),
                Origin("extra_materials", "extra 1.0", "extra = extra"),
            )
        ]
    )
    assert not system.registry.failures
    monkeypatch.setattr("psdr_room_core.engine.plugins.plugin_system", lambda: system)
    library = TorchGraphLibrary()
    assert "gain" in library.node_types and "plugin_bricks" in library.names()
    assert library.material("oak_planks").category == "wood floor"
    assert "already defined" in caplog.text
    maps = library.material("plugin_bricks").evaluate(32)
    assert maps["base_color"].shape == (3, 32, 32)
    with pytest.raises(PsdrRoomError, match="unknown material 'nope'; known: .*plugin_bricks"):
        library.material("nope")


def test_registered_and_configured_like_every_capability() -> None:
    from psdr_room_core.method.capabilities import MaterialGraph, ProceduralMaterial

    assert isinstance(LIBRARY, MaterialGraph) and isinstance(LIBRARY.material("oak_planks"), ProceduralMaterial)
    registry = load_plugins().registry
    implementation = registry.implementation("material_graph", "torch_graph")
    conf = yaml.safe_load((REPO / "conf" / "material_graph" / "torch_graph.yaml").read_text())
    assert conf["impl"] == "torch_graph"
    library = implementation.factory(**conf["torch_graph"])
    assert library.names() == LIBRARY.names()
    with pytest.raises(PsdrRoomError, match="material graph directory not found"):
        implementation.factory(extra_dirs=["/nonexistent/graphs"])
