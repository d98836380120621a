"""The method's own hooks, declared to the engine by the method's plugin (``add_hookspecs``).

``model_registries`` is called whenever the registry of downloadable model files is read; ``material_graphs``
and ``material_nodes`` when the procedural material library is built.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from psdr_room_core.engine.hookspecs import hookspec


@hookspec
def model_registries() -> list[str | Path]:
    """Return the paths of model-registry JSON files listing the weight files this plugin's
    implementations use (same format as ``psdr_room_core/method/models.json``; absolute paths, e.g.
    ``Path(__file__).with_name("models.json")``).

    Called whenever the model registry is read: by ``psdr-room-models list|download|verify`` and by
    implementations that look a model up by name. Entries are added after the built-in ones; a name that
    is already taken is reported and left out.
    """


@hookspec
def material_graphs() -> list[str | Path]:
    """Return directories of procedural material graph files (``*.yaml``/``*.json``, the format of
    ``psdr_room_plugins/material_graph/graph.py``) that ``material_graph=torch_graph`` adds to its library.

    Called when the library is built. A material name (file stem) that is already taken is reported and
    left out.
    """


@hookspec
def material_nodes() -> list[Any]:
    """Return node types (``psdr_room_plugins.material_graph.NodeType``) that material graphs may use.

    Called when the ``torch_graph`` library is built; a node type name that is already taken is reported
    and left out.
    """
