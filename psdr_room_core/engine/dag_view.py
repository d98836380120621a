"""The pipeline as a reader sees it (``psdr-room --dag``): every stage in run order with its inputs, outputs and
the implementation the config chooses for each capability it uses, as text or as a Mermaid flowchart."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .choice import AUTO, capability_group
from .graph import Pipeline
from .registry import Registry
from .stage_config import StageNode

FORMS = ("text", "mermaid")
"""What ``--dag=FORM`` may ask for; ``--dag`` alone is ``text``."""


def signature(node: StageNode) -> str:
    """``name(parameter, parameter=artifact, ...) -> artifact, ...``: each input by its function parameter, with
    the artifact that feeds it where the names differ, then the artifacts the stage produces."""
    inputs = ", ".join(p if p == a else f"{p}={a}" for p, a in node.inputs.items())
    return f"{node.name}({inputs}) -> {', '.join(node.outputs.values())}"


def implementations(node: StageNode, cfg: Mapping[str, Any], registry: Registry) -> dict[str, str]:
    """Capability → the implementation the config chooses for this stage (``auto`` with its order), with the
    settings the stage's ``_uses_`` gives it. A capability without its config group, or an implementation no plugin
    registers, is a one-line error (as in a run)."""
    chosen: dict[str, str] = {}
    for capability in registry.stage(node.function).uses:
        group = capability_group(cfg, node, capability)
        name = str(group["impl"])
        if name == AUTO:
            order = (group.get(AUTO) or {}).get("order") or []
            description = f"auto (the first usable of {', '.join(map(str, order))})"
        else:
            registry.implementation(capability, name)
            description = name
        settings = node.uses.get(capability)
        if settings:
            description += f" with {', '.join(f'{k}={v}' for k, v in settings.items())}"
        chosen[capability] = description
    return chosen


def text(pipeline: Pipeline, cfg: Mapping[str, Any], registry: Registry) -> str:
    """One line per stage in run order (:func:`signature`), its stage function where it is not its name and the
    implementations it uses indented under it; first the artifacts given with ``+inject.NAME=DIR``."""
    lines = [f"given: {name} (inject.{name})" for name in sorted(pipeline.provided)]
    for node in pipeline.nodes:
        lines.append(signature(node))
        if node.function != node.name:
            lines.append(f"    stage function: {node.function}")
        lines += [f"    {c}: {d}" for c, d in implementations(node, cfg, registry).items()]
    return "\n".join(lines)


def _label(text: str) -> str:
    """``text`` inside a Mermaid label's double quotes."""
    return '"' + text.replace('"', "#quot;") + '"'


def mermaid(pipeline: Pipeline, cfg: Mapping[str, Any], registry: Registry) -> str:
    """A Mermaid ``flowchart``: a box per stage (its name, stage function and implementations), an arrow from the
    stage producing an artifact to each stage reading it, labelled with the artifacts; injected artifacts are
    rounded boxes of their own."""
    ids = {node.name: f"s{i}" for i, node in enumerate(pipeline.nodes)}
    given = {name: f"given{i}" for i, name in enumerate(sorted(pipeline.provided))}
    lines = ["flowchart TD"]
    lines += [f"    {given[name]}([{_label(name)}])" for name in given]
    for node in pipeline.nodes:
        parts = [node.name] if node.function == node.name else [node.name, f"stage function: {node.function}"]
        parts += [f"{c}: {d}" for c, d in implementations(node, cfg, registry).items()]
        lines.append(f"    {ids[node.name]}[{_label('<br/>'.join(parts))}]")
    for node in pipeline.nodes:
        edges: dict[str, list[str]] = {}
        for artifact in node.inputs.values():
            source = given[artifact] if artifact in given else ids[pipeline.producer[artifact].name]
            edges.setdefault(source, [])
            if artifact not in edges[source]:
                edges[source].append(artifact)
        lines += [f"    {s} -->|{_label(', '.join(a))}| {ids[node.name]}" for s, a in edges.items()]
    return "\n".join(lines)
