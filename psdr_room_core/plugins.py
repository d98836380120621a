"""Plugin manager: loads the ``psdr_room`` entry points and keeps the registry of what they provide.

Built-in plugins (``psdr_room_plugins.*``) are listed in this distribution's entry points and loaded exactly
like third-party ones. A plugin that fails to import, implements an unknown hook, or raises while
registering is reported in a one-line warning and left out; only a run that selects something it would
have provided fails, with a message that names the plugin and its error.
"""

from __future__ import annotations

import functools
import inspect
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from importlib.metadata import EntryPoint, entry_points
from typing import Any

import pluggy

from . import hookspecs
from .capabilities import CAPABILITIES
from .errors import PsdrRoomError

log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "psdr_room"


@dataclass(frozen=True)
class Origin:
    """Where a registration came from: the plugin (entry point) and its distribution."""

    plugin: str
    distribution: str
    entry_point: str

    def __str__(self) -> str:
        return f"plugin '{self.plugin}' ({self.entry_point}, from {self.distribution})"


@dataclass(frozen=True)
class Implementation:
    """One implementation of a capability."""

    capability: str
    name: str
    factory: Callable[..., Any]
    version: str
    description: str
    origin: Origin
    params: type | None = None
    """The schema of its config node (:mod:`psdr_room_core.settings`); None: not checked."""


@dataclass(frozen=True)
class StageDef:
    """A stage function as registered by a plugin; the config decides where it runs in the DAG."""

    name: str
    fn: Callable[..., Any]
    version: str
    uses: tuple[str, ...]
    """Capabilities the stage calls through ``ctx.impl(capability)``."""
    reads_photo: bool
    """Whether the stage reads the input photo file itself (its bytes are then part of the cache key)."""
    sidecars: tuple[str, ...]
    """Suffixes of files beside the photo (``<stem><suffix>``) the stage reads when present (their bytes,
    or their absence, are part of the cache key)."""
    description: str
    origin: Origin
    params: type | None = None
    """The schema of its parameters (:mod:`psdr_room_core.settings`); None: not checked."""


@dataclass
class Registry:
    """Everything the loaded plugins provide, with where each item came from."""

    implementations: dict[tuple[str, str], Implementation] = field(default_factory=dict)
    stages: dict[str, StageDef] = field(default_factory=dict)
    conflicts: dict[tuple[str, str], list[Origin]] = field(default_factory=dict)
    failures: dict[str, str] = field(default_factory=dict)
    """Plugin name → why it was left out."""
    _origin: Origin = Origin("?", "?", "?")

    def add_implementation(
        self,
        capability: str,
        name: str,
        factory: Callable[..., Any],
        *,
        version: str = "1",
        description: str = "",
        params: type | None = None,
    ) -> None:
        """Register ``factory`` as implementation ``name`` of ``capability`` (one of ``CAPABILITIES``).

        Bump ``version`` whenever the implementation's results change: it is part of every cache key.
        ``params``: the dataclass schema of ``factory``'s keyword arguments (:mod:`psdr_room_core.settings`),
        checked against ``<capability>.<name>`` before any stage runs.
        """
        if capability not in CAPABILITIES:
            raise ValueError(f"unknown capability '{capability}'; expected one of {', '.join(CAPABILITIES)}")
        key = (capability, name)
        if key in self.implementations:
            self.conflicts.setdefault(key, [self.implementations[key].origin]).append(self._origin)
            return
        description = description or (inspect.getdoc(factory) or "").split("\n")[0]
        self.implementations[key] = Implementation(capability, name, factory, version, description, self._origin, params)

    def add_stage(
        self,
        name: str,
        fn: Callable[..., Any],
        *,
        version: str = "1",
        uses: Iterable[str] = (),
        reads_photo: bool = False,
        sidecars: Iterable[str] = (),
        params: type | None = None,
    ) -> None:
        """Register stage function ``fn`` under ``name`` (a later plugin's stage of the same name wins,
        so a plugin can replace a built-in stage; bump ``version`` when its results change). ``uses``: the
        capabilities it calls; ``reads_photo`` and ``sidecars`` (suffixes of files beside the photo): the
        files it reads itself, whose bytes join its cache key; ``params``: the dataclass schema of its config
        node's parameters (:mod:`psdr_room_core.settings`), checked before any stage runs."""
        uses = tuple(uses)
        for capability in uses:
            if capability not in CAPABILITIES:
                raise ValueError(f"stage '{name}' uses unknown capability '{capability}'")
        description = (inspect.getdoc(fn) or "").split("\n")[0]
        self.stages[name] = StageDef(name, fn, version, uses, reads_photo, tuple(sidecars), description, self._origin, params)

    # ------------------------------------------------------------------ lookups used by the runner
    def implementation(self, capability: str, name: str) -> Implementation:
        """The implementation selected by ``<capability>=<name>``, or a one-line error listing the choices."""
        key = (capability, name)
        if key in self.conflicts:
            both = " and ".join(str(o) for o in self.conflicts[key])
            raise PsdrRoomError(
                f"{capability}={name} is registered by {both}; uninstall one of them or rename its implementation"
            )
        if key not in self.implementations:
            valid = sorted(n for c, n in self.implementations if c == capability)
            raise PsdrRoomError(
                f"unknown {capability} implementation '{name}'; valid names: {', '.join(valid) or '(none)'}"
                + self._failure_hint()
            )
        return self.implementations[key]

    def stage(self, name: str) -> StageDef:
        if name not in self.stages:
            raise PsdrRoomError(
                f"no stage function '{name}' is registered; known: {', '.join(sorted(self.stages))}"
                + self._failure_hint()
            )
        return self.stages[name]

    def _failure_hint(self) -> str:
        if not self.failures:
            return ""
        return " (left out: " + "; ".join(f"{p}: {why}" for p, why in sorted(self.failures.items())) + ")"


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


def _unknown_hooks(plugin: object) -> list[str]:
    known = {name for name, _ in inspect.getmembers(hookspecs, inspect.isfunction)}
    marker = f"{hookspecs.PROJECT}_impl"
    return sorted(
        name for name in dir(plugin) if hasattr(getattr(plugin, name, None), marker) and name not in known
    )


def _report_failure(registry: Registry, origin: Origin, why: str) -> None:
    registry.failures[origin.plugin] = why
    log.warning("psdr-room: %s was left out: %s", origin, why)


def load_plugins(extra: Iterable[tuple[object, Origin]] = ()) -> PluginSystem:
    """Load every ``psdr_room`` entry point (plus ``extra`` plugin objects, for tests) and register them."""
    manager = pluggy.PluginManager(hookspecs.PROJECT)
    manager.add_hookspecs(hookspecs)
    registry = Registry()
    origins: dict[str, Origin] = {}
    candidates: list[tuple[Callable[[], object], Origin]] = [
        (ep.load, _origin(ep)) for ep in sorted(entry_points(group=ENTRY_POINT_GROUP), key=_builtin_first)
    ]
    candidates += [(functools.partial(lambda p: p, plugin), origin) for plugin, origin in extra]
    for load, origin in candidates:
        try:
            plugin = load()
        except Exception as exc:  # a broken third-party package must not break unrelated runs
            _report_failure(registry, origin, f"import failed: {type(exc).__name__}: {exc}")
            continue
        unknown = _unknown_hooks(plugin)
        if unknown:
            _report_failure(registry, origin, f"implements unknown hook(s) {', '.join(unknown)}")
            continue
        try:
            manager.register(plugin, name=origin.plugin)
        except ValueError as exc:
            _report_failure(registry, origin, f"could not be registered: {exc}")
            continue
        origins[origin.plugin] = origin
        _register(manager, plugin, origin, registry)
    return PluginSystem(manager=manager, registry=registry, origins=origins)


def _register(manager: pluggy.PluginManager, plugin: object, origin: Origin, registry: Registry) -> None:
    """Run one plugin's registration hooks; on error, roll back what it added and leave it out."""
    before_impl, before_stages = dict(registry.implementations), dict(registry.stages)
    registry._origin = origin
    try:
        for hook_name in ("register_implementations", "register_stages"):
            fn = getattr(plugin, hook_name, None)
            if fn is not None and hasattr(fn, f"{hookspecs.PROJECT}_impl"):
                fn(registry=registry)
    except Exception as exc:
        registry.implementations, registry.stages = before_impl, before_stages
        manager.unregister(plugin)
        _report_failure(registry, origin, f"registration failed: {type(exc).__name__}: {exc}")
    finally:
        registry._origin = Origin("?", "?", "?")


def _builtin_first(ep: EntryPoint) -> tuple[int, str]:
    """Built-ins register first, so a third-party stage of the same name replaces a built-in one."""
    return (0 if ep.value.startswith(("psdr_room_core", "psdr_room_plugins")) else 1, ep.name)


@functools.lru_cache(maxsize=1)
def plugin_system() -> PluginSystem:
    """The process-wide plugin system (loaded once)."""
    return load_plugins()
