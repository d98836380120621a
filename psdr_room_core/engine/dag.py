"""The stage graph: composed from config, sorted by its artifacts, sliced, and run through the cache.

A stage node in the composed config is any top-level mapping with a ``_stage_`` key::

    room_init:
      _stage_: room_init                 # registered stage function (plugins' register_stages)
      _inputs_: {cloud: point_cloud}     # function parameter -> artifact name
      _outputs_: {room: room_box}        # function output -> artifact name (a list means same names)
      _uses_: {renderer: {spp: 4}}       # optional: this stage's settings of a capability's implementation,
                                         # over those of conf/<capability>/ (for every implementation)
      ransac_threshold: 0.02             # everything else: the stage's parameters (ctx.params)

Adding, removing or swapping a stage is a config change (``+stage@my_stage=my_stage``,
``~room_fit``, ``stage@room_init=my_room_init``). Stage functions know nothing of caching, Hydra or
progress display: the :class:`Runner` does those, and announces each step through the run-event hooks.
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import logging
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar, cast, overload

from tqdm import tqdm

from . import references
from .artifacts import Artifact, artifact_kind_of
from .cache import Entry, Store, digest_dir, digest_file, stage_key
from .capabilities import Availability
from .errors import PsdrRoomError
from .fingerprint import code_fingerprint
from .memory import PeakMemory
from .plugins import PluginSystem
from .records import RunRecord, StageRecord
from .registry import Registry, StageDef

AUTO = "auto"
"""The implementation name that selects the first usable one of ``<capability>.auto.order``."""

log = logging.getLogger("psdr_room")

RESERVED = ("_stage_", "_inputs_", "_outputs_", "_uses_")


@dataclass(frozen=True)
class StageNode:
    """A stage as placed in the pipeline by the config."""

    name: str
    function: str
    inputs: dict[str, str]
    outputs: dict[str, str]
    params: dict[str, Any]
    uses: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Capability → settings that replace the configured implementation's for this stage only (``_uses_``)."""


def check_stage_inputs(nodes: Iterable[StageNode], registry: Registry) -> None:
    """Check each stage node's ``_inputs_`` against its function's parameters (``fn(ctx, **inputs)``) when the
    pipeline is built, as kedro checks a node's inputs when the node is made: an input the function does not take,
    or a parameter without a default that no input gives, is a one-line :class:`PsdrRoomError` (stage, input,
    expected, found) before any stage runs."""
    for node in nodes:
        stage = registry.stage(node.function)
        parameters = references.parameters(stage.target)[1:]  # after ctx; a reference's read from its source
        if any(p.var_keyword for p in parameters):
            continue
        takes = [p.name for p in parameters if p.keyword]
        needed = [p.name for p in parameters if p.required and p.keyword]
        expected = f"expected {', '.join(takes) or 'none'} (stage function {node.function})"
        for name in node.inputs:
            if name not in takes:
                raise PsdrRoomError(
                    f"stage '{node.name}': input '{name}' is not a parameter of its function; "
                    f"{expected}, found {', '.join(node.inputs)}; fix {node.name}._inputs_"
                )
        for name in needed:
            if name not in node.inputs:
                raise PsdrRoomError(
                    f"stage '{node.name}': no input for parameter '{name}'; {expected}, found "
                    f"{', '.join(node.inputs) or 'none'}; add it to {node.name}._inputs_"
                )


@dataclass(frozen=True)
class Selection:
    """The stages a run considers (in order) and those it recomputes even if cached."""

    stages: list[StageNode]
    forced: frozenset[str]


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


class Pipeline:
    """Stage nodes sorted topologically by the artifacts they consume and produce."""

    def __init__(self, nodes: Iterable[StageNode], provided: Iterable[str] = ()) -> None:
        self.provided = set(provided)
        self.producer: dict[str, StageNode] = {}
        for node in nodes:
            for artifact in node.outputs.values():
                if artifact in self.producer:
                    raise PsdrRoomError(
                        f"artifact '{artifact}' is produced by both stages '{self.producer[artifact].name}' and "
                        f"'{node.name}'; remove one of them from the config"
                    )
                self.producer[artifact] = node
        self.nodes = self._sorted(list(nodes))

    @classmethod
    def from_config(cls, cfg: Mapping[str, Any], provided: Iterable[str] = ()) -> Pipeline:
        """Build the pipeline from the composed config's stage nodes (see module docstring)."""
        nodes = []
        for name, node in cfg.items():
            if not isinstance(node, Mapping) or "_stage_" not in node:
                continue
            outputs = node.get("_outputs_") or {}
            if not isinstance(outputs, Mapping):
                outputs = {o: o for o in outputs}
            nodes.append(
                StageNode(
                    name=str(name),
                    function=str(node["_stage_"]),
                    inputs=dict(node.get("_inputs_") or {}),
                    outputs=dict(outputs),
                    params={k: v for k, v in node.items() if k not in RESERVED},
                    uses={str(c): dict(v) for c, v in (node.get("_uses_") or {}).items()},
                )
            )
        return cls(nodes, provided)

    def _sorted(self, nodes: list[StageNode]) -> list[StageNode]:
        for node in nodes:
            for artifact in node.inputs.values():
                if artifact not in self.producer and artifact not in self.provided:
                    raise PsdrRoomError(
                        f"stage '{node.name}' needs artifact '{artifact}' but no stage produces it; "
                        f"add the producing stage or give it with inject.{artifact}=DIR"
                    )
        order: list[StageNode] = []
        done: set[str] = set()
        pending = list(nodes)
        while pending:  # the first stage in config order whose inputs are ready, one at a time
            ready = next((n for n in pending if all(self._available(a, done) for a in n.inputs.values())), None)
            if ready is None:
                raise PsdrRoomError(f"the stages {', '.join(n.name for n in pending)} form a cycle; fix their _inputs_")
            order.append(ready)
            done.add(ready.name)
            pending.remove(ready)
        return order

    def _available(self, artifact: str, done: set[str]) -> bool:
        return artifact in self.provided or self.producer[artifact].name in done

    def node(self, name: str) -> StageNode:
        for node in self.nodes:
            if node.name == name:
                return node
        raise PsdrRoomError(f"no stage '{name}' in the pipeline; stages: {', '.join(n.name for n in self.nodes)}")

    def upstream(self, name: str) -> set[str]:
        """Names of the stages ``name`` depends on, transitively (excluding itself)."""
        found: set[str] = set()
        stack = [self.node(name)]
        while stack:
            for artifact in stack.pop().inputs.values():
                producer = self.producer.get(artifact)
                if producer is not None and artifact not in self.provided and producer.name not in found:
                    found.add(producer.name)
                    stack.append(producer)
        return found

    def downstream(self, name: str) -> set[str]:
        """Names of the stages that depend on ``name``, transitively (excluding itself)."""
        return {n.name for n in self.nodes if name in self.upstream(n.name)}

    def select(self, only: str | None = None, start: str | None = None, until: str | None = None) -> Selection:
        """Slice the pipeline (kedro-style): ``until`` keeps a stage and what it needs; ``start`` recomputes
        a stage and everything after it; ``only`` recomputes one stage. Upstream outputs come from the cache
        (or are computed when missing)."""
        if only is not None and (start is not None or until is not None):
            raise PsdrRoomError("run.only cannot be combined with run.from or run.until; use one or the other")
        keep = {n.name for n in self.nodes}
        forced: set[str] = set()
        if only is not None:
            keep = self.upstream(only) | {only}
            forced = {only}
        if start is not None:
            forced = self.downstream(start) | {start}
            keep = set().union(*(self.upstream(n) | {n} for n in forced))
        if until is not None:
            keep &= self.upstream(until) | {until}
            forced &= keep
        return Selection(stages=[n for n in self.nodes if n.name in keep], forced=frozenset(forced))


SettingsT = TypeVar("SettingsT")
ImplT = TypeVar("ImplT")


class Deferred:
    """An implementation the engine constructs only when the stage asks for it (:meth:`StageContext.impl`): a
    cached stage never constructs one that reads no files, so a cached run imports none of its libraries."""

    def __init__(self, construct: Callable[[], Any]) -> None:
        self.construct = construct


def typed_settings(schema: type[SettingsT], values: Mapping[str, Any]) -> SettingsT:
    """``values`` (a config node :mod:`.settings` checked against ``schema``) as an instance of ``schema``: typed
    fields, nested settings as their dataclasses, the schema's defaults where the node leaves a key out."""
    from omegaconf import OmegaConf

    return cast(SettingsT, OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(schema), dict(values))))


@dataclass
class StageContext:
    """What a stage function gets besides its input artifacts."""

    stage: str
    params: dict[str, Any]
    seed: int
    photo: Path
    implementations: dict[str, Any]
    timings: dict[str, float] = field(default_factory=dict)
    """Seconds the stage measured of its own work (say, per iteration): kept in the cache entry's manifest and
    ``metrics.json``, never in an artifact, so that no result's digest depends on the clock."""

    def settings(self, schema: type[SettingsT]) -> SettingsT:
        """:attr:`params` as an instance of ``schema``, the dataclass the stage registered them with (checked
        before the run: :mod:`.settings`): typed fields instead of dict lookups and casts."""
        return typed_settings(schema, self.params)

    @overload
    def impl(self, capability: str) -> Any: ...

    @overload
    def impl(self, capability: str, protocol: type[ImplT]) -> ImplT: ...

    def impl(self, capability: str, protocol: type[Any] | None = None) -> Any:
        """The selected implementation of ``capability`` (declared in the stage's ``uses``), typed as
        ``protocol`` (the capability's, which the engine checked when it constructed the implementation)."""
        try:
            implementation = self.implementations[capability]
        except KeyError:
            raise PsdrRoomError(f"stage '{self.stage}' uses capability '{capability}' without declaring it") from None
        if isinstance(implementation, Deferred):
            implementation = self.implementations[capability] = implementation.construct()
        if protocol is not None and not isinstance(implementation, protocol):
            raise PsdrRoomError(
                f"stage '{self.stage}' wants its {capability} to be a {protocol.__qualname__}; "
                f"{type(implementation).__name__} is not"
            )
        return implementation

    def progress(self, iterable: Iterable[Any], total: int | None = None, desc: str | None = None) -> Iterable[Any]:
        """Wrap a loop to show a progress bar (on a terminal)."""
        bar: Iterable[Any] = tqdm(
            iterable, total=total, desc=desc or self.stage, leave=False, disable=None, dynamic_ncols=True
        )
        return bar


class Runner:
    """Runs a selection of a pipeline with the cache, calling the run-event hooks.

    ``cache_mode``: ``readwrite`` reads and commits entries; ``read`` uses existing entries but commits
    nothing to ``store``; ``off`` ignores it. Whatever is not committed to ``store`` is written to
    ``scratch`` (a throwaway store), so downstream stages always see artifacts as saved on disk.
    """

    def __init__(
        self,
        plugins: PluginSystem,
        cfg: Mapping[str, Any],
        photo: Path,
        store: Store,
        scratch: Store,
        cache_mode: str = "readwrite",
        injected: Mapping[str, Path] | None = None,
    ) -> None:
        self.plugins = plugins
        self.cfg = cfg
        self.photo = photo
        self.read_store = store if cache_mode in ("read", "readwrite") else None
        self.write_store = store if cache_mode == "readwrite" else scratch
        self.seed = int(cfg.get("seed", 0))
        self.injected = dict(injected or {})

    def run(self, selection: Selection) -> RunRecord:
        record = RunRecord(photo=self.photo, config=dict(self.cfg))
        self._load_injected(record)
        self.plugins.hook.before_run(run=record)
        # What a stage left in reference cycles goes before the next starts: renderer scenes kept alive that way
        # held ~95 MiB of unevaluated JIT variables that made the next stages' tracing slower (fit_appearance
        # 0.86 -> 0.66 s per iteration after the whole pipeline on the example). What lived before the run
        # (imported libraries, plugins, config) is frozen for it, so a collection costs ~0 s instead of ~0.12 s.
        gc.freeze()
        try:
            for node in selection.stages:
                self._run_stage(node, node.name in selection.forced, record)
                if not record.stages[-1].cached:
                    gc.collect()
        finally:
            gc.unfreeze()
        return record

    def _load_injected(self, record: RunRecord) -> None:
        for name, directory in self.injected.items():
            directory = Path(directory)
            types = self.plugins.registry.artifacts
            record.artifacts[name] = types[artifact_kind_of(directory, types)].load(directory)
            record.digests[name] = digest_dir(directory)

    def _implementations(
        self, node: StageNode, stage: StageDef
    ) -> tuple[dict[str, Any], dict[str, dict[str, Any]], dict[str, str]]:
        """Instantiate the selected implementation of each capability the stage uses, with the node's
        ``_uses_`` settings over the configured ones.

        Returns the instances, their descriptions (part of the cache key) and, for capabilities set to
        ``auto``, how the choice was made (for the run record, not the key: only the choice matters). An
        implementation registered with ``reads_files=False`` and not chosen by ``auto`` is returned
        :class:`Deferred`: the stage constructs it if it computes.
        """
        unknown = sorted(set(node.uses) - set(stage.uses))
        if unknown:
            raise PsdrRoomError(
                f"stage '{node.name}': _uses_ names {', '.join(unknown)}, which the stage does not use "
                f"(it uses {', '.join(stage.uses) or 'none'}); remove them from its config"
            )
        instances, described, selected_by = {}, {}, {}
        for capability in stage.uses:
            group = self.cfg.get(capability)
            if not isinstance(group, Mapping) or "impl" not in group:
                raise PsdrRoomError(
                    f"stage '{stage.name}' needs the '{capability}' config group; add {capability}=NAME"
                )
            group = with_settings(group, node.uses.get(capability, {}))
            name = str(group["impl"])
            if name == AUTO:
                name, instances[capability], skipped = self._first_available(capability, group)
                selected_by[capability] = "auto" + "".join(f"; not {n}: {why}" for n, why in skipped.items())
                log.info("%s=auto selected %s (%s)", capability, name, selected_by[capability])
            impl = self.plugins.registry.implementation(capability, name)
            if capability not in instances:  # auto constructed its choice to ask whether it is usable
                construct = functools.partial(self._construct, capability, name, group)
                instances[capability] = Deferred(construct) if impl.reads_files is False else construct()
            described[capability] = {
                "name": name,
                "version": impl.version,
                "code": code_fingerprint(impl.target),
                "params": dict(group.get(name) or {}),
            }
        return instances, described, selected_by

    def _construct(self, capability: str, name: str, node: Mapping[str, Any]) -> Any:
        impl = self.plugins.registry.implementation(capability, name)
        params = dict(node.get(name) or {})
        # the factory gets its node's values typed by the schema; with no node (an auto.order name the config
        # leaves out), its own defaults
        if name in node and impl.params is not None and dataclasses.is_dataclass(impl.params):
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
        protocol = self.plugins.registry.protocols.get(capability)
        if protocol is not None and not isinstance(instance, protocol):
            missing = [m for m in dir(protocol) if not m.startswith("_") and not callable(getattr(instance, m, None))]
            raise PsdrRoomError(
                f"{capability}.{name} ({type(instance).__name__}) is not a {capability} implementation: it has no "
                f"{', '.join(missing)} (the {protocol.__module__}.{protocol.__qualname__} protocol)"
            )
        return instance

    def _first_available(self, capability: str, node: Mapping[str, Any]) -> tuple[str, Any, dict[str, str]]:
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
            try:
                instance = self._construct(capability, name, node)
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

    def _external_files(self, stage: StageDef, instances: Mapping[str, Any]) -> dict[str, str]:
        files: dict[str, Path] = {}
        if stage.reads_photo:
            files["photo"] = self.photo
        for suffix in stage.sidecars:
            files[f"sidecar:{suffix}"] = self.photo.with_name(self.photo.stem + suffix)
        for capability, instance in instances.items():
            if isinstance(instance, Deferred):  # registered as reading no files
                continue
            for i, path in enumerate(getattr(instance, "external_files", lambda _p: [])(self.photo)):
                files[f"{capability}[{i}]:{Path(path).name}"] = Path(path)
        return {role: (digest_file(p) if p.is_file() else "absent") for role, p in files.items()}

    def _run_stage(self, node: StageNode, forced: bool, record: RunRecord) -> None:
        stage = self.plugins.registry.stage(node.function)
        inputs = {param: record.artifacts[artifact] for param, artifact in node.inputs.items()}
        instances, described, selected_by = self._implementations(node, stage)
        key = stage_key(
            stage=node.name,
            function=stage.name,
            function_version=stage.version,
            function_code=code_fingerprint(stage.target),
            config={"params": node.params, "seed": self.seed, "outputs": node.outputs},
            implementations=described,
            inputs={param: record.digests[artifact] for param, artifact in node.inputs.items()},
            files=self._external_files(stage, instances),
        )
        for capability, d in described.items():
            impl = self.plugins.registry.implementation(capability, d["name"])
            record.implementations[capability] = {
                "name": d["name"],
                "version": impl.version,
                "origin": str(impl.origin),
            }
            if capability in selected_by:
                record.implementations[capability]["selected_by"] = selected_by[capability]
        start = time.perf_counter()
        with PeakMemory() as peak:
            entry = self._lookup(key, forced)
            cached = entry is not None
            if entry is None:
                with self.write_store.lock(key):  # a concurrent run may be computing this entry: wait for it
                    entry = self._lookup(key, forced)
                    cached = entry is not None
                    if entry is None:
                        entry = self._compute(node, stage, key, inputs, instances, forced)
            outputs = {name: entry.load(name, self.plugins.registry.artifacts) for name in node.outputs}
        for name, artifact_name in node.outputs.items():
            record.artifacts[artifact_name] = outputs[name]
            record.digests[artifact_name] = entry.digests[name]
            record.saved[artifact_name] = entry.path / name
        stage_record = StageRecord(
            name=node.name,
            function=stage.name,
            key=key,
            cached=cached,
            seconds=time.perf_counter() - start,
            compute_seconds=float(entry.manifest.get("seconds", 0.0)),
            outputs={node.outputs[n]: d for n, d in entry.digests.items()},
            implementations={c: d["name"] for c, d in described.items()},
            peak_rss_mb=peak.megabytes,
            timings=dict(entry.manifest.get("timings") or {}),
        )
        record.stages.append(stage_record)
        self.plugins.hook.after_stage(record=stage_record, outputs=outputs)

    def _lookup(self, key: str, forced: bool) -> Entry | None:
        return None if forced or self.read_store is None else self.read_store.lookup(key)

    def _compute(
        self,
        node: StageNode,
        stage: StageDef,
        key: str,
        inputs: dict[str, Artifact],
        instances: dict[str, Any],
        forced: bool,
    ) -> Entry:
        ctx = StageContext(
            stage=node.name, params=dict(node.params), seed=self.seed, photo=self.photo, implementations=instances
        )
        self.plugins.hook.before_stage(stage=node.name, key=key, inputs=inputs)
        start = time.perf_counter()
        try:
            result = stage.fn(ctx, **inputs)
            outputs = self._check_outputs(node, result)
            return self.write_store.commit(
                key, node.name, outputs, time.perf_counter() - start, replace=forced, timings=ctx.timings
            )
        except BaseException as exc:
            self.plugins.hook.on_stage_error(stage=node.name, key=key, error=exc)
            raise

    @staticmethod
    def _check_outputs(node: StageNode, result: Any) -> dict[str, Artifact]:
        if len(node.outputs) == 1 and not isinstance(result, Mapping):
            result = {next(iter(node.outputs)): result}
        if not isinstance(result, Mapping) or set(result) != set(node.outputs):
            got = sorted(result) if isinstance(result, Mapping) else type(result).__name__
            raise PsdrRoomError(f"stage '{node.name}' returned {got}, but its _outputs_ are {sorted(node.outputs)}")
        for name, value in result.items():
            if not isinstance(value, Artifact):
                raise PsdrRoomError(f"stage '{node.name}' output '{name}' is a {type(value).__name__}, not an artifact")
        return dict(result)
