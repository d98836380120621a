"""Choosing and constructing the implementation of each capability a stage uses: the one its config group names
(``<capability>.impl``), or with ``auto`` the first of ``<capability>.auto.order`` usable for the photo."""

from __future__ import annotations

import dataclasses
import functools
import logging
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .capabilities import Availability
from .context import Deferred
from .errors import PsdrRoomError
from .fingerprint import code_fingerprint
from .registry import Registry, StageDef
from .stage_config import StageNode, typed_settings

AUTO = "auto"
"""The implementation name that selects the first usable one of ``<capability>.auto.order``."""

log = logging.getLogger("psdr_room")


def with_settings(group: Mapping[str, Any], settings: Mapping[str, Any]) -> dict[str, Any]:
    """A capability's config group with ``settings`` over every implementation's own (a stage's ``_uses_``)."""
    out = dict(group)
    if not settings:
        return out
    named = [str(out.get("impl")), *((out.get(AUTO) or {}).get("order") or []), *out]
    for name in dict.fromkeys(n for n in named if n not in ("impl", AUTO)):
        own = out.get(name) or {}
        if isinstance(own, Mapping):
            out[name] = {**own, **settings}
    return out


def capability_group(cfg: Mapping[str, Any], node: StageNode, capability: str) -> dict[str, Any]:
    """The config group of ``capability`` as stage ``node`` sees it: the node's ``_uses_`` settings over the
    configured ones; a one-line error where the config has no such group."""
    group = cfg.get(capability)
    if not isinstance(group, Mapping) or "impl" not in group:
        raise PsdrRoomError(f"stage '{node.name}' needs the '{capability}' config group; add {capability}=NAME")
    return with_settings(group, node.uses.get(capability, {}))


@dataclass(frozen=True)
class Chosen:
    """The implementations of a stage's capabilities, as :meth:`Chooser.for_stage` chose them."""

    instances: dict[str, Any]
    """Capability → its instance (:class:`Deferred` when constructed only if the stage computes)."""
    described: dict[str, dict[str, Any]]
    """Capability → name, version, code fingerprint and parameters of its implementation (part of the cache key)."""
    selected_by: dict[str, str]
    """Capability set to ``auto`` → how the choice was made (for the run record, not the key: only the choice
    matters)."""


class Chooser:
    """Chooses the implementations of a run's stages from the registry, the composed config and the photo."""

    def __init__(self, registry: Registry, cfg: Mapping[str, Any], photo: Path) -> None:
        self.registry = registry
        self.cfg = cfg
        self.photo = photo

    def for_stage(self, node: StageNode, stage: StageDef) -> Chosen:
        """Instantiate the selected implementation of each capability the stage uses, with the node's
        ``_uses_`` settings over the configured ones. An implementation registered with ``reads_files=False``
        and not chosen by ``auto`` is :class:`Deferred`: the stage constructs it if it computes."""
        unknown = sorted(set(node.uses) - set(stage.uses))
        if unknown:
            raise PsdrRoomError(
                f"stage '{node.name}': _uses_ names {', '.join(unknown)}, which the stage does not use "
                f"(it uses {', '.join(stage.uses) or 'none'}); remove them from its config"
            )
        instances, described, selected_by = {}, {}, {}
        for capability in stage.uses:
            group = capability_group(self.cfg, node, capability)
            name = str(group["impl"])
            if name == AUTO:
                name, instances[capability], skipped = self.first_available(capability, group)
                selected_by[capability] = "auto" + "".join(f"; not {n}: {why}" for n, why in skipped.items())
                log.info("%s=auto selected %s (%s)", capability, name, selected_by[capability])
            impl = self.registry.implementation(capability, name)
            if capability not in instances:  # auto constructed its choice to ask whether it is usable
                construct = functools.partial(self.construct, capability, name, group)
                instances[capability] = Deferred(construct) if impl.reads_files is False else construct()
            described[capability] = {
                "name": name,
                "version": impl.version,
                "code": code_fingerprint(impl.target),
                "params": dict(group.get(name) or {}),
            }
        return Chosen(instances=instances, described=described, selected_by=selected_by)

    def construct(self, capability: str, name: str, node: Mapping[str, Any]) -> Any:
        """The implementation ``name`` of ``capability`` made by its factory from its settings in ``node`` (the
        capability's config group), checked against the capability's protocol."""
        impl = self.registry.implementation(capability, name)
        params = dict(node.get(name) or {})
        # the factory gets its node's values typed by the schema; with no node (an auto.order name the config
        # leaves out), the schema's defaults, or its own where it has no schema
        if impl.params is not None and dataclasses.is_dataclass(impl.params):
            if name not in node:
                self.check_defaults(capability, name)
            settings = typed_settings(impl.params, params)
            params = {f.name: getattr(settings, f.name) for f in dataclasses.fields(settings)}
        try:
            instance = impl.factory(**params)
        except TypeError as exc:
            raise PsdrRoomError(
                f"{capability}.{name}: invalid parameters ({exc}); see conf/{capability}/{name}.yaml and the stages' _uses_"
            ) from None
        if callable(getattr(instance, "external_files", None)) and impl.reads_files is False:
            raise PsdrRoomError(
                f"{capability}.{name} ({impl.origin}) has external_files but was registered with reads_files=False, "
                "so the files it reads could not join the cache key; register it with reads_files=True"
            )
        protocol = self.registry.protocols.get(capability)
        if protocol is not None and not isinstance(instance, protocol):
            missing = [m for m in dir(protocol) if not m.startswith("_") and not callable(getattr(instance, m, None))]
            raise PsdrRoomError(
                f"{capability}.{name} ({type(instance).__name__}) is not a {capability} implementation: it has no "
                f"{', '.join(missing)} (the {protocol.__module__}.{protocol.__qualname__} protocol)"
            )
        return instance

    def check_defaults(self, capability: str, name: str) -> None:
        """Refuse, in one line, an implementation the config names (in ``auto.order``) but gives no node, whose
        schema leaves settings without a value."""
        from omegaconf import OmegaConf

        schema = self.registry.implementation(capability, name).params
        missing = sorted(OmegaConf.missing_keys(OmegaConf.structured(schema))) if schema is not None else []
        if missing:
            raise PsdrRoomError(
                f"{capability}.{name} has no settings in the config (its schema needs {', '.join(missing)}); add "
                f"{name} to the {capability} group's defaults list, as conf/{capability}/auto.yaml does"
            )

    def first_available(self, capability: str, node: Mapping[str, Any]) -> tuple[str, Any, dict[str, str]]:
        """``<capability>=auto``: the first implementation of ``auto.order`` usable for this photo.

        An implementation is usable unless its ``unavailable(photo)`` (see ``capabilities.Availability``)
        gives a reason; the skipped ones and their reasons are returned for the log and the run record.
        """
        order = list((node.get(AUTO) or {}).get("order") or [])
        if not order:
            raise PsdrRoomError(
                f"{capability}=auto needs a non-empty {capability}.auto.order list; see conf/{capability}/auto.yaml"
            )
        skipped: dict[str, str] = {}
        for name in order:
            if name not in node:  # a config mistake, not a reason to pass over it
                self.check_defaults(capability, name)
            try:
                instance = self.construct(capability, name, node)
                reason = instance.unavailable(self.photo) if isinstance(instance, Availability) else None
            except PsdrRoomError as exc:
                reason = str(exc)
            if reason is None:
                return name, instance, skipped
            skipped[name] = reason
        raise PsdrRoomError(
            f"{capability}=auto: none of {', '.join(order)} is usable for {self.photo} "
            f"({'; '.join(f'{n}: {r}' for n, r in skipped.items())}); choose one with {capability}=NAME"
        )
