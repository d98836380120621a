"""The method's own hooks, declared to the engine by the method's plugin (``add_hookspecs``).

``model_registries`` is called whenever the registry of downloadable model files is read. (The material library's
hooks, ``material_graphs`` and ``material_nodes``, are declared where they are called: the ``torch_graph`` plugin,
:mod:`psdr_room_plugins.material_graph.hookspecs`.)
"""

from __future__ import annotations

from pathlib import Path

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
