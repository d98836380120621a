"""One home per setting: a schema declares each key's type, range and meaning (``setting(doc=...)``), the shipped
YAML holds its value, and nothing else does. Every key of every registered stage, implementation and settings schema
has a value in the shipped config (none is left to a code default) and a meaning; :func:`reference` renders a node
from the two."""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import MISSING

from psdr_room_core.engine import shipped
from psdr_room_core.engine.cli import compose_config
from psdr_room_core.engine.dag import Pipeline
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.run import resolve_config
from psdr_room_core.engine.settings import entries, reference, setting
from psdr_room_core.method.stages.settings import PlaceObjects

CONF = Path(__file__).resolve().parents[1] / "conf"


def _configs(registry: Registry) -> Iterator[dict[str, Any]]:
    """The shipped config, then one with each implementation choice it does not already hold."""
    default = resolve_config(compose_config(["image=photo.jpg"]))
    yield default
    for capability in registry.capabilities:
        for option in sorted(path.stem for path in (CONF / capability).glob("*.yaml")):
            if option not in (default.get(capability) or {}):
                yield resolve_config(compose_config(["image=photo.jpg", f"{capability}={option}"]))


def _nodes(data: dict[str, Any], registry: Registry) -> Iterator[tuple[str, type, Mapping[str, Any]]]:
    """(key, schema, values) of every node of a resolved config that a registered schema declares."""
    for node in Pipeline.from_config(data).nodes:
        schema = registry.stages[node.function].params
        assert schema is not None, node.name
        yield node.name, schema, {k: v for k, v in node.params.items() if not k.startswith("_")}
    for capability in registry.capabilities:
        for name, values in (data.get(capability) or {}).items():
            implementation = registry.implementations.get((capability, str(name)))
            if implementation is not None and implementation.params is not None:
                yield f"{capability}.{name}", implementation.params, values or {}
    for name, schema in registry.settings.items():
        if schema is not None:
            yield name, schema, data[name]


def _schemas(schema: type) -> Iterator[type]:
    yield schema
    for field in dataclasses.fields(schema):
        for candidate in (hint := typing.get_type_hints(schema)[field.name], *typing.get_args(hint)):
            if isinstance(candidate, type) and dataclasses.is_dataclass(candidate):
                yield from _schemas(candidate)


def test_every_key_has_a_shipped_value_and_a_meaning() -> None:
    registry = plugin_system().registry
    problems: dict[str, str] = {}
    for data in _configs(registry):
        for where, schema, values in _nodes(data, registry):
            for entry in entries(schema, values):
                key = f"{where}.{entry.key}"
                if entry.value is MISSING:
                    problems[key] = "has no value in the shipped config"
                elif not entry.field.metadata.get("doc"):
                    problems[key] = f"has no doc in {schema.__qualname__}'s schema"
    assert not problems, "\n".join(f"{key} {problem}" for key, problem in sorted(problems.items()))


def test_no_schema_field_carries_a_code_default() -> None:
    registry = plugin_system().registry
    declared = [stage.params for stage in registry.stages.values()]
    declared += [implementation.params for implementation in registry.implementations.values()]
    declared += list(registry.settings.values())
    defaults = {
        f"{schema.__qualname__}.{field.name}"
        for top in declared
        if top is not None
        for schema in _schemas(top)
        for field in dataclasses.fields(schema)
        if field.default not in (MISSING, dataclasses.MISSING) or field.default_factory is not dataclasses.MISSING
    }
    assert not defaults


@dataclass
class Inner:
    size: int = setting(ge=8, doc="Side, pixels.")


@dataclass
class Outer:
    ratio: float = setting(gt=0, lt=1, doc="A share.")
    names: list[str] = setting(doc="Categories.")
    parts: dict[str, list[str]] = setting(doc="Category → its parts.")
    inner: Inner = setting(doc="The inner node.")
    maybe: Inner | None = setting(doc="Or nothing.")
    flag: bool = setting(doc="")


def test_reference_renders_each_key_with_its_value_and_meaning() -> None:
    values = {
        "ratio": 0.5,
        "names": ["bed", "sofa"],
        "parts": {"bed": ["pillow"]},
        "inner": {"size": 16},
        "maybe": None,
    }
    assert reference(Outer, values) == "\n".join(
        [
            "ratio = 0.5  # A share.",
            "names = [bed, sofa]  # Categories.",
            "parts = {bed: [pillow]}  # Category → its parts.",
            "inner:  # The inner node.",
            "  size = 16  # Side, pixels.",
            "maybe = null  # Or nothing.",
            "flag = ???",
        ]
    )
    lines = reference(PlaceObjects, shipped.node("place_objects")).splitlines()
    assert "search:  # The view search (:mod:`psdr_room_core.method.view_search`)." in lines
    assert "  n_yaw = 12  # Rotations about the vertical axis swept (init=radius too)." in lines
    assert "  grounded = [chair, table, sofa, bed, desk, rug, plant, cabinet, shelf]" in [
        line.partition("  #")[0] for line in lines
    ]
