"""``material_graph=torch_graph``: differentiable procedural materials as node graphs in torch (§3.2, §4.4).

The paper optimises the parameters of Substance-like node graphs (DiffMatV2) through the renderer; this
package is the same idea in plain torch: tileable generator and filter nodes (:mod:`.nodes`), typed and
bounded parameters with a sigmoid reparameterisation (:mod:`.params`), graph files that are data
(:mod:`.graph`, ``library/*.yaml``), the library (:mod:`.library`), thumbnails (:mod:`.thumbnails`) and the
``psdr-room-materials`` command (:mod:`psdr_room_core.applications.materials`). The library is registered by
reference: torch loads when it is constructed.

    from psdr_room_plugins.material_graph.library import TorchGraphLibrary

    lib = TorchGraphLibrary()
    oak = lib.material("oak_planks")
    u = oak.parameters()                      # unconstrained tensors, requires_grad
    maps = oak.evaluate(512, u)               # base_color, roughness, metallic, height, normal
"""

from __future__ import annotations

from dataclasses import dataclass

import pluggy

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting

from . import hookspecs


@dataclass
class TorchGraphSettings:
    """``material_graph=torch_graph``: where graphs come from and where they are evaluated."""

    extra_dirs: list[str] = setting(
        doc="More directories of graph files (*.yaml, *.yml, *.json), after the built-in library and plugins' "
        "(material_graphs hook)."
    )
    use_plugins: bool = setting(doc="Take graphs and node types from plugins (material_graphs, material_nodes hooks).")
    device: str = setting(doc="Torch device the maps are evaluated on (cpu, cuda).")


@hookimpl
def add_hookspecs(plugin_manager: pluggy.PluginManager) -> None:
    """The library's hooks (:mod:`.hookspecs`): graph files and node types from other plugins."""
    plugin_manager.add_hookspecs(hookspecs)


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation(
        "material_graph",
        "torch_graph",
        "psdr_room_plugins.material_graph.library:TorchGraphLibrary",
        params=TorchGraphSettings,
        reads_files=False,
    )
