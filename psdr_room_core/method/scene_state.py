"""The schema of a scene folder's ``appearance.json``: a scene folder may come from anywhere, so everything in
it is checked (types, ranges, names, library materials) before anything is allocated or rendered.

:func:`read_state` reads and checks a file; :func:`check_state` checks a state in memory (``psdr-room-edit``
calls it again after its edits, so an edit outside a value's range is refused with that range, the same
way for every value). The file is parsed only within :data:`LIMITS`; every error is one line naming the file and
the value's place in it, showing at most :data:`~psdr_room_core.engine.bounded.ECHO` characters of the value.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from psdr_room_core.engine.bounded import JsonLimits, excerpt, load_json
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.ownership import plain_name

PART_KINDS = ("homogeneous", "procedural")
LIGHT_KINDS = ("ceiling", "behind_camera", "invisible_wall", "window", "lamp")
RANGES: dict[str, tuple[float, float]] = {
    "camera.width": (8, 16384),
    "camera.height": (8, 16384),
    "camera.fx": (1e-3, 1e7),
    "camera.fy": (1e-3, 1e7),
    "camera.cx": (-1e6, 1e6),
    "camera.cy": (-1e6, 1e6),
    "texture_size": (8, 4096),
    "base_color": (0.0, 1.0),
    "roughness": (0.0, 1.0),
    "specular": (0.0, 1.0),
    "scale": (1e-3, 1e3),
    "rotation": (-1e4, 1e4),
    "radiance": (0.0, 1e6),
}
"""Allowed closed range of each number (``texture_size``: pixels per side of a baked map, at most 4096 so that a
scene folder cannot make the editor allocate gigabytes)."""
TOP_KEYS = ("camera", "camera_to_world", "parts", "lights", "fixtures", "texture_size")
PART_KEYS = ("part", "kind", "base_color", "roughness", "specular", "material", "scale", "rotation", "params")
LIMITS = JsonLimits(max_bytes=64_000_000, max_string=4096)
"""What an ``appearance.json`` may hold: its strings are names and kinds."""


def read_state(path: Path, library: Any) -> dict[str, Any]:
    """``appearance.json`` at ``path``, checked by :func:`check_state` against the material ``library``."""
    try:
        state = load_json(path, LIMITS, "re-export the scene")
    except json.JSONDecodeError as exc:
        raise PsdrRoomError(f"{path}: invalid JSON ({exc.msg} at line {exc.lineno}); re-export the scene") from None
    except UnicodeDecodeError:
        raise PsdrRoomError(f"{path}: not UTF-8 text; re-export the scene") from None
    if not isinstance(state, dict):
        raise PsdrRoomError(f"{path}: expected a JSON object; re-export the scene")
    missing = [k for k in TOP_KEYS if k not in state]
    if missing:
        raise PsdrRoomError(f"{path}: missing {', '.join(missing)}; re-export the scene with this version")
    check_state(state, library, str(path))
    return state


def check_state(state: Mapping[str, Any], library: Any, source: str) -> None:
    """Raise a one-line error naming ``source`` and the value's place unless ``state`` fits the schema."""
    check = _Checker(source)
    camera = check.mapping(state["camera"], "camera", ("width", "height", "fx", "fy", "cx", "cy"))
    for key in ("width", "height"):
        check.number(camera[key], f"camera.{key}", integer=True)
    for key in ("fx", "fy", "cx", "cy"):
        check.number(camera[key], f"camera.{key}")
    matrix = state["camera_to_world"]
    if not (isinstance(matrix, list) and len(matrix) == 4 and all(isinstance(r, list) and len(r) == 4 for r in matrix)):
        check.fail("camera_to_world", matrix, "a 4x4 list of numbers")
    for i, row in enumerate(matrix):
        for j, value in enumerate(row):
            check.number(value, f"camera_to_world[{i}][{j}]", limits=(-1e6, 1e6))
    check.number(state["texture_size"], "texture_size", integer=True)
    names = []
    for i, part in enumerate(check.items(state["parts"], "parts")):
        where = f"parts[{i}]"
        part = check.mapping(part, where, PART_KEYS[:3], optional=PART_KEYS[3:])
        name = plain_name(part["part"], Path(source), "part")
        names.append(name)
        where = f"part {name}"
        if part["kind"] not in PART_KINDS:
            check.fail(f"{where}: kind", part["kind"], f"one of {', '.join(PART_KINDS)}")
        check.rgb(part["base_color"], f"{where}: base_color", "base_color")
        for key in ("roughness", "specular", "scale", "rotation"):
            if key in part:
                check.number(part[key], f"{where}: {key}", limits=RANGES[key])
        if part["kind"] == "procedural":
            check_graph(part.get("material"), part.get("params") or {}, library, f"{source}: {where}")
    for i, light in enumerate(check.items(state["lights"], "lights")):
        light = check.mapping(light, f"lights[{i}]", ("name", "kind", "part", "radiance"))
        name = plain_name(light["name"], Path(source), "light")
        if light["kind"] not in LIGHT_KINDS:
            check.fail(f"light {name}: kind", light["kind"], f"one of {', '.join(LIGHT_KINDS)}")
        if light["part"] is not None and light["part"] not in names:
            check.fail(f"light {name}: part", light["part"], f"null or a part: {', '.join(names)}")
        check.rgb(light["radiance"], f"light {name}: radiance", "radiance")
    for fixture in check.items(state["fixtures"], "fixtures"):
        plain_name(fixture, Path(source), "fixture")


def check_graph(material: Any, params: Any, library: Any, where: str) -> None:
    """A procedural part's ``material`` is in the ``library`` and its ``params`` are the graph's parameters, of
    their shapes and inside their ranges."""
    if not isinstance(material, str) or material not in library.names():
        raise PsdrRoomError(
            f"{where}: material {excerpt(repr(material))} is not in the library; `psdr-room-materials list` shows them"
        )
    if not isinstance(params, Mapping):
        raise PsdrRoomError(f"{where}: params must be an object of graph parameters")
    bounds = library.material(material).bounds
    for key, value in params.items():
        if key not in bounds:
            raise PsdrRoomError(f"{where}: {material} has no parameter '{excerpt(key)}'; it has {', '.join(bounds)}")
        bound = bounds[key]
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            array = np.asarray(np.nan)
        if array.shape != tuple(bound.value.shape) or not np.all(np.isfinite(array)):
            raise PsdrRoomError(
                f"{where}: {key}={excerpt(json.dumps(value))} is invalid; "
                f"allowed: numbers of shape {tuple(bound.value.shape)}"
            )
        lo, hi = np.asarray(bound.lo, dtype=np.float32), np.asarray(bound.hi, dtype=np.float32)
        single = array.astype(np.float32)  # the graph's precision: a slider's 0.05 is its bound float32(0.05)
        if np.any(single < lo) or np.any(single > hi):
            raise PsdrRoomError(
                f"{where}: {key}={excerpt(json.dumps(value))} is out of range; allowed: {_span(lo)} to {_span(hi)}"
            )


class _Checker:
    """One-line errors naming the source file (or edit) and the value's place."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, where: str, value: Any, allowed: str) -> None:
        raise PsdrRoomError(f"{self.source}: {where}={excerpt(json.dumps(value))} is invalid; allowed: {allowed}")

    def mapping(
        self, value: Any, where: str, required: tuple[str, ...], optional: tuple[str, ...] = ()
    ) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            self.fail(where, value, "an object")
        missing = [k for k in required if k not in value]
        unknown = [k for k in value if k not in (*required, *optional)]
        if missing or unknown:
            what = (
                f"missing {', '.join(missing)}"
                if missing
                else f"unknown key(s) {excerpt(', '.join(map(str, unknown)))}"
            )
            raise PsdrRoomError(f"{self.source}: {where}: {what}; re-export the scene")
        return value

    def items(self, value: Any, where: str) -> list[Any]:
        if not isinstance(value, list):
            self.fail(where, value, "a list")
        return value

    def number(self, value: Any, where: str, integer: bool = False, limits: tuple[float, float] | None = None) -> None:
        lo, hi = limits or RANGES[where]
        ok_type = isinstance(value, int) if integer else isinstance(value, (int, float))
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not ok_type or not math.isfinite(value):
            self.fail(where, value, f"{kind} from {lo:g} to {hi:g}")
        if not lo <= value <= hi:
            raise PsdrRoomError(
                f"{self.source}: {where}={excerpt(json.dumps(value))} is out of range; "
                f"allowed: {kind} from {lo:g} to {hi:g}"
            )

    def rgb(self, value: Any, where: str, key: str) -> None:
        if not isinstance(value, list) or len(value) != 3:
            self.fail(where, value, "[r, g, b]")
        for channel in value:
            self.number(channel, where, limits=RANGES[key])


def _span(bound: np.ndarray) -> str:
    return f"{float(bound):g}" if bound.ndim == 0 else json.dumps(bound.tolist())
