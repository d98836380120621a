"""The plugin contract: every hook a psdr-room plugin can implement, in one place.

A plugin is a module (or object) with functions decorated by :data:`hookimpl`, named by an entry point in
the ``psdr_room`` group of its distribution's metadata::

    [project.entry-points.psdr_room]
    my_depth = "my_package.my_depth"

The built-in plugins in ``psdr_room_plugins`` are found the same way. Hooks are called in this order:
``register_implementations`` and ``register_stages`` once when plugins are loaded; ``conf_searchpath``
when Hydra composes the configuration; then for each run ``before_run``, for every stage
``before_stage`` followed by ``after_stage`` or ``on_stage_error``, and finally ``after_run``.
``model_registries`` is called whenever the registry of downloadable model files is read;
``material_graphs`` and ``material_nodes`` when the procedural material library is built.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import pluggy

if TYPE_CHECKING:
    from .dag import RunRecord, StageRecord
    from .plugins import Registry

PROJECT = "psdr_room"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def register_implementations(registry: Registry) -> None:
    """Add capability implementations with ``registry.add_implementation(capability, name, factory)``.

    Called once per plugin when plugins are loaded. ``factory(**params)`` is called with the parameters of
    the implementation's config node (``<capability>.<name>`` in the composed config) and returns an object
    satisfying the capability's protocol in :mod:`psdr_room_core.capabilities`. Factories must be cheap:
    load model weights lazily, on first use.
    """


@hookspec
def register_stages(registry: Registry) -> None:
    """Add pipeline stages with ``registry.add_stage(name, fn, uses=(...), version=...)``.

    A stage is a plain function ``fn(ctx, **inputs) -> {output_name: artifact}``; which stages run and how
    their inputs and outputs are wired is decided by the config (``conf/stage/*.yaml``), not here.
    """


@hookspec
def conf_searchpath() -> str | None:
    """Return a Hydra search-path entry (``pkg://my_package.conf`` or ``file:///abs/dir``) holding this
    plugin's config files, e.g. ``depth/my_depth.yaml`` selecting and configuring its implementation."""


@hookspec
def model_registries() -> list[str | Path]:
    """Return the paths of model-registry JSON files listing the weight files this plugin's
    implementations use (same format as ``psdr_room_core/models.json``; absolute paths, e.g.
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


@hookspec
def before_run(run: RunRecord) -> None:
    """Called before the first stage of a run; ``run.stages`` is still empty."""


@hookspec
def before_stage(stage: str, key: str, inputs: dict[str, Any]) -> None:
    """Called before a stage executes (not when its outputs come from the cache).

    ``stage`` is the stage's name in the config, ``key`` its cache key, ``inputs`` its input artifacts.
    """


@hookspec
def after_stage(record: StageRecord, outputs: dict[str, Any]) -> None:
    """Called when a stage has finished or was served from the cache (``record.cached``)."""


@hookspec
def on_stage_error(stage: str, key: str, error: BaseException) -> None:
    """Called when a stage raises; nothing of it has been written to the cache."""


@hookspec
def after_run(run: RunRecord, run_dir: Path) -> None:
    """Called when all selected stages have finished and the artifacts are published in ``run_dir``.

    Reports and metrics are written here (see ``psdr_room_plugins.report``).
    """
