"""Typed, range-checked settings: every stage and implementation declares its parameters as a dataclass.

A schema is a Hydra/OmegaConf structured config: field types say what a value must be (``int``,
``float``, ``bool``, ``str``, ``list[float]``, ``Optional[str]``, nested dataclasses), and :func:`setting`
adds what a type cannot (ranges, allowed words, list lengths) and what the key means (``doc``). The schema is
the one home of a key's type, range and meaning; the shipped YAML in ``conf/`` is the one home of its value (a
schema field has no default, except a key a config may leave out). :func:`reference` renders a node's keys,
values and meanings from the two. Plugins pass their schemas to ``registry.add_stage(..., params=S)`` and
``registry.add_implementation(..., params=S)``; :func:`check_config` checks the composed config against every
registered schema before any stage runs, and the first problem ends the run in one line naming the key, the
value and what is allowed::

    room_fit.iterations=-3 is out of range; allowed: an integer >= 1
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import operator
import types
import typing
from collections.abc import Iterable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

from omegaconf import MISSING, OmegaConf
from omegaconf.errors import ConfigKeyError, MissingMandatoryValue, ValidationError

from .bounded import excerpt
from .choice import AUTO, with_settings
from .errors import PsdrRoomError
from .stage_config import StageNode

if TYPE_CHECKING:
    from .registry import Registry


ENGINE_KEYS = ("image", "seed", "cache", "cache_dir", "run", "inject")
"""Top-level config keys the engine itself reads (besides stage nodes, capability groups and the nodes plugins
declare with ``registry.add_settings``)."""
RUN_KEYS = ("only", "from", "until", "threads")
"""The keys of the ``run`` node."""


@dataclasses.dataclass
class NoSettings:
    """The schema of a stage or implementation that takes no parameters."""


RULES = ("ge", "gt", "le", "lt", "choices", "length")
"""The checks :func:`setting` may put on a field (its ``metadata`` also holds the ``doc``)."""


def setting(
    default: Any = MISSING,
    *,
    doc: str = "",
    ge: float | None = None,
    gt: float | None = None,
    le: float | None = None,
    lt: float | None = None,
    choices: tuple[str, ...] | None = None,
    length: int | None = None,
) -> Any:
    """A schema field with what its key means (``doc``: units, and what raising or lowering it does), bounds
    (applied to a number, or to every number of a list), allowed words (``choices``) or a list ``length``;
    ``default`` only for a key a config may leave out (its ``doc`` says why)."""
    rules = {k: v for k, v in dict(ge=ge, gt=gt, le=le, lt=lt, choices=choices, length=length).items() if v is not None}
    metadata = {**rules, "doc": doc}
    if isinstance(default, (list, dict)) or dataclasses.is_dataclass(default):  # each instance its own copy
        return dataclasses.field(default_factory=lambda: copy.deepcopy(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


@dataclasses.dataclass(frozen=True)
class Entry:
    """One key of a config node, as :func:`entries` walks it."""

    key: str
    """Its dotted path inside the node."""
    depth: int
    """How deep it is nested (0: a key of the node itself)."""
    field: dataclasses.Field[Any]
    """Its schema field (``field.metadata["doc"]``: what it means)."""
    value: Any
    """Its value in the node; :data:`~omegaconf.MISSING` where the node has none."""
    nested: bool
    """Whether it holds a nested schema's keys (the entries that follow, one level deeper)."""


def entries(schema: type, values: Mapping[str, Any] | None, *, prefix: str = "", depth: int = 0) -> Iterator[Entry]:
    """Every field of ``schema``, nested schemas' too (each after its parent), in declaration order, with its
    value in ``values`` (a resolved config node)."""
    hints = typing.get_type_hints(schema)
    for field in dataclasses.fields(schema):
        value = (values or {}).get(field.name, MISSING)
        nested = _dataclass_of(hints[field.name])
        key = f"{prefix}.{field.name}" if prefix else field.name
        opened = nested is not None and isinstance(value, Mapping)
        yield Entry(key, depth, field, value, opened)
        if opened and nested is not None:
            yield from entries(nested, value, prefix=key, depth=depth + 1)


def reference(schema: type, values: Mapping[str, Any]) -> str:
    """The reference of a config node: a line ``key = value  # what it means`` per key of ``schema`` (a nested
    schema's keys indented under a line ``key:  # what it means``), the values from ``values`` (the resolved
    node; ``???`` where it has none)."""
    lines = []
    for entry in entries(schema, values):
        doc = entry.field.metadata.get("doc", "")
        comment = f"  # {doc}" if doc else ""
        name = entry.key.rpartition(".")[2]
        shown = f"{name}:" if entry.nested else f"{name} = {_flow(entry.value)}"
        lines.append(f"{'  ' * entry.depth}{shown}{comment}")
    return "\n".join(lines)


def check_settings(schema: type, values: Mapping[str, Any], where: str) -> None:
    """Raise a one-line :class:`PsdrRoomError` unless ``values`` (the config node ``where``) fits ``schema``: its
    types, the bounds of each field (:func:`setting`), and the rules across fields that a schema's
    ``__post_init__`` checks (raising :class:`PsdrRoomError`; it runs on the values, after the bounds)."""
    try:
        merged = OmegaConf.merge(OmegaConf.structured(schema), dict(values))
        OmegaConf.to_container(merged, throw_on_missing=True)
    except ConfigKeyError as exc:
        parent, _, key = (exc.full_key or "?").rpartition(".")
        names = [f.name for f in dataclasses.fields(_schema_at(schema, parent))]
        raise PsdrRoomError(
            f"{_join(where, exc.full_key or '?')} is not a setting of {_join(where, parent)}"
            f"{did_you_mean(key, names)}; known: {', '.join(names) or '(none)'}"
        ) from None
    except MissingMandatoryValue as exc:
        raise PsdrRoomError(
            f"{_join(where, exc.full_key or '?')} has no value; set {_join(where, exc.full_key or '?')}=VALUE "
            "in the config (its schema requires it)"
        ) from None
    except ValidationError as exc:
        key = exc.full_key or "?"
        value = _value_at(values, key)
        reason = str(exc).splitlines()[0].replace(str(value), _show(value))  # OmegaConf's words quote the value
        raise PsdrRoomError(
            f"{_join(where, key)}={_show(value)} is invalid: {reason}; allowed: {_allowed(schema, key)}"
        ) from None
    _check_rules(schema, merged, where)
    OmegaConf.to_object(merged)  # the schemas' __post_init__ rules


def did_you_mean(word: str, known: Iterable[str]) -> str:
    """`` (did you mean X?)`` for the known name closest to a mistyped ``word``, else an empty string."""
    close = difflib.get_close_matches(word, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


def check_keys(data: Mapping[str, Any], nodes: list[StageNode], registry: Registry) -> None:
    """Refuse, in one line with a did-you-mean and the valid names, a top-level key that is neither the
    engine's, a stage node, a capability group nor a plugin's declared settings, and an unknown ``run.*`` key;
    check the declared settings against their schemas."""
    known = sorted({*ENGINE_KEYS, *(node.name for node in nodes), *registry.capabilities, *registry.settings})
    for key in data:
        if key not in known:
            raise PsdrRoomError(
                f"{key} is not a setting{did_you_mean(key, known)}; the settings are: {', '.join(known)}"
            )
    for key in data.get("run") or {}:
        if key not in RUN_KEYS:
            raise PsdrRoomError(
                f"run.{key} is not a setting of run{did_you_mean(key, RUN_KEYS)}; known: {', '.join(RUN_KEYS)}"
            )
    for name, schema in registry.settings.items():
        if schema is not None and isinstance(data.get(name), Mapping):
            check_settings(schema, data[name], name)


def check_config(data: Mapping[str, Any], nodes: list[StageNode], registry: Registry) -> None:
    """Check the top-level keys (:func:`check_keys`), every stage node of the pipeline (with its ``_uses_`` settings over the capability groups) and
    every implementation node of the capability groups (``<capability>.<name>``, in config order) against the schemas their plugins declared (those
    without one are not checked)."""
    check_keys(data, nodes, registry)
    for node in nodes:
        stage = registry.stages.get(node.function)
        if stage is not None and stage.params is not None:
            check_settings(stage.params, node.params, node.name)
        for capability, settings in node.uses.items():
            group = data.get(capability)
            for name, values in (with_settings(group, settings) if isinstance(group, Mapping) else {}).items():
                impl = registry.implementations.get((capability, str(name)))
                if impl is not None and impl.params is not None:
                    check_settings(impl.params, values or {}, f"{node.name}._uses_.{capability}")
    for capability in registry.capabilities:
        group = data.get(capability)
        if not isinstance(group, Mapping) or "impl" not in group:
            continue
        if group["impl"] == AUTO:
            order = (group.get(AUTO) or {}).get("order")
            if not isinstance(order, list) or not order or not all(isinstance(n, str) for n in order):
                raise PsdrRoomError(
                    f"{capability}.auto.order={_show(order)} is invalid; allowed: a non-empty "
                    f"list of {capability} implementation names"
                )
        for name, values in group.items():
            impl = registry.implementations.get((capability, str(name)))
            if impl is not None and impl.params is not None:
                check_settings(impl.params, values or {}, f"{capability}.{name}")


# ---------------------------------------------------------------------------------------------- helpers
def _check_rules(schema: type, node: Any, where: str) -> None:
    hints = typing.get_type_hints(schema)
    for field in dataclasses.fields(schema):
        value = node[field.name]
        key = _join(where, field.name)
        nested = _dataclass_of(hints[field.name])
        if nested is not None:
            if value is not None:
                _check_rules(nested, value, key)
            continue
        rules = {name: rule for name, rule in field.metadata.items() if name in RULES}
        if not rules or value is None:
            continue
        items = list(value) if OmegaConf.is_list(value) else [value]
        if "length" in rules and (not OmegaConf.is_list(value) or len(items) != rules["length"]):
            raise PsdrRoomError(f"{key}={_show(value)} is invalid; allowed: {_describe(hints[field.name], rules)}")
        for item in items:
            if not _obeys(item, rules):
                problem = "is not one of the choices" if "choices" in rules else "is out of range"
                raise PsdrRoomError(f"{key}={_show(value)} {problem}; allowed: {_describe(hints[field.name], rules)}")


def _dataclass_of(hint: Any) -> type | None:
    """The dataclass of a ``Schema`` or ``Optional[Schema]`` field, else None."""
    for candidate in (hint, *typing.get_args(hint)):
        if isinstance(candidate, type) and dataclasses.is_dataclass(candidate):
            return candidate
    return None


def _obeys(value: Any, rules: Mapping[str, Any]) -> bool:
    if "choices" in rules:
        return value in rules["choices"]
    tests = {"ge": operator.ge, "gt": operator.gt, "le": operator.le, "lt": operator.lt}
    return all(test(value, rules[name]) for name, test in tests.items() if name in rules)


def _describe(hint: Any, rules: Mapping[str, Any]) -> str:
    if "choices" in rules:
        return "one of " + ", ".join(rules["choices"])
    words = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<"}
    bounds = " and ".join(f"{words[k]} {rules[k]:g}" for k in words if k in rules)
    return " ".join(p for p in (_type_name(hint), bounds) if p) + (
        f", {rules['length']} of them" if "length" in rules else ""
    )


def _type_name(hint: Any) -> str:
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    origin = typing.get_origin(hint)
    if origin in (list, tuple):
        return f"a list of {_type_name(args[0]).removeprefix('a ').removeprefix('an ')}s" if args else "a list"
    if origin in (typing.Union, types.UnionType) and len(args) == 1:  # Optional[X] or X | None
        return f"null or {_type_name(args[0])}"
    return {int: "an integer", float: "a number", bool: "true or false", str: "a string"}.get(hint, "a value")


def _allowed(schema: type, key: str) -> str:
    parent, _, name = key.split("[")[0].rpartition(".")
    owner = _schema_at(schema, parent)
    fields = {f.name: f for f in dataclasses.fields(owner)}
    if name not in fields:
        return "see the schema"
    rules = {rule: bound for rule, bound in fields[name].metadata.items() if rule in RULES}
    return _describe(typing.get_type_hints(owner)[name], rules)


def _schema_at(schema: type, path: str) -> type:
    for part in [p for p in path.split(".") if p]:
        nested = _dataclass_of(typing.get_type_hints(schema).get(part))
        if nested is None:
            return schema
        schema = nested
    return schema


def _value_at(values: Mapping[str, Any], key: str) -> Any:
    value: Any = values
    for part in key.replace("]", "").replace("[", ".").split("."):
        try:
            value = value[int(part)] if isinstance(value, list) else value[part]
        except (KeyError, IndexError, ValueError, TypeError):
            return "?"
    return value


def _show(value: Any) -> str:
    """``value`` as an error line shows it: at most :data:`~.bounded.ECHO` characters."""
    if OmegaConf.is_config(value):
        value = OmegaConf.to_container(value)
    return "null" if value is None else excerpt(str(value))


def _flow(value: Any) -> str:
    """``value`` as a YAML flow value: ``null``, ``true``, ``[1, 2]``, ``{bed: [pillow]}``; ``???``: none."""
    if value is MISSING:
        return "???"
    if value is None or isinstance(value, bool):
        return {None: "null", True: "true", False: "false"}[value]
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{key}: {_flow(item)}" for key, item in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_flow(item) for item in value) + "]"
    return str(value)


def _join(where: str, key: str) -> str:
    return f"{where}.{key}" if key else where
