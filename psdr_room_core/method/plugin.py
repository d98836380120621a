"""The method as a plugin of the engine (the built-in entry point ``core``): its capabilities, artifact types,
own hooks, stages and run figures, registered here in one place."""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path
from typing import Any

import pluggy

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.records import RunRecord
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import NoSettings

from . import artifacts, hookspecs
from .capabilities import CAPABILITIES, DESCRIPTIONS, PROTOCOLS
from .crops import CROPS_SUFFIX
from .guesses import guesses
from .room_box import RoomInitParams
from .stages import settings

log = logging.getLogger("psdr_room")

STAGES = __package__ + ".stages"
"""The package of the stage modules (:mod:`.stages`)."""


@hookimpl
def add_hookspecs(plugin_manager: pluggy.PluginManager) -> None:
    """The method's own hooks (:mod:`.hookspecs`): model registries, material graphs and nodes."""
    plugin_manager.add_hookspecs(hookspecs)


@hookimpl
def register_capabilities(registry: Registry) -> None:
    """The paper's swappable parts, in pipeline order (:mod:`.capabilities`)."""
    for name in CAPABILITIES:
        registry.add_capability(name, DESCRIPTIONS[name], PROTOCOLS[name])


@hookimpl
def register_artifacts(registry: Registry) -> None:
    """The method's artifact types (:mod:`.artifacts`)."""
    for artifact_type in artifacts.TYPES:
        registry.add_artifact(artifact_type)


@hookimpl
def register_stages(registry: Registry) -> None:
    """The stages of the paper's pipeline; ``conf/stage/*.yaml`` places them in the DAG. By reference: a stage's
    module (and torch, Mitsuba, what it needs) is imported when the stage first computes."""
    registry.add_stage("load_image", f"{STAGES}.preprocess:load_image", reads_photo=True, params=settings.LoadImage)
    registry.add_stage("estimate_fov", f"{STAGES}.preprocess:estimate_fov", uses=["fov"], params=NoSettings)
    registry.add_stage("detect", f"{STAGES}.preprocess:detect", uses=["detector"], params=NoSettings)
    registry.add_stage("segment", f"{STAGES}.preprocess:segment", uses=["segmentation"], version="2", params=NoSettings)
    registry.add_stage(
        "estimate_depth", f"{STAGES}.preprocess:estimate_depth", uses=["depth"], version="2", params=NoSettings
    )
    registry.add_stage("point_cloud", f"{STAGES}.preprocess:point_cloud", params=settings.PointCloud)
    registry.add_stage("room_init", f"{STAGES}.room:room_init", version="2", params=RoomInitParams)
    registry.add_stage(
        "room_fit", f"{STAGES}.room:room_fit", uses=["renderer", "optimizer"], version="2", params=settings.RoomFit
    )
    registry.add_stage(
        "group_objects", f"{STAGES}.objects.group:group_objects", uses=["retrieval"], params=settings.GroupObjects
    )
    registry.add_stage(
        "retrieve_objects",
        f"{STAGES}.objects.retrieve:retrieve_objects",
        uses=["retrieval"],
        version="3",
        params=settings.RetrieveObjects,
    )
    registry.add_stage(
        "place_objects",
        f"{STAGES}.objects.place:place_objects",
        uses=["retrieval"],
        version="4",
        params=settings.PlaceObjects,
    )
    registry.add_stage(
        "fit_objects",
        f"{STAGES}.objects.fit:fit_objects",
        uses=["renderer", "optimizer"],
        version="4",
        params=settings.FitObjects,
    )
    registry.add_stage(
        "assign_materials",
        f"{STAGES}.materials:assign_materials",
        uses=["renderer", "material_graph", "texture"],
        sidecars=[CROPS_SUFFIX],
        version="3",
        params=settings.AssignMaterials,
    )
    registry.add_stage(
        "init_lights",
        f"{STAGES}.lighting:init_lights",
        uses=["renderer", "material_graph", "denoiser"],
        version="3",
        params=settings.InitLights,
    )
    registry.add_stage(
        "fit_appearance",
        f"{STAGES}.appearance:fit_appearance",
        uses=["renderer", "optimizer", "material_graph", "texture", "denoiser"],
        version="5",
        params=settings.FitAppearance,
    )
    registry.add_stage(
        "export_scene",
        f"{STAGES}.export:export_scene",
        uses=["material_graph"],
        version="4",
        params=settings.ExportScene,
    )


@hookimpl
def run_metrics(run: RunRecord) -> dict[str, Any]:
    """Key estimates for ``metrics.json``: the camera (and its error against a synthetic room's ground truth),
    every optimisation log's summary, the room box."""
    out: dict[str, Any] = {}
    camera, room = (
        run.artifact("camera", artifacts.Camera),
        run.artifact(("room_box_fit", "room_box"), artifacts.RoomBox),
    )
    if camera is not None:
        out["camera"] = {
            "vfov_deg": camera.vfov_deg,
            "fx": camera.fx,
            "fy": camera.fy,
            "method": camera.method,
            "confidence": camera.confidence,
        }
        out["vfov_deg"] = camera.vfov_deg
        fitted = run.artifact("camera_fit", artifacts.Camera)
        if fitted is not None:
            out["camera"]["vfov_fit_deg"] = fitted.vfov_deg
        truth = run.photo.parent / "ground_truth.json"
        if truth.is_file():
            intrinsics = json.loads(truth.read_text()).get("intrinsics", {})
            if "fy" in intrinsics and "height" in intrinsics:
                scale = camera.height / float(intrinsics["height"])
                true_vfov = math.degrees(2 * math.atan(0.5 * camera.height / (float(intrinsics["fy"]) * scale)))
                out["camera"]["vfov_error_deg"] = camera.vfov_deg - true_vfov
    for name, artifact in run.artifacts.items():
        if isinstance(artifact, artifacts.OptimizationLog):
            out[name] = artifact.summary
    if room is not None:
        out["room_box"] = {
            "size": [2 * float(h) for h in room.half_size],
            "yaw_deg": math.degrees(float(room.yaw)),
            "camera_height": room.extra.get("camera_height"),
            "ceiling_visible": room.ceiling_visible,
        }
        held = run.artifact("room_box_objects", artifacts.RoomBox)
        if held is not None:  # grown where fit_objects' objects reach beyond it
            out["room_box"]["size_holding_objects"] = [2 * float(h) for h in held.half_size]
    out["guessed"] = guesses(camera, run.artifact("room_box", artifacts.RoomBox))
    return out


@hookimpl
def after_run(run: RunRecord, run_dir: Path) -> None:
    """Say, one line each, what the run guessed because the photo did not show it (:mod:`.guesses`)."""
    for guess in guesses(run.artifact("camera", artifacts.Camera), run.artifact("room_box", artifacts.RoomBox)):
        log.warning("guessed: %s", guess)


@hookimpl
def register_settings(registry: Registry) -> None:
    """The settings several stages share (``priors``: :class:`~psdr_room_core.method.params.Priors`)."""
    from .params import Priors

    registry.add_settings("priors", Priors)
