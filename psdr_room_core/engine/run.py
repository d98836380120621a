"""One run: composed config in, artifacts, ``metrics.json`` and a report out (in the Hydra run directory)."""

from __future__ import annotations

import json
import logging
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import InterpolationResolutionError, MissingMandatoryValue

from .artifacts import Artifact
from .cache import CACHE_MODES, Store
from .debris import scratch_dir, sweep
from .errors import PsdrRoomError
from .files import WRITING, move_into_place
from .graph import Pipeline, check_stage_inputs
from .interrupts import sigterm_interrupts
from .ownership import check_writable_into, claim
from .plugins import PluginSystem, plugin_system
from .records import RunRecord
from .runner import Runner
from .settings import check_config
from .stage_config import stage_nodes

log = logging.getLogger("psdr_room")

PUBLISHING = "publishing"
"""The scratch kind of :func:`publish`'s staging folder."""
STORE = "run_store"
"""The scratch kind of the store a run keeps the results it does not cache in, in its run folder."""

PUBLISHED = ("artifacts", "metrics.json", "run.json")
"""What :func:`publish` writes (and replaces) in every run directory; an artifact type with a ``published_as``
class attribute is also written at the top of it, under that name (see :func:`published`)."""


def published(plugins: PluginSystem) -> tuple[str, ...]:
    """The names :func:`publish` may write in a run directory with these plugins' artifact types."""
    tops = (getattr(t, "published_as", None) for t in plugins.registry.artifacts.values())
    return (*PUBLISHED, *sorted({name for name in tops if name}))


def resolve_config(cfg: DictConfig, *, missing_ok: bool = False) -> dict[str, Any]:
    """The composed config as plain data, with one-line errors for missing or unresolvable values; with
    ``missing_ok``, a missing value (``???``, as ``image`` before one is given) stays as it is."""
    try:
        data = OmegaConf.to_container(cfg, resolve=True, throw_on_missing=not missing_ok)
    except MissingMandatoryValue as exc:
        key = exc.full_key or "?"
        hint = "image=PATH/TO/photo.jpg" if key == "image" else f"{key}=VALUE"
        raise PsdrRoomError(f"{key} is required; add {hint} to the command line") from None
    except InterpolationResolutionError as exc:
        raise PsdrRoomError(f"config value {exc.full_key} cannot be resolved: {str(exc).splitlines()[0]}") from None
    assert isinstance(data, dict)
    return {str(key): value for key, value in data.items()}


def plan(data: Mapping[str, Any], plugins: PluginSystem) -> tuple[Pipeline, dict[str, Path]]:
    """The pipeline of a resolved config and its injected artifact folders, every key and setting checked
    (the command line calls it before Hydra writes anything; :func:`execute` again)."""
    mode = str(data["cache"])
    if mode not in CACHE_MODES:
        raise PsdrRoomError(f"cache={mode} is not a cache mode; use one of {', '.join(CACHE_MODES)}")
    injected = {name: Path(str(path)).expanduser().absolute() for name, path in (data.get("inject") or {}).items()}
    pipeline = Pipeline.from_config(data, provided=injected)
    check_stage_inputs(pipeline.nodes, plugins.registry)
    check_config(data, stage_nodes(data), plugins.registry)  # a stage replaced by what was given too
    return pipeline, injected


def execute(cfg: DictConfig, run_dir: Path, plugins: PluginSystem | None = None) -> RunRecord:
    """Run the configured pipeline and publish its results in ``run_dir``, first removing what a killed run left
    there (:mod:`.debris`). SIGTERM stops it as Ctrl-C does (:mod:`.interrupts`)."""
    plugins = plugins or plugin_system()
    data = resolve_config(cfg)
    pipeline, injected = plan(data, plugins)
    mode = str(data["cache"])
    check_writable_into(run_dir, published(plugins), "run directory")
    for kind in (PUBLISHING, STORE, WRITING):
        sweep(run_dir, kind)
    photo = Path(str(data["image"])).expanduser().absolute()
    run = data["run"]
    selection = pipeline.select(only=run.get("only"), start=run.get("from"), until=run.get("until"))
    store = Store(Path(str(data["cache_dir"])))
    if mode == "readwrite" and not store.writable():
        log.warning(
            "cache_dir=%s is read-only: finished stages are read from it, new results are not stored "
            "(set cache_dir= to a writable folder to keep them)",
            store.root,
        )
        mode = "read"
    scratch = scratch_dir(run_dir, STORE)
    try:
        with sigterm_interrupts():
            runner = Runner(plugins, data, photo, store, Store(scratch), mode, injected)
            record = runner.run(selection)
            publish(record, run_dir, data, plugins)  # copies from the scratch store too
            plugins.hook.after_run(run=record, run_dir=run_dir)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return record


def metrics(record: RunRecord, plugins: PluginSystem) -> dict[str, Any]:
    """The run's numbers: per-stage wall time, peak memory and cache hits, implementations and digests, then what the
    plugins add (``run_metrics``)."""
    out: dict[str, Any] = {
        "stages": {
            r.name: {
                "seconds": round(r.seconds, 4),
                "compute_seconds": round(r.compute_seconds, 4),
                "peak_rss_mb": round(r.peak_rss_mb, 1),
                **({"timings": {k: round(v, 4) for k, v in r.timings.items()}} if r.timings else {}),
                "cached": r.cached,
                "key": r.key,
            }
            for r in record.stages
        },
        "total_seconds": round(sum(r.seconds for r in record.stages), 4),
        "implementations": record.implementations,
        "digests": record.digests,
    }
    for figures in plugins.hook.run_metrics(run=record):
        out.update(figures or {})
    return out


def publish(record: RunRecord, run_dir: Path, data: Mapping[str, Any], plugins: PluginSystem) -> None:
    """Write every artifact under ``artifacts/<name>/`` (and at ``<published_as>/`` when its type has one, as the
    method's exported scene does), ``metrics.json`` and ``run.json``. All of it is written in a scratch folder of kind
    :data:`PUBLISHING` in ``run_dir``, then each entry renamed into place (:func:`~.files.move_into_place`): each
    appears whole, and a run killed meanwhile leaves only that scratch folder. The run directory is marked as ours
    (:mod:`~psdr_room_core.engine.ownership`): a rerun into it may replace these."""
    run_dir.mkdir(parents=True, exist_ok=True)
    claim(run_dir)  # execute() refused a run directory holding files of the user's before any stage ran
    staging = scratch_dir(run_dir, PUBLISHING)
    try:
        for name, artifact in record.artifacts.items():
            _save(artifact, staging / "artifacts" / name, record.saved.get(name))
            top = getattr(type(artifact), "published_as", None)
            if top:
                _save(artifact, staging / top, record.saved.get(name))
        (staging / "metrics.json").write_text(json.dumps(metrics(record, plugins), indent=2) + "\n")
        (staging / "run.json").write_text(
            json.dumps(
                {
                    "photo": str(record.photo),
                    "implementations": record.implementations,
                    "stages": [r.name for r in record.stages],
                    "config": data,
                },
                indent=2,
                default=str,
            )
            + "\n"
        )
        for item in sorted(staging.iterdir()):
            move_into_place(item, run_dir / item.name, PUBLISHING)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _save(artifact: Artifact, directory: Path, entry: Path | None) -> None:
    """``artifact``'s files in ``directory``: copied from the cache entry it was read from (the bytes its type
    saved, without encoding them again), else saved anew (an entry pruned meanwhile, an injected artifact)."""
    directory.mkdir(parents=True)
    if entry is not None and entry.is_dir():
        try:
            for file in sorted(entry.rglob("*")):
                if file.is_file():  # contents only: the copies get the user's own permissions, as saved files do
                    (directory / file.relative_to(entry)).parent.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(file, directory / file.relative_to(entry))
            return
        except OSError:
            shutil.rmtree(directory, ignore_errors=True)
            directory.mkdir(parents=True)
    artifact.save(directory)
