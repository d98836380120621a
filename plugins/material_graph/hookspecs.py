"""The hooks of the ``torch_graph`` material library, declared by its plugin (``add_hookspecs``) and called when
:class:`~psdr_room_plugins.material_graph.library.TorchGraphLibrary` is built: plugins add graph files and node
types to it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from psdr_room_core.engine.hookspecs import hookspec


@hookspec
def material_graphs() -> list[str | Path]:
    """Return directories of procedural material graph files (``*.yaml``/``*.json``, the format of
    ``plugins/material_graph/graph.py``) that ``material_graph=torch_graph`` adds to its library.

    Called when the library is built. A material name (file stem) that is already taken is reported and
    left out.
    """


@hookspec
def material_nodes() -> list[Any]:
    """Return node types (``psdr_room_plugins.material_graph.nodes.NodeType``) that material graphs may use.

    Called when the ``torch_graph`` library is built; a node type name that is already taken is reported
    and left out.
    """
