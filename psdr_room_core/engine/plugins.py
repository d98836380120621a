"""Plugin manager: loads the ``psdr_room`` entry points and keeps the registry of what they provide.

Built-in plugins (this distribution's own entry points) are loaded exactly like third-party ones, first. Loading
goes in phases so that no plugin depends on another's load order: every plugin's ``add_hookspecs`` (hooks a
plugin declares for others, as the method does for its model registries and material libraries), then every
``register_capabilities`` and ``register_artifacts``, then each plugin's ``register_implementations``,
``register_stages`` and ``register_settings``. A plugin that fails to import, implements an unknown hook, or raises while registering is
reported in a one-line warning and left out; only a run that selects something it would have provided fails,
with a message that names the plugin and its error.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from importlib.metadata import EntryPoint, entry_points
from typing import Any

import pluggy

from . import hookspecs, references
from .artifacts import Artifact
from .errors import PsdrRoomError
from .references import Target

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
    target: Target
    """Its factory, or a reference ``"module:attribute"`` to it (imported when first constructed)."""
    version: str
    origin: Origin
    params: type | None = None
    """The schema of its config node (:mod:`psdr_room_core.engine.settings`); None: not checked."""
    reads_files: bool | None = None
    """Whether its instances have ``external_files(photo)`` (files they read, part of the cache key). False: it
    is constructed only when a stage that uses it computes (a cached run never imports its libraries); True or
    None (not declared): for every stage that uses it, cached or not."""
    summary: str = ""
    """Its one-line description as registered; empty: its factory's docstring."""

    @functools.cached_property
    def factory(self) -> Callable[..., Any]:
        """The factory (a reference's imported now)."""
        return references.load(self.target)

    @functools.cached_property
    def description(self) -> str:
        return self.summary or references.docstring(self.target)


@dataclass(frozen=True)
class StageDef:
    """A stage function as registered by a plugin; the config decides where it runs in the DAG."""

    name: str
    target: Target
    """The stage function, or a reference ``"module:attribute"`` to it (imported when the stage first computes)."""
    version: str
    uses: tuple[str, ...]
    """Capabilities the stage calls through ``ctx.impl(capability)``."""
    reads_photo: bool
    """Whether the stage reads the input photo file itself (its bytes are then part of the cache key)."""
    sidecars: tuple[str, ...]
    """Suffixes of files beside the photo (``<stem><suffix>``) the stage reads when present (their bytes,
    or their absence, are part of the cache key)."""
    origin: Origin
    params: type | None = None
    """The schema of its parameters (:mod:`psdr_room_core.engine.settings`); None: not checked."""

    @functools.cached_property
    def fn(self) -> Callable[..., Any]:
        """The stage function (a reference's imported now)."""
        return references.load(self.target)

    @functools.cached_property
    def description(self) -> str:
        return references.docstring(self.target)


@dataclass
class Registry:
    """Everything the loaded plugins provide, with where each item came from."""

    capabilities: dict[str, str] = field(default_factory=dict)
    """Capability → one-line description, in registration order (the method's pipeline order)."""
    protocols: dict[str, type] = field(default_factory=dict)
    """Capability → the protocol its implementations satisfy (checked when one is constructed), where declared."""
    artifacts: dict[str, type[Artifact]] = field(default_factory=dict)
    """Artifact kind → type, for loading cached, injected or published artifacts."""
    implementations: dict[tuple[str, str], Implementation] = field(default_factory=dict)
    stages: dict[str, StageDef] = field(default_factory=dict)
    settings: dict[str, type | None] = field(default_factory=dict)
    """Top-level config node a plugin reads → its schema (None: not checked beyond its name)."""
    conflicts: dict[tuple[str, str], list[Origin]] = field(default_factory=dict)
    failures: dict[str, str] = field(default_factory=dict)
    """Plugin name → why it was left out."""
    _origin: Origin = Origin("?", "?", "?")

    def add_capability(self, name: str, description: str, protocol: type | None = None) -> None:
        """Declare capability ``name``: a config group of the same name selects one of its implementations;
        ``protocol``: a ``runtime_checkable`` Protocol every implementation must satisfy (its methods are
        checked when an implementation is constructed, before the stage that uses it runs)."""
        if not name.isidentifier():
            raise ValueError(f"capability name '{name}' is not an identifier")
        self.capabilities.setdefault(name, description)
        if protocol is not None:
            self.protocols.setdefault(name, protocol)

    def add_artifact(self, artifact_type: type[Artifact]) -> None:
        """Register an artifact type under its ``kind`` (a kind registered twice keeps the first type)."""
        for attribute in ("kind", "marker", "save", "load"):
            if not hasattr(artifact_type, attribute):
                raise ValueError(f"artifact type {artifact_type.__name__} has no '{attribute}'")
        self.artifacts.setdefault(artifact_type.kind, artifact_type)

    def add_implementation(
        self,
        capability: str,
        name: str,
        factory: Target,
        *,
        version: str = "1",
        description: str = "",
        params: type | None = None,
        reads_files: bool | None = None,
    ) -> None:
        """Register ``factory`` (or a reference ``"module:attribute"`` to it, imported on first use) as
        implementation ``name`` of ``capability`` (a declared one).

        Bump ``version`` whenever the implementation's results change: it is part of every cache key.
        ``params``: the dataclass schema of ``factory``'s keyword arguments (:mod:`psdr_room_core.engine.settings`),
        checked against ``<capability>.<name>`` before any stage runs. ``reads_files``: whether its instances read
        files (``external_files(photo)``, part of the cache key); False lets a cached stage skip constructing it
        (an instance that has them after all is refused), None constructs it for every stage as True does.
        """
        if capability not in self.capabilities:
            raise ValueError(f"unknown capability '{capability}'; expected one of {', '.join(self.capabilities)}")
        key = (capability, name)
        if key in self.implementations:
            self.conflicts.setdefault(key, [self.implementations[key].origin]).append(self._origin)
            return
        self.implementations[key] = Implementation(
            capability, name, factory, version, self._origin, params, reads_files, description
        )

    def add_stage(
        self,
        name: str,
        fn: Target,
        *,
        version: str = "1",
        uses: Iterable[str] = (),
        reads_photo: bool = False,
        sidecars: Iterable[str] = (),
        params: type | None = None,
    ) -> None:
        """Register stage function ``fn`` (or a reference ``"module:attribute"`` to it, imported when the stage
        first computes) under ``name`` (a later plugin's stage of the same name wins,
        so a plugin can replace a built-in stage; bump ``version`` when its results change). ``uses``: the
        capabilities it calls; ``reads_photo`` and ``sidecars`` (suffixes of files beside the photo): the
        files it reads itself, whose bytes join its cache key; ``params``: the dataclass schema of its config
        node's parameters (:mod:`psdr_room_core.engine.settings`), checked before any stage runs."""
        uses = tuple(uses)
        for capability in uses:
            if capability not in self.capabilities:
                raise ValueError(f"stage '{name}' uses unknown capability '{capability}'")
        self.stages[name] = StageDef(name, fn, version, uses, reads_photo, tuple(sidecars), self._origin, params)

    def add_settings(self, name: str, params: type | None = None) -> None:
        """Declare ``name``, a top-level config node this plugin reads (the report's ``report``), with the
        dataclass schema of its keys (:mod:`psdr_room_core.engine.settings`); an undeclared top-level key
        that is neither a stage nor a capability is refused before any stage runs."""
        if not name.isidentifier():
            raise ValueError(f"settings name '{name}' is not an identifier")
        self.settings.setdefault(name, params)

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
        except ValueError as exc:
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
    """Run one plugin's registration hooks of one phase; on error, roll back what it added, leave it out and
    return False."""
    before = {
        name: dict(getattr(registry, name))
        for name in ("capabilities", "artifacts", "implementations", "stages", "settings")
    }
    registry._origin = origin
    try:
        for hook_name in hook_names:
            fn = _hook_impl(plugin, hook_name)
            if fn is not None:
                fn(registry=registry)
    except Exception as exc:
        for name, items in before.items():
            setattr(registry, name, items)
        manager.unregister(plugin)
        _report_failure(registry, origin, f"registration failed: {type(exc).__name__}: {exc}")
        return False
    finally:
        registry._origin = Origin("?", "?", "?")
    return True


def _builtin_first(found: Iterable[EntryPoint]) -> list[EntryPoint]:
    """Entry points by name, those of the engine's own distribution (the one whose entry points load from the
    engine's top-level package) first, so a third-party stage of the same name replaces a built-in one."""
    found = list(found)
    package = __name__.split(".")[0]
    own = {ep.dist.name for ep in found if ep.dist is not None and ep.value.split(".")[0] == package}
    return sorted(found, key=lambda ep: (0 if ep.dist is not None and ep.dist.name in own else 1, ep.name))


@functools.lru_cache(maxsize=1)
def plugin_system() -> PluginSystem:
    """The process-wide plugin system (loaded once)."""
    return load_plugins()
