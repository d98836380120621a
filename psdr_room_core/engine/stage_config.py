"""Stage nodes read from the composed config, and config values typed by their schema.

A stage node in the composed config is any top-level mapping with a ``_stage_`` key::

    room_init:
      _stage_: room_init                 # registered stage function (plugins' register_stages)
      _inputs_: {cloud: point_cloud}     # function parameter -> artifact name
      _outputs_: {room: room_box}        # function output -> artifact name (a list means same names)
      _uses_: {renderer: {spp: 4}}       # optional: this stage's settings of a capability's implementation,
                                         # over those of conf/<capability>/ (for every implementation)
      ransac_threshold: 0.02             # everything else: the stage's parameters (ctx.params)

Adding, removing or swapping a stage is a config change (``+stage@my_stage=my_stage``,
``~room_fit``, ``stage@room_init=my_room_init``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar, cast

RESERVED = ("_stage_", "_inputs_", "_outputs_", "_uses_")
"""The keys of a stage node that place it in the pipeline; the others are its parameters."""

SettingsT = TypeVar("SettingsT")


@dataclass(frozen=True)
class StageNode:
    """A stage as placed in the pipeline by the config."""

    name: str
    function: str
    inputs: dict[str, str]
    outputs: dict[str, str]
    params: dict[str, Any]
    uses: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Capability → settings that replace the configured implementation's for this stage only (``_uses_``)."""


def stage_nodes(cfg: Mapping[str, Any]) -> list[StageNode]:
    """The stage nodes of the composed config, in config order (see module docstring)."""
    nodes = []
    for name, node in cfg.items():
        if not isinstance(node, Mapping) or "_stage_" not in node:
            continue
        outputs = node.get("_outputs_") or {}
        if not isinstance(outputs, Mapping):
            outputs = {o: o for o in outputs}
        nodes.append(
            StageNode(
                name=str(name),
                function=str(node["_stage_"]),
                inputs=dict(node.get("_inputs_") or {}),
                outputs=dict(outputs),
                params={k: v for k, v in node.items() if k not in RESERVED},
                uses={str(c): dict(v) for c, v in (node.get("_uses_") or {}).items()},
            )
        )
    return nodes


def typed_settings(schema: type[SettingsT], values: Mapping[str, Any]) -> SettingsT:
    """``values`` (a config node :mod:`.settings` checked against ``schema``) as an instance of ``schema``: typed
    fields, nested settings as their dataclasses, the schema's defaults where the node leaves a key out."""
    from omegaconf import OmegaConf

    return cast(SettingsT, OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(schema), dict(values))))
