"""``psdr-room-edit``: change an exported scene's materials, lights or camera and re-render it (paper Fig. 8),
without re-running any optimisation.

    psdr-room-edit outputs/.../scene material.floor=herringbone_oak material.floor.scale=2
    psdr-room-edit outputs/.../scene material.object_7_body.base_color=[0.6,0.1,0.1] light.scale=1.5 camera.fov=60

Edits (``KEY=VALUE``, values in YAML):

* ``material.<part>=<library graph>``: the part wears that procedural material (its own parameter values,
  the part's texture transform kept);
* ``material.<part>=homogeneous``: the part becomes a flat colour (its current mean colour);
* ``material.<part>.<node>.<param>=<value>``: a graph parameter of a procedural part;
* ``material.<part>.base_color|roughness|specular|scale|rotation=<value>``: base colour (linear RGB, of a
  homogeneous part), roughness, specular, and the texture transform of a procedural one;
* ``light.scale=<s or [r, g, b]>``: every light's radiance times ``s`` (per channel for ``[r, g, b]``: a colour
  filter that warms or cools the light); ``light.<name>.radiance=<rgb or number>``;
* ``camera.fov=<degrees>``: the vertical field of view.

A value outside its range (a graph parameter's, roughness 0..1, ...) is refused with the range, never clamped.

The edited scene is written to ``--out`` (default ``<scene>-edited``) as a complete scene folder (XML,
meshes, maps, ``scene.glb``, ``appearance.json``), and rendered to ``render.png`` there (denoised by
``--denoiser``, default ``oidn``).
"""

from __future__ import annotations

import argparse
import logging
import math
import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from psdr_room_core.engine.debris import scratch_dir, sweep
from psdr_room_core.engine.errors import PsdrRoomError, exit_status
from psdr_room_core.engine.files import check_creatable, move_into_place
from psdr_room_core.engine.ownership import check_replaceable, claim
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.method.artifacts import Light, PartAppearance, appearance_fields, vec3, write_png
from psdr_room_core.method.geometry import TriangleMesh
from psdr_room_core.method.rgb_scene import build_scene, to_srgb8
from psdr_room_core.method.scene_state import check_state, read_state
from psdr_room_core.method.stages.export import read_mesh_ply, scene_folder

HOMOGENEOUS_KEYS = ("base_color", "roughness", "specular")
EDIT = "edit"
"""The scratch kind of an edited scene being written (beside ``--out``)."""


def load_state(scene_dir: Path, library: Any) -> dict[str, Any]:
    """A scene folder's ``appearance.json``, checked against the schema (:mod:`psdr_room_core.method.scene_state`)
    and ``library``."""
    path = scene_dir / "appearance.json"
    if not path.is_file():
        raise PsdrRoomError(f"{scene_dir}: no appearance.json; pass the scene/ folder of a psdr-room run")
    return read_state(path, library)


def apply_edit(state: dict[str, Any], key: str, raw: str, library: Any) -> None:
    """Apply one ``KEY=VALUE`` edit to a scene state in place (see the module docstring); a value outside its
    range is refused with the range (the scene's schema, :func:`psdr_room_core.method.scene_state.check_state`)."""
    try:
        value = yaml.safe_load(raw)
    except yaml.YAMLError:
        raise PsdrRoomError(f"edit {key}={raw}: the value is not valid YAML") from None
    head, _, rest = key.partition(".")
    if head == "camera" and rest == "fov":
        fov = _number(value, key)
        if not 1.0 < fov < 179.0:
            raise PsdrRoomError(f"edit {key}={raw}: the field of view must be between 1 and 179 degrees")
        camera = state["camera"]
        camera["fy"] = camera["fx"] = 0.5 * camera["height"] / math.tan(math.radians(fov) / 2.0)
    elif head == "light":
        _edit_light(state, key, rest, value)
    elif head == "material" and rest:
        _edit_material(state, key, rest, value, library)
    else:
        raise PsdrRoomError(
            f"edit {key}: unknown; use material.<part>[.<param>], light.scale, light.<name>.radiance or camera.fov"
        )
    check_state(state, library, f"edit {key}={raw}")


def _number(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise PsdrRoomError(f"edit {key}: expected a number, got {value!r}")
    return float(value)


def _rgb(value: Any, key: str) -> list[float]:
    values = [value] * 3 if isinstance(value, (int, float)) else value
    if not isinstance(values, list) or len(values) != 3:
        raise PsdrRoomError(f"edit {key}: expected a number or [r, g, b], got {value!r}")
    return [_number(v, key) for v in values]


def _edit_light(state: dict[str, Any], key: str, rest: str, value: Any) -> None:
    if rest == "scale":
        scale = _rgb(value, key)
        if min(scale) < 0:
            raise PsdrRoomError(f"edit {key}: the scale must be >= 0")
        for light in state["lights"]:
            light["radiance"] = [s * c for s, c in zip(scale, light["radiance"])]
        return
    name, _, field = rest.rpartition(".")
    light = next((l for l in state["lights"] if l["name"] == name), None)
    if light is None or field != "radiance":
        names = ", ".join(l["name"] for l in state["lights"])
        raise PsdrRoomError(f"edit {key}: use light.scale or light.<name>.radiance; lights: {names}")
    light["radiance"] = _rgb(value, key)


def _edit_material(state: dict[str, Any], key: str, rest: str, value: Any, library: Any) -> None:
    names = [p["part"] for p in state["parts"]]
    part_name = next((n for n in sorted(names, key=len, reverse=True) if rest == n or rest.startswith(n + ".")), None)
    if part_name is None:
        raise PsdrRoomError(f"edit {key}: no part '{rest.split('.')[0]}'; parts: {', '.join(names)}")
    index = names.index(part_name)
    part = PartAppearance(**{**state["parts"][index], "base_color": tuple(state["parts"][index]["base_color"])})
    field = rest[len(part_name) + 1 :]
    if not field:
        if value == "homogeneous":
            part = replace(part, kind="homogeneous", material=None, params={})
        elif isinstance(value, str) and value in library.names():
            graph = library.material(value)
            part = replace(
                part, kind="procedural", material=value, params={k: b.value.tolist() for k, b in graph.bounds.items()}
            )
        else:
            raise PsdrRoomError(f"edit {key}={value}: not a library material; `psdr-room-materials list` shows them")
    elif field in HOMOGENEOUS_KEYS:
        if field == "base_color":
            if part.kind != "homogeneous":
                raise PsdrRoomError(f"edit {key}: {part_name} is procedural; edit its graph's colour parameters")
            part = replace(part, base_color=vec3(_rgb(value, key)))
        else:
            number_change: dict[str, Any] = {field: _number(value, key)}
            part = replace(part, **number_change)
    elif field in ("scale", "rotation"):
        number = _number(value, key)
        if field == "scale" and number <= 0:
            raise PsdrRoomError(f"edit {key}: the scale must be > 0")
        transform_change: dict[str, Any] = {field: number}
        part = replace(part, **transform_change)
    else:
        if part.kind != "procedural":
            raise PsdrRoomError(
                f"edit {key}: {part_name} is homogeneous; set material.{part_name}=<library graph> first"
            )
        bounds = library.material(part.material).bounds
        if field not in bounds:
            raise PsdrRoomError(f"edit {key}: {part.material} has no parameter '{field}'; it has {', '.join(bounds)}")
        part = replace(part, params={**part.params, field: value})
    state["parts"][index] = {**state["parts"][index], **part.__dict__, "base_color": list(part.base_color)}


def rebuild(scene_dir: Path, state: dict[str, Any], library: Any) -> Any:
    """The :class:`~psdr_room_core.method.rgb_scene.RgbScene` of a scene folder's meshes with ``state``'s materials."""

    def mesh(name: str) -> TriangleMesh:
        path = scene_dir / "meshes" / f"{name}.ply"
        if not path.is_file():
            raise PsdrRoomError(f"{path}: missing; the scene folder is incomplete, re-export it")
        return read_mesh_ply(path.read_bytes(), str(path))[0]

    fields = appearance_fields({"parts": state["parts"], "radiance": {}}, scene_dir / "appearance.json")
    lights = [
        Light(l["name"], l["kind"], mesh(l["name"]), tuple(l["radiance"]), l.get("part")) for l in state["lights"]
    ]
    emitting = {l.part for l in lights if l.part}
    meshes = {p.part: mesh(p.part) for p in fields["parts"] if p.part not in emitting}
    return build_scene(
        meshes, fields["parts"], lights, {n: mesh(n) for n in state["fixtures"]}, library, int(state["texture_size"])
    )


def render_folder(folder: Path, spp: int, renderer: Any, denoiser: Any) -> np.ndarray:
    """``scene.xml`` of a folder rendered by ``renderer.mitsuba`` (its ``render_file``) and cleaned by
    ``denoiser``, as sRGB uint8."""
    return to_srgb8(denoiser.denoise(*renderer.render_file(folder / "scene.xml", spp)))


def edit_scene(
    scene: Path, edits: list[str], out: Path, spp: int = 64, max_depth: int = 3, denoiser: str = "oidn"
) -> Path:
    """Apply ``edits`` (``KEY=VALUE``) to the scene folder ``scene`` and write the edited scene, rendered to
    ``render.png``, as the folder ``out`` (which appears whole, and replaces only a folder of ours); return it.
    It is written in a scratch folder of kind :data:`EDIT` beside ``out``, renamed into place; what a killed edit
    left there is removed first (:mod:`~psdr_room_core.engine.debris`)."""
    registry = plugin_system().registry
    clean = registry.implementation("denoiser", denoiser).factory()
    renderer = registry.implementation("renderer", "mitsuba").factory()  # the scene is a Mitsuba file
    scene_dir = scene.resolve()
    if out.resolve() == scene_dir:
        raise PsdrRoomError(f"--out {out}: must differ from the scene folder it edits")
    check_replaceable(out, "--out")
    check_creatable(out, "--out")
    library = registry.implementation("material_graph", "torch_graph").factory()
    state = load_state(scene_dir, library)
    for edit in edits:
        key, sep, raw = edit.partition("=")
        if not sep:
            raise PsdrRoomError(f"edit {edit!r}: expected KEY=VALUE")
        apply_edit(state, key.strip(), raw, library)
    files = scene_folder(rebuild(scene_dir, state, library), state, spp, max_depth, glb=True, usd=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    sweep(out.parent.absolute(), EDIT)
    staging = scratch_dir(out.parent, EDIT)
    try:
        for name, data in files.items():
            (staging / name).parent.mkdir(parents=True, exist_ok=True)
            (staging / name).write_bytes(data)
        write_png(staging / "render.png", render_folder(staging, spp, renderer, clean))
        claim(staging)
        check_replaceable(out, "--out")
        move_into_place(staging, out, EDIT)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return out


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``psdr-room-edit``."""
    parser = argparse.ArgumentParser(
        prog="psdr-room-edit",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("scene", type=Path, help="a run's scene/ folder (or an edited one)")
    parser.add_argument("edits", nargs="*", metavar="KEY=VALUE")
    parser.add_argument("--out", type=Path, help="where the edited scene goes (default: <scene>-edited)")
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel of render.png (default 64)")
    parser.add_argument("--max-depth", type=int, default=3, help="path length in the written scene.xml (default 3)")
    parser.add_argument(
        "--denoiser",
        default="oidn",
        help="a denoiser implementation for render.png (default oidn; none: the path tracer's noisy image)",
    )
    args = parser.parse_intermixed_args(argv)
    out = args.out or args.scene.with_name(args.scene.name + "-edited")
    logging.basicConfig(level=logging.WARNING, format="%(message)s")  # warnings (a swept scratch folder) on stderr
    status = exit_status(
        "psdr-room-edit",
        out.parent,
        lambda: edit_scene(args.scene, args.edits, out, args.spp, args.max_depth, args.denoiser),
    )
    if status:
        return status
    print(f"edited scene → {out} (render.png)")
    return 0
