"""One run: composed config in, artifacts, ``metrics.json`` and a report out (in the Hydra run directory)."""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import InterpolationResolutionError, MissingMandatoryValue

from .artifacts import Artifact
from .cache import CACHE_MODES, Store
from .dag import Pipeline, RunRecord, Runner
from .errors import PsdrRoomError
from .ownership import check_writable_into, claim
from .plugins import PluginSystem, plugin_system
from .settings import check_config

PUBLISH_AS = {"scene_files": "scene"}
"""Artifact kinds that are also published at the top of the run directory, under this name."""
PUBLISHED = ("artifacts", *PUBLISH_AS.values(), "metrics.json", "run.json")
"""What :func:`publish` writes (and replaces) in the run directory."""


def resolve_config(cfg: DictConfig) -> dict[str, Any]:
    """The composed config as plain data, with one-line errors for missing or unresolvable values."""
    try:
        data = OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)
    except MissingMandatoryValue as exc:
        key = exc.full_key or "?"
        hint = "image=PATH/TO/photo.jpg" if key == "image" else f"{key}=VALUE"
        raise PsdrRoomError(f"{key} is required; add {hint} to the command line") from None
    except InterpolationResolutionError as exc:
        raise PsdrRoomError(f"config value {exc.full_key} cannot be resolved: {str(exc).splitlines()[0]}") from None
    assert isinstance(data, dict)
    return data


def execute(cfg: DictConfig, run_dir: Path, plugins: PluginSystem | None = None) -> RunRecord:
    """Run the configured pipeline and publish its results in ``run_dir``."""
    plugins = plugins or plugin_system()
    data = resolve_config(cfg)
    mode = str(data["cache"])
    if mode not in CACHE_MODES:
        raise PsdrRoomError(f"cache={mode} is not a cache mode; use one of {', '.join(CACHE_MODES)}")
    check_writable_into(run_dir, PUBLISHED, "run directory")
    photo = Path(str(data["image"])).expanduser().absolute()
    injected = {name: Path(str(path)).expanduser().absolute() for name, path in (data.get("inject") or {}).items()}
    pipeline = Pipeline.from_config(data, provided=injected)
    check_config(data, pipeline.nodes, plugins.registry)
    run = data["run"]
    selection = pipeline.select(only=run.get("only"), start=run.get("from"), until=run.get("until"))
    store = Store(Path(str(data["cache_dir"])))
    with tempfile.TemporaryDirectory(prefix="psdr-room-scratch-") as scratch:
        runner = Runner(plugins, data, photo, store, Store(Path(scratch)), mode, injected)
        record = runner.run(selection)
    publish(record, run_dir, data)
    plugins.hook.after_run(run=record, run_dir=run_dir)
    return record


def metrics(record: RunRecord) -> dict[str, Any]:
    """The run's numbers: per-stage wall time and cache hits, implementations, and key estimates."""
    out: dict[str, Any] = {
        "stages": {
            r.name: {"seconds": round(r.seconds, 4), "compute_seconds": round(r.compute_seconds, 4),
                     "cached": r.cached, "key": r.key}
            for r in record.stages
        },
        "total_seconds": round(sum(r.seconds for r in record.stages), 4),
        "implementations": record.implementations,
        "digests": record.digests,
    }
    camera = record.artifacts.get("camera")
    if camera is not None:
        out["camera"] = {"vfov_deg": camera.vfov_deg, "fx": camera.fx, "fy": camera.fy,
                         "method": camera.method, "confidence": camera.confidence}
        out["vfov_deg"] = camera.vfov_deg
        if "camera_fit" in record.artifacts:
            out["camera"]["vfov_fit_deg"] = record.artifacts["camera_fit"].vfov_deg
        truth = record.photo.parent / "ground_truth.json"
        if truth.is_file():
            intrinsics = json.loads(truth.read_text()).get("intrinsics", {})
            if "fy" in intrinsics and "height" in intrinsics:
                scale = camera.height / float(intrinsics["height"])
                true_vfov = math.degrees(2 * math.atan(0.5 * camera.height / (float(intrinsics["fy"]) * scale)))
                out["camera"]["vfov_error_deg"] = camera.vfov_deg - true_vfov
    for name, artifact in record.artifacts.items():
        if artifact.kind == "optimization_log":
            out[name] = artifact.summary
    room = record.artifacts.get("room_box_fit", record.artifacts.get("room_box"))
    if room is not None:
        out["room_box"] = {"size": [2 * float(h) for h in room.half_size], "yaw_deg": math.degrees(float(room.yaw)),
                           "camera_height": room.extra.get("camera_height"), "ceiling_visible": room.ceiling_visible}
    return out


def publish(record: RunRecord, run_dir: Path, data: Mapping[str, Any]) -> None:
    """Write every artifact under ``artifacts/<name>/``, the scene under ``scene/``, ``metrics.json`` and
    ``run.json``; all of it appears at once (staged in a hidden directory, then moved into place). The run
    directory is marked as ours (:mod:`~psdr_room_core.ownership`): a rerun into it may replace these."""
    run_dir.mkdir(parents=True, exist_ok=True)
    claim(run_dir)  # execute() refused a run directory holding files of the user's before any stage ran
    staging = Path(tempfile.mkdtemp(prefix=".publishing-", dir=run_dir))
    try:
        for name, artifact in record.artifacts.items():
            _save(artifact, staging / "artifacts" / name)
            if artifact.kind in PUBLISH_AS:
                _save(artifact, staging / PUBLISH_AS[artifact.kind])
        (staging / "metrics.json").write_text(json.dumps(metrics(record), indent=2) + "\n")
        (staging / "run.json").write_text(json.dumps(
            {"photo": str(record.photo), "implementations": record.implementations,
             "stages": [r.name for r in record.stages], "config": data}, indent=2, default=str) + "\n")
        for item in staging.iterdir():
            target = run_dir / item.name
            if target.is_dir():
                shutil.rmtree(target)
            os.replace(item, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _save(artifact: Artifact, directory: Path) -> None:
    directory.mkdir(parents=True)
    artifact.save(directory)
