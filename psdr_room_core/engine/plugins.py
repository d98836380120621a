"""Plugin manager: loads the ``psdr_room`` entry points and keeps the registry of what they provide.

Built-in plugins (this distribution's own entry points) are loaded exactly like third-party ones, first. Loading
goes in phases so that no plugin depends on another's load order: every plugin's ``add_hookspecs`` (hooks a
plugin declares for others, as the method does for its model registries and material libraries), then every
``register_capabilities`` and ``register_artifacts``, then each plugin's ``register_implementations``,
``register_stages`` and ``register_settings``. A plugin that fails to import, implements an unknown hook, takes
an argument its hook does not have, or raises while registering is reported in a one-line warning and left out; only a run that selects something it would have provided fails,
with a message that names the plugin and its error.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Any

import pluggy

from . import hookspecs
from .registry import Origin, Registry

log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "psdr_room"


@dataclass
class PluginSystem:
    """The pluggy manager (for run-event hooks) and the registry (for implementations and stages)."""

    manager: pluggy.PluginManager
    registry: Registry
    origins: dict[str, Origin]

    @property
    def hook(self) -> Any:
        return self.manager.hook

    def conf_searchpaths(self) -> list[str]:
        """Hydra search-path entries contributed by plugins, in load order."""
        return [p for p in self.manager.hook.conf_searchpath() if p]


def _origin(ep: EntryPoint) -> Origin:
    dist = f"{ep.dist.name} {ep.dist.version}" if ep.dist is not None else "unknown distribution"
    return Origin(plugin=ep.name, distribution=dist, entry_point=f"{ep.name} = {ep.value}")


def _hook_impl(plugin: object, name: str) -> Callable[..., Any] | None:
    fn = getattr(plugin, name, None)
    return fn if fn is not None and hasattr(fn, f"{hookspecs.PROJECT}_impl") else None


def _unknown_hooks(manager: pluggy.PluginManager, plugin: object) -> list[str]:
    known = {name for name, caller in vars(manager.hook).items() if getattr(caller, "spec", None) is not None}
    return sorted(name for name in dir(plugin) if _hook_impl(plugin, name) is not None and name not in known)


def _report_failure(registry: Registry, origin: Origin, why: str) -> None:
    registry.failures[origin.plugin] = why
    log.warning("psdr-room: %s was left out: %s", origin, why)


def load_plugins(extra: Iterable[tuple[object, Origin]] = (), discover: bool = True) -> PluginSystem:
    """Load every ``psdr_room`` entry point (unless ``discover`` is False) plus ``extra`` plugin objects (for
    tests and embedding), and register them."""
    manager = pluggy.PluginManager(hookspecs.PROJECT)
    manager.add_hookspecs(hookspecs)
    registry = Registry()
    found = _builtin_first(entry_points(group=ENTRY_POINT_GROUP)) if discover else []
    candidates: list[tuple[Callable[[], object], Origin]] = [(ep.load, _origin(ep)) for ep in found]
    candidates += [(functools.partial(lambda p: p, plugin), origin) for plugin, origin in extra]
    loaded: list[tuple[object, Origin]] = []
    for load, origin in candidates:
        try:
            plugin = load()
        except Exception as exc:  # a broken third-party package must not break unrelated runs
            _report_failure(registry, origin, f"import failed: {type(exc).__name__}: {exc}")
            continue
        add = _hook_impl(plugin, "add_hookspecs")
        try:
            if add is not None:
                add(plugin_manager=manager)
        except Exception as exc:
            _report_failure(registry, origin, f"add_hookspecs failed: {type(exc).__name__}: {exc}")
            continue
        loaded.append((plugin, origin))
    registered: list[tuple[object, Origin]] = []
    for plugin, origin in loaded:
        unknown = _unknown_hooks(manager, plugin)
        if unknown:
            _report_failure(registry, origin, f"implements unknown hook(s) {', '.join(unknown)}")
            continue
        try:
            manager.register(plugin, name=origin.plugin)
        except (ValueError, pluggy.PluginValidationError) as exc:
            _report_failure(registry, origin, f"could not be registered: {exc}")
            continue
        registered.append((plugin, origin))
    phases = (
        ("register_capabilities", "register_artifacts"),
        ("register_implementations", "register_stages", "register_settings"),
    )
    for phase in phases:
        for plugin, origin in list(registered):
            if not _register(manager, plugin, origin, registry, phase):
                registered.remove((plugin, origin))
    origins = {origin.plugin: origin for _, origin in registered}
    return PluginSystem(manager=manager, registry=registry, origins=origins)


def _register(
    manager: pluggy.PluginManager, plugin: object, origin: Origin, registry: Registry, hook_names: tuple[str, ...]
) -> bool:
    """Run one plugin's registration hooks of one phase; on error, remove what it added in every phase, leave it
    out and return False."""
    registry._origin = origin
    try:
        for hook_name in hook_names:
            fn = _hook_impl(plugin, hook_name)
            if fn is not None:
                fn(registry=registry)
    except Exception as exc:
        registry.forget(origin.plugin)
        manager.unregister(plugin)
        _report_failure(registry, origin, f"registration failed: {type(exc).__name__}: {exc}")
        return False
    finally:
        registry._origin = Origin("?", "?", "?")
    return True


def _builtin_first(found: Iterable[EntryPoint]) -> list[EntryPoint]:
    """Entry points by name, those of the engine's own distribution (the one whose entry points load from the
    engine's top-level package) first, so a built-in name stays the built-in's (:mod:`.registry`)."""
    found = list(found)
    package = __name__.split(".")[0]
    own = {ep.dist.name for ep in found if ep.dist is not None and ep.value.split(".")[0] == package}
    return sorted(found, key=lambda ep: (0 if ep.dist is not None and ep.dist.name in own else 1, ep.name))


@functools.lru_cache(maxsize=1)
def plugin_system() -> PluginSystem:
    """The process-wide plugin system (loaded once)."""
    return load_plugins()
