"""Export: the reconstructed scene as Mitsuba 3 XML (separate, welded room and object meshes, baked maps,
area lights), as glTF 2.0 and as OpenUSD, with its editable appearance and the point cloud.

The room box is written as one quad mesh per side (floor, ceiling, four walls) with normals facing into
the room: separate meshes keep each side's parameters addressable, and welded quads give correct
boundary gradients in differentiable renders (``RENDERING-NOTES.md``). Each object is written as one
world-space mesh per material group (``object_<segment>_<group>``), so each part can get its own material.
Every part and light is a shape of its own id that ``mi.traverse`` reaches in a default ``mitsuba.load_file``.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from typing import Any
from xml.sax.saxutils import quoteattr

import cv2
import numpy as np

from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError

from ..artifacts import (
    Camera,
    Light,
    Lights,
    PartAppearance,
    Placements,
    PointCloud,
    RoomBox,
    SceneAppearance,
    SceneFiles,
)
from ..artifacts.io import ply_bytes
from ..capabilities import MaterialGraph
from ..geometry import TriangleMesh
from ..gltf import scene_glb
from ..rgb_scene import RgbScene, build_scene, part_meshes
from ..shading import linear_to_srgb
from ..usd import scene_usda
from ..visualize import to_uint8
from .settings import ExportScene

CV_TO_MITSUBA = np.diag([-1.0, -1.0, 1.0, 1.0])
"""OpenCV camera axes (x right, y down, z forward) → Mitsuba's (x left, y up, z forward)."""


def mesh_ply(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray | None = None, part: int | None = None) -> bytes:
    """A binary PLY triangle mesh: positions (one vertex per corner), texture coordinates ``u``, ``v`` when
    given, and ``part`` as a per-face ``part_x`` property when given (Mitsuba reads it as the mesh attribute
    ``face_part``; its loader merges meshes of equal materials into one unnamed shape unless they carry an
    attribute, so the part index keeps every part its own shape, addressable by id)."""
    props = "property float x\nproperty float y\nproperty float z\n" + (
        "property float u\nproperty float v\n" if uv is not None else ""
    )
    face_props = "property list uchar int vertex_indices\n" + ("property float part_x\n" if part is not None else "")
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(vertices)}\n{props}"
        f"element face {len(faces)}\n{face_props}end_header\n"
    )
    columns = [np.asarray(vertices, np.float64)] + ([np.asarray(uv, np.float64)] if uv is not None else [])
    tris = np.empty(len(faces), dtype=_face_dtype(part is not None))
    tris["n"], tris["i"] = 3, faces
    if part is not None:
        tris["part"] = part
    return header.encode("ascii") + np.hstack(columns).astype("<f4").tobytes() + tris.tobytes()


def _face_dtype(with_part: bool) -> np.dtype:
    """A PLY face record of :func:`mesh_ply`: three indices, and the part index when written."""
    return np.dtype([("n", "u1"), ("i", "<i4", (3,))] + ([("part", "<f4")] if with_part else []))


def _matrix(m: np.ndarray) -> str:
    return " ".join(f"{float(x):.9g}" for x in np.asarray(m).reshape(-1))


MAP_CHANNELS = ("base_color", "roughness")
"""The principled inputs a part's baked maps hold."""


def map_path(part: str, channel: str) -> str:
    """Where a part's baked map of ``channel`` lies in a scene folder."""
    return f"textures/{part}_{channel}.png"


def _texture(name: str, channel: str, value: Any, files: dict[str, bytes]) -> list[str]:
    """XML for one principled input: a constant, or a map written to ``textures/`` (base colour as sRGB PNG,
    roughness as a linear PNG)."""
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 3:
        path = map_path(name, channel)
        if channel == "base_color":
            files[path] = _png8(linear_to_srgb(array))
            raw = "false"
        else:
            files[path] = _png8(array[..., 0])
            raw = "true"
        return [
            f'<texture type="bitmap" name="{channel}"><string name="filename" value="{path}"/>'
            f'<boolean name="raw" value="{raw}"/></texture>'
        ]
    if channel == "base_color":
        return [f'<rgb name="base_color" value="{" ".join(f"{float(c):.6g}" for c in array.reshape(-1))}"/>']
    return [f'<float name="{channel}" value="{float(array.reshape(-1)[0]):.6g}"/>']


def _png8(image: np.ndarray) -> bytes:
    """A float image in [0, 1] (grey or RGB) as an 8-bit PNG file."""
    data = to_uint8(image)
    ok, encoded = cv2.imencode(".png", np.ascontiguousarray(data[..., ::-1] if data.ndim == 3 else data))
    assert ok
    return encoded.tobytes()


def scene_xml(
    camera: Camera, camera_to_world: np.ndarray, scene: RgbScene, spp: int, max_depth: int, files: dict[str, bytes]
) -> str:
    """Mitsuba 3 scene description of ``scene`` (meshes and textures are added to ``files``): the camera
    (``$width``, ``$height``, ``$spp`` overridable, ``spp`` by default), two-sided principled surfaces, area-light
    meshes, and a path tracer of ``max_depth`` (``$max_depth``)."""
    to_world = np.asarray(camera_to_world) @ CV_TO_MITSUBA
    offset_x = (camera.width / 2.0 - camera.cx) / camera.width
    offset_y = (camera.height / 2.0 - camera.cy) / camera.height
    lines = [
        '<scene version="3.0.0">',
        f'    <default name="spp" value="{int(spp)}"/>',
        f'    <default name="max_depth" value="{int(max_depth)}"/>',
        f'    <default name="width" value="{camera.width}"/>',
        f'    <default name="height" value="{camera.height}"/>',
        '    <integrator type="path"><integer name="max_depth" value="$max_depth"/></integrator>',
        '    <sensor type="perspective" id="camera">',
        '        <string name="fov_axis" value="y"/>',
        f'        <float name="fov" value="{camera.vfov_deg:.9g}"/>',
        f'        <float name="principal_point_offset_x" value="{offset_x:.9g}"/>',
        f'        <float name="principal_point_offset_y" value="{offset_y:.9g}"/>',
        '        <float name="near_clip" value="0.001"/>',
        '        <float name="far_clip" value="10000"/>',
        f'        <transform name="to_world"><matrix value="{_matrix(to_world)}"/></transform>',
        '        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>',
        '        <film type="hdrfilm">',
        '            <integer name="width" value="$width"/>',
        '            <integer name="height" value="$height"/>',
        '            <rfilter type="box"/>',
        "        </film>",
        "    </sensor>",
    ]
    for part, (name, mesh) in enumerate(scene.meshes.items()):
        surface = scene.surfaces[name]
        files[f"meshes/{name}.ply"] = mesh_ply(mesh.vertices, mesh.faces, surface.uv if surface.mapped else None, part)
        inputs = (
            _texture(name, "base_color", surface.base_color, files)
            + _texture(name, "roughness", surface.roughness, files)
            + [f'<float name="specular" value="{float(surface.specular):.6g}"/>']
        )
        lines += [
            f'    <shape type="ply" id={quoteattr(name)}>',
            f'        <string name="filename" value="meshes/{name}.ply"/>',
            '        <boolean name="face_normals" value="true"/>',
            '        <bsdf type="twosided"><bsdf type="principled">',
            *(f"            {line}" for line in inputs),
            "        </bsdf></bsdf>",
            "    </shape>",
        ]
    for part, (name, (mesh, radiance)) in enumerate(scene.emitters.items(), start=len(scene.meshes)):
        files[f"meshes/{name}.ply"] = mesh_ply(mesh.vertices, mesh.faces, part=part)
        rgb = " ".join(f"{float(c):.6g}" for c in radiance)
        lines += [
            f'    <shape type="ply" id={quoteattr(name)}>',
            f'        <string name="filename" value="meshes/{name}.ply"/>',
            '        <boolean name="face_normals" value="true"/>',
            '        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>',
            f'        <emitter type="area"><rgb name="radiance" value="{rgb}"/></emitter>',
            "    </shape>",
        ]
    lines.append("</scene>")
    return "\n".join(lines) + "\n"


def read_mesh_ply(data: bytes, source: str) -> tuple[TriangleMesh, np.ndarray | None]:
    """A mesh written by :func:`mesh_ply` (with its texture coordinates, if any); ``source`` names it in errors."""
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise PsdrRoomError(f"{source}: not a PLY file as psdr-room writes it; re-export the scene")
    header = data[:end].decode("ascii", "replace").split("\n")
    try:
        n_vertices = int(next(l.split()[2] for l in header if l.startswith("element vertex")))
        n_faces = int(next(l.split()[2] for l in header if l.startswith("element face")))
    except (StopIteration, ValueError, IndexError):
        raise PsdrRoomError(f"{source}: PLY header without vertex/face counts; re-export the scene") from None
    face_at = next(i for i, l in enumerate(header) if l.startswith("element face"))
    columns = sum(1 for l in header[:face_at] if l.startswith("property float"))
    with_part = any(l.startswith("property float part_x") for l in header[face_at:])
    body = data[end + len(b"end_header\n") :]
    size = n_vertices * columns * 4
    tris = np.frombuffer(body[size:], dtype=_face_dtype(with_part), count=n_faces)
    table = np.frombuffer(body[:size], dtype="<f4").reshape(n_vertices, columns).astype(np.float64)
    return TriangleMesh(table[:, :3], tris["i"].astype(np.int64)), (table[:, 3:5] if columns >= 5 else None)


def scene_state(
    camera: Camera,
    camera_to_world: np.ndarray,
    parts: list[PartAppearance],
    lights: list[Light],
    fixtures: list[str],
    texture_size: int,
) -> dict[str, Any]:
    """What a scene folder's ``appearance.json`` holds: everything besides the meshes needed to rebuild and
    edit it (camera, every part's material with its graph parameters, the lights, the window frames)."""
    return {
        "camera": {
            "width": camera.width,
            "height": camera.height,
            "fx": camera.fx,
            "fy": camera.fy,
            "cx": camera.cx,
            "cy": camera.cy,
        },
        "camera_to_world": np.asarray(camera_to_world).tolist(),
        "parts": [asdict(p) for p in parts],
        "lights": [{"name": l.name, "kind": l.kind, "part": l.part, "radiance": list(l.radiance)} for l in lights],
        "fixtures": list(fixtures),
        "texture_size": int(texture_size),
    }


def scene_folder(
    scene: RgbScene, state: dict[str, Any], spp: int, max_depth: int, glb: bool, usd: bool
) -> dict[str, bytes]:
    """The files of a scene folder: ``scene.xml`` with its meshes and maps, ``scene.glb`` (when ``glb``),
    ``scene.usda`` (when ``usd``; it shares the maps) and ``appearance.json`` (``state``)."""
    camera = Camera(**state["camera"])
    c2w = np.asarray(state["camera_to_world"], dtype=np.float64)
    files: dict[str, bytes] = {}
    files["scene.xml"] = scene_xml(camera, c2w, scene, spp, max_depth, files).encode()
    if glb:
        files["scene.glb"] = scene_glb(scene, camera, c2w)
    if usd:
        maps = {
            part: {channel: map_path(part, channel) for channel in MAP_CHANNELS if map_path(part, channel) in files}
            for part in scene.meshes
        }
        files["scene.usda"] = scene_usda(scene, camera, c2w, maps).encode()
    files["appearance.json"] = (json.dumps(state, indent=1) + "\n").encode()
    return files


def export_scene(
    ctx: StageContext,
    camera: Camera,
    room: RoomBox,
    cloud: PointCloud,
    placements: Placements,
    lights: Lights,
    appearance: SceneAppearance,
) -> SceneFiles:
    """Write the fitted scene: ``scene.xml`` (Mitsuba 3; ``mitsuba.load_file`` renders what ``fit_appearance``
    rendered; its path tracer takes ``spp`` samples and ``max_depth`` bounces unless told otherwise) with its
    meshes (PLY, texture coordinates on mapped parts) and the procedural parts' maps baked at ``texture_size``
    (``textures/``); ``scene.glb`` (glTF 2.0, when ``glb``); ``scene.usda`` (OpenUSD, when ``usd``);
    ``appearance.json`` (camera, every part's material with its graph parameters, the lights: what
    ``psdr-room-edit`` changes); and the segmented point cloud in world coordinates (``point_cloud.ply``)."""
    settings = ctx.settings(ExportScene)
    lit = [Light(l.name, l.kind, l.mesh, appearance.radiance.get(l.name, l.radiance), l.part) for l in lights.lights]
    scene = build_scene(
        part_meshes(room, placements),
        appearance.parts,
        lit,
        lights.fixtures,
        ctx.impl("material_graph", MaterialGraph),
        settings.texture_size,
    )
    c2w = np.asarray(room.camera_to_world)
    state = scene_state(camera, c2w, appearance.parts, lit, list(lights.fixtures), settings.texture_size)
    files = scene_folder(scene, state, settings.spp, settings.max_depth, settings.glb, settings.usd)
    world = cloud.points @ c2w[:3, :3].T + c2w[:3, 3]
    files["point_cloud.ply"] = ply_bytes(world, cloud.colors, cloud.segment)
    return SceneFiles(files=files)
