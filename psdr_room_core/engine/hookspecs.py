"""The engine's plugin contract: every hook the engine calls, in one place.

A plugin is a module (or object) with functions decorated by :data:`hookimpl`, named by an entry point in
the ``psdr_room`` group of its distribution's metadata::

    [project.entry-points.psdr_room]
    my_depth = "my_package.my_depth"

The built-in plugins are found the same way. When plugins are loaded: ``add_hookspecs`` (hooks a plugin
declares for others to implement; the method's are in :mod:`psdr_room_core.method.hookspecs`, the material
library's in :mod:`psdr_room_plugins.material_graph.hookspecs`), then
``register_capabilities`` and ``register_artifacts`` of every plugin, then ``register_implementations``,
``register_stages`` and ``register_settings``. ``conf_searchpath`` when Hydra composes the configuration. Then for each run
``before_run``, for every stage ``before_stage`` (when it computes) followed by ``after_stage`` or
``on_stage_error``, ``run_metrics`` when the run's ``metrics.json`` is written, and finally ``after_run``. The
three stage hooks get the stage's :class:`~.records.StageRecord` first, as ``record``: one object per stage,
filled in as it runs.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import pluggy

if TYPE_CHECKING:
    from .records import RunRecord, StageRecord
    from .registry import Registry

PROJECT = "psdr_room"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


def _stage_and_key_deprecated(hook: str) -> dict[str, Warning]:
    """The warnings pluggy gives when a plugin registers a ``hook`` implementation taking ``stage`` or ``key``,
    which the stage's record holds (``record.name``, ``record.key``)."""
    return {
        argument: DeprecationWarning(
            f"{hook}: the argument '{argument}' is deprecated and goes in the next release; take 'record' "
            f"and read record.{field}"
        )
        for argument, field in (("stage", "name"), ("key", "key"))
    }


@hookspec
def add_hookspecs(plugin_manager: pluggy.PluginManager) -> None:
    """Declare hooks of this plugin's own for other plugins to implement: ``plugin_manager.add_hookspecs(module)``
    (as pytest's ``pytest_addhooks``). Called first, before any registration hook."""


@hookspec
def register_capabilities(registry: Registry) -> None:
    """Declare capabilities with ``registry.add_capability(name, description)``: the swappable parts of a
    method, each selected by the config group of the same name. Called before any implementation is added."""


@hookspec
def register_artifacts(registry: Registry) -> None:
    """Add artifact types with ``registry.add_artifact(cls)``: classes with ``kind``, ``marker``, ``save`` and
    ``load`` (:class:`~psdr_room_core.engine.artifacts.Artifact`), so the engine can load them from the cache
    and from ``+inject.NAME=DIR``."""


@hookspec
def register_implementations(registry: Registry) -> None:
    """Add capability implementations with ``registry.add_implementation(capability, name, factory)``.

    Called once per plugin when plugins are loaded. ``factory(**params)`` is called with the parameters of
    the implementation's config node (``<capability>.<name>`` in the composed config), typed by its ``params``
    schema (nested settings as their dataclasses, the schema's defaults for keys left out), and returns an object
    satisfying the capability's protocol (the method's are in :mod:`psdr_room_core.method.capabilities`). Factories must be cheap:
    load model weights lazily, on first use. ``factory`` may be a reference ``"module:attribute"``, imported when
    first constructed; with ``reads_files=False`` a cached stage never constructs it (:mod:`.references`).
    """


@hookspec
def register_stages(registry: Registry) -> None:
    """Add pipeline stages with ``registry.add_stage(name, fn, uses=(...), version=...)``.

    A stage is a plain function ``fn(ctx, **inputs) -> {output_name: artifact}``; which stages run and how
    their inputs and outputs are wired is decided by the config (``conf/stage/*.yaml``), not here. ``fn`` may
    be a reference ``"module:attribute"``, imported when the stage first computes (:mod:`.references`).
    """


@hookspec
def register_settings(registry: Registry) -> None:
    """Declare the top-level config nodes this plugin reads with ``registry.add_settings(name, params)``
    (a stage's or an implementation's own settings are declared with it, not here)."""


@hookspec
def conf_searchpath() -> str | None:
    """Return a Hydra search-path entry (``pkg://my_package.conf`` or ``file:///abs/dir``) holding this
    plugin's config files, e.g. ``depth/my_depth.yaml`` selecting and configuring its implementation."""


@hookspec
def before_run(run: RunRecord) -> None:
    """Called before the first stage of a run; ``run.stages`` is still empty."""


@hookspec(warn_on_impl_args=_stage_and_key_deprecated("before_stage"))
def before_stage(record: StageRecord, inputs: dict[str, Any], stage: str, key: str) -> None:
    """Called before a stage executes (not when its outputs come from the cache).

    ``record`` is the stage's record, the same object ``after_stage`` or ``on_stage_error`` gets next: its
    ``name`` (the stage's name in the config), ``function``, ``key`` (its cache key) and ``implementations``
    are set, the rest is filled in when the stage is done. ``inputs`` are its input artifacts. ``stage`` and
    ``key`` (``record.name`` and ``record.key``) are deprecated.
    """


@hookspec
def after_stage(record: StageRecord, outputs: dict[str, Any]) -> None:
    """Called when a stage has finished or was served from the cache (``record.cached``); ``outputs`` are its
    output artifacts, by the stage function's output names."""


@hookspec(warn_on_impl_args=_stage_and_key_deprecated("on_stage_error"))
def on_stage_error(record: StageRecord, error: BaseException, stage: str, key: str) -> None:
    """Called when a stage raises ``error``; nothing of it has been written to the cache. ``record`` is the
    stage's record as ``before_stage`` got it; ``stage`` and ``key`` (``record.name`` and ``record.key``) are
    deprecated."""


@hookspec
def run_metrics(run: RunRecord) -> dict[str, Any]:
    """Return figures of a finished run for its ``metrics.json`` (merged over all plugins, beside the engine's
    per-stage times, cache hits, implementations and digests)."""


@hookspec
def after_run(run: RunRecord, run_dir: Path) -> None:
    """Called when all selected stages have finished and the artifacts are published in ``run_dir``.

    Reports and metrics are written here (see ``psdr_room_plugins.report``).
    """
