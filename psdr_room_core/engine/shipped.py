"""The shipped config as tests, benchmarks and notebooks read it: ``conf/config.yaml`` composed with Hydra's
compose API, as the command line composes it, never copied. ``node("place_objects.search")`` is that node's resolved values,
``settings(SearchParams, "place_objects.search")`` the same as its schema's object, ``arguments(schema, key)`` the
keyword arguments the engine constructs an implementation with; ``overrides`` as on the command line."""

from __future__ import annotations

import copy
import dataclasses
import functools
from typing import Any, TypeVar

from omegaconf import OmegaConf

from .cli import compose_config
from .stage_config import typed_settings

SettingsT = TypeVar("SettingsT")


@functools.cache
def _composed(overrides: tuple[str, ...]) -> Any:
    return compose_config(list(overrides))


@functools.cache
def _resolved(key: str, overrides: tuple[str, ...]) -> Any:
    value = OmegaConf.select(_composed(overrides), key, throw_on_missing=True)
    if value is None:
        raise KeyError(f"the shipped config has no {key}")
    return OmegaConf.to_container(value, resolve=True) if OmegaConf.is_config(value) else value


def node(key: str, *overrides: str) -> Any:
    """The resolved value at the dotted ``key`` of the shipped config with ``overrides`` (a stage node without
    its ``_stage_``, ``_inputs_``, ... keys); the caller's own copy."""
    value = copy.deepcopy(_resolved(key, overrides))
    if isinstance(value, dict):
        return {name: item for name, item in value.items() if not str(name).startswith("_")}
    return value


def settings(schema: type[SettingsT], key: str, *overrides: str) -> SettingsT:
    """The node at ``key`` as an instance of ``schema``, as a stage reads its settings."""
    return typed_settings(schema, node(key, *overrides))


def arguments(schema: type, key: str, *overrides: str) -> dict[str, Any]:
    """The keyword arguments of the implementation whose node is ``key``: its settings, field by field."""
    typed: Any = settings(schema, key, *overrides)
    return {field.name: getattr(typed, field.name) for field in dataclasses.fields(typed)}
