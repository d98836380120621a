"""The registry: what the loaded plugins provide (capabilities, artifact types, implementations, stages, settings
schemas), each with the plugin it came from. Plugins fill it from their ``register_*`` hooks
(:mod:`.hookspecs`); :mod:`.plugins` loads them.

A name is registered once, whatever it names. The same registration again (the same object with the same options,
by another plugin or by the same one) changes nothing. A different one under a name already taken
is refused with a one-line ``ValueError`` naming both plugins: the plugin registering second is left out, with a
warning, and the first keeps the name (built-in plugins load first). To replace a built-in stage, register yours
under a name of its own and swap it in by config (``stage@room_init=my_room_init``); another implementation of a
capability takes a name of its own too (``fov=exif``).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from . import references
from .artifacts import Artifact
from .errors import PsdrRoomError
from .references import Target


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


_FREE = object()
"""What is registered under a name nobody registered."""


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
    """The names two plugins registered differently: ``(capability, implementation)``, or ``(kind, name)`` of a
    ``capability``, ``artifact``, ``stage`` or ``settings`` → the plugin that has it and the one refused."""
    failures: dict[str, str] = field(default_factory=dict)
    """Plugin name → why it was left out."""
    _origin: Origin = Origin("?", "?", "?")
    _owners: dict[str, Origin] = field(default_factory=dict)
    """Each name registered, as an error names it (``stage 'room_init'``, ``fov=fixed``) → the plugin that registered
    it (read only for a name still registered: a left-out plugin's names are removed, not their owners)."""
    _added: dict[str, list[tuple[str, Any]]] = field(default_factory=dict)
    """Plugin name → (registry attribute, key) of each item it added, for :meth:`forget`."""

    def add_capability(self, name: str, description: str, protocol: type | None = None) -> None:
        """Declare capability ``name``: a config group of the same name selects one of its implementations;
        ``protocol``: a ``runtime_checkable`` Protocol every implementation must satisfy (its methods are
        checked when an implementation is constructed, before the stage that uses it runs)."""
        if not name.isidentifier():
            raise ValueError(f"capability name '{name}' is not an identifier")
        registered = (self.capabilities[name], self.protocols.get(name)) if name in self.capabilities else _FREE
        if self._claim(("capability", name), f"capability '{name}'", registered, (description, protocol)):
            self.capabilities[name] = description
            self._added_by_origin("capabilities", name)
            if protocol is not None:
                self.protocols[name] = protocol
                self._added_by_origin("protocols", name)

    def add_artifact(self, artifact_type: type[Artifact]) -> None:
        """Register an artifact type under its ``kind``."""
        for attribute in ("kind", "marker", "save", "load"):
            if not hasattr(artifact_type, attribute):
                raise ValueError(f"artifact type {artifact_type.__name__} has no '{attribute}'")
        kind = artifact_type.kind
        registered = self.artifacts.get(kind, _FREE)
        if self._claim(("artifact", kind), f"artifact kind '{kind}'", registered, artifact_type):
            self.artifacts[kind] = artifact_type
            self._added_by_origin("artifacts", kind)

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
        new = Implementation(capability, name, factory, version, self._origin, params, reads_files, description)
        registered = self.implementations.get(key)
        as_registered = _FREE if registered is None else dataclasses.replace(registered, origin=new.origin)
        if self._claim(key, f"{capability}={name}", as_registered, new):
            self.implementations[key] = new
            self._added_by_origin("implementations", key)

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
        first computes) under ``name`` (a name no other plugin registered: the config swaps a stage for another;
        bump ``version`` when its results change). ``uses``: the
        capabilities it calls; ``reads_photo`` and ``sidecars`` (suffixes of files beside the photo): the
        files it reads itself, whose bytes join its cache key; ``params``: the dataclass schema of its config
        node's parameters (:mod:`psdr_room_core.engine.settings`), checked before any stage runs."""
        uses = tuple(uses)
        for capability in uses:
            if capability not in self.capabilities:
                raise ValueError(f"stage '{name}' uses unknown capability '{capability}'")
        new = StageDef(name, fn, version, uses, reads_photo, tuple(sidecars), self._origin, params)
        registered = self.stages.get(name)
        as_registered = _FREE if registered is None else dataclasses.replace(registered, origin=new.origin)
        if self._claim(("stage", name), f"stage '{name}'", as_registered, new):
            self.stages[name] = new
            self._added_by_origin("stages", name)

    def add_settings(self, name: str, params: type | None = None) -> None:
        """Declare ``name``, a top-level config node this plugin reads (the report's ``report``), with the
        dataclass schema of its keys (:mod:`psdr_room_core.engine.settings`); an undeclared top-level key
        that is neither a stage nor a capability is refused before any stage runs."""
        if not name.isidentifier():
            raise ValueError(f"settings name '{name}' is not an identifier")
        if self._claim(("settings", name), f"settings '{name}'", self.settings.get(name, _FREE), params):
            self.settings[name] = params
            self._added_by_origin("settings", name)

    def forget(self, plugin: str) -> None:
        """Remove everything plugin ``plugin`` registered, in every phase (it is left out)."""
        for attribute, key in self._added.pop(plugin, []):
            getattr(self, attribute).pop(key, None)

    def _added_by_origin(self, attribute: str, key: Any) -> None:
        self._added.setdefault(self._origin.plugin, []).append((attribute, key))

    def _claim(self, key: tuple[str, str], label: str, registered: object, registering: object) -> bool:
        """Whether the name ``label`` (``key`` in :attr:`conflicts`) is free, so that the plugin registering now
        takes it; False where ``registering`` is what is ``registered`` under it already (:data:`_FREE` where
        nothing is). A different registration is refused (module docstring)."""
        if registered is _FREE:
            self._owners[label] = self._origin
            return True
        if registered == registering:
            return False
        owner = self._owners[label]
        self.conflicts[key] = [owner, self._origin]
        raise ValueError(f"{label} is registered by {owner} and by {self._origin}; rename one of them")

    # ------------------------------------------------------------------ lookups used by the runner
    def implementation(self, capability: str, name: str) -> Implementation:
        """The implementation selected by ``<capability>=<name>``, or a one-line error listing the choices."""
        key = (capability, name)
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
