"""``psdr-room --settings NODE``: what each setting of a stage or an implementation means, with its value in the
composed config (the meanings are the schemas' ``doc``, :func:`.settings.reference`)."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from .choice import AUTO
from .errors import PsdrRoomError
from .settings import did_you_mean, reference
from .stage_config import stage_nodes

if TYPE_CHECKING:
    from .registry import Registry

CHOICE_KEYS = ("impl", AUTO)
"""Keys of a capability's group that choose an implementation rather than configure one."""


def schemas(data: Mapping[str, Any], registry: Registry) -> dict[str, tuple[type, Mapping[str, Any]]]:
    """Node path → (its schema, its values) for every stage node, every configured implementation and every
    plugin's declared settings of the resolved config ``data`` that has a schema."""
    found: dict[str, tuple[type, Mapping[str, Any]]] = {}
    for node in stage_nodes(data):
        params = registry.stage(node.function).params
        if params is not None:
            found[node.name] = (params, node.params)
    for capability in registry.capabilities:
        group = data.get(capability)
        for name, values in (group or {}).items() if isinstance(group, Mapping) else ():
            if name in CHOICE_KEYS or (capability, name) not in registry.implementations:
                continue
            params = registry.implementation(capability, name).params
            if params is not None and isinstance(values, Mapping):
                found[f"{capability}.{name}"] = (params, values)
    for name, params in registry.settings.items():
        if params is not None and isinstance(data.get(name), Mapping):
            found[name] = (params, data[name])
    return found


def text(name: str, data: Mapping[str, Any], registry: Registry) -> str:
    """The reference of node ``name``: its schema's first docstring line, then a line per setting."""
    known = schemas(data, registry)
    if name not in known:
        raise PsdrRoomError(
            f"--settings {name}: no settings node of that name{did_you_mean(name, known)}; nodes: "
            f"{', '.join(sorted(known))}"
        )
    schema, values = known[name]
    summary = _first_sentence(schema.__doc__ or "")
    header = f"{name}:" + (f"  # {summary}" if summary and not summary.startswith(schema.__name__ + "(") else "")
    body = reference(schema, values)
    return "\n".join([header, *("  " + line for line in body.splitlines())])


def _first_sentence(doc: str) -> str:
    """The first sentence of a docstring's first paragraph, on one line (it ends at a full stop before a capital:
    not at "eq. 3")."""
    paragraph = " ".join(doc.strip().split("\n\n")[0].split())
    end = re.search(r"\.\s+(?=[A-Z])", paragraph)
    return paragraph if end is None else paragraph[: end.start() + 1]
