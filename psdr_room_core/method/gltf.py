"""A glTF 2.0 binary (``.glb``) of the reconstructed scene: one named node and mesh per scene part with a
metallic-roughness PBR material (constant, or embedded PNG maps on the planar texture coordinates) and its
fitted specular (``KHR_materials_specular``), the lights as emissive meshes (``KHR_materials_emissive_strength``
carries radiance above 1) with a spot light standing in for each (``KHR_lights_punctual``: rasterisers light
nothing from emissive meshes), and the photo's camera with its aspect ratio.

The stand-ins are approximations (glTF has no area light): a Lambertian panel of radiance L and area A emits
pi L A; a spot light over a hemisphere (outer cone pi / 2) of the same power has intensity L A / 2. A path
tracer that lights from emissive meshes (Cycles, a three.js path tracer) counts the light twice from a raw import:
``psdr-room-blender`` builds the scene for Blender with area lights instead."""

from __future__ import annotations

import json
import math
import struct
from typing import Any

import cv2
import numpy as np

from .artifacts import Camera
from .rgb_scene import RgbScene
from .shading import SPECULAR_F0, linear_to_srgb
from .visualize import to_uint8

CV_TO_GL = np.diag([1.0, -1.0, -1.0, 1.0])
"""OpenCV camera axes (x right, y down, z forward) → glTF's (x right, y up, looking down −z)."""
LUMENS_PER_WATT = 683.0
"""glTF light intensities are photometric (candela); radiance is radiometric: the conversion glTF importers
(Blender's among them) undo."""
GLTF_F0 = 0.04
"""A glTF dielectric's normal-incidence reflectance at its default IOR 1.5; a principled BSDF's ``specular`` s
has ``SPECULAR_F0`` s (Mitsuba, Blender), so ``KHR_materials_specular`` scales it by 2 s."""


class _Buffer:
    """The binary chunk with its buffer views and accessors."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict[str, Any]] = []
        self.accessors: list[dict[str, Any]] = []

    def view(self, payload: bytes, target: int | None = None) -> int:
        while len(self.data) % 4:
            self.data.append(0)
        self.views.append(
            {
                "buffer": 0,
                "byteOffset": len(self.data),
                "byteLength": len(payload),
                **({"target": target} if target else {}),
            }
        )
        self.data += payload
        return len(self.views) - 1

    def accessor(self, array: np.ndarray, kind: str, component: int, target: int, bounds: bool = False) -> int:
        view = self.view(np.ascontiguousarray(array).tobytes(), target)
        entry: dict[str, Any] = {"bufferView": view, "componentType": component, "count": int(len(array)), "type": kind}
        if bounds:
            entry["min"] = [float(v) for v in array.min(axis=0)]
            entry["max"] = [float(v) for v in array.max(axis=0)]
        self.accessors.append(entry)
        return len(self.accessors) - 1


def _png(image: np.ndarray) -> bytes:
    ok, data = cv2.imencode(".png", np.ascontiguousarray(image[..., ::-1] if image.ndim == 3 else image))
    assert ok
    return data.tobytes()


def scene_glb(scene: RgbScene, camera: Camera, camera_to_world: np.ndarray) -> bytes:
    """The scene as a ``.glb`` (y up, metres, world coordinates baked into the vertices)."""
    buf = _Buffer()
    meshes, materials, textures, images, nodes = [], [], [], [], []

    def texture(png: bytes) -> int:
        images.append({"bufferView": buf.view(png), "mimeType": "image/png"})
        textures.append({"source": len(images) - 1, "sampler": 0})
        return len(textures) - 1

    def add(
        name: str, vertices: np.ndarray, faces: np.ndarray, material: dict[str, Any], uv: np.ndarray | None
    ) -> None:
        attributes = {"POSITION": buf.accessor(vertices.astype(np.float32), "VEC3", 5126, 34962, bounds=True)}
        if uv is not None:
            attributes["TEXCOORD_0"] = buf.accessor(uv.astype(np.float32), "VEC2", 5126, 34962)
        indices = buf.accessor(faces.astype(np.uint32).reshape(-1), "SCALAR", 5125, 34963)
        materials.append({"name": name, "doubleSided": True, **material})
        meshes.append(
            {
                "name": name,
                "primitives": [{"attributes": attributes, "indices": indices, "material": len(materials) - 1}],
            }
        )
        nodes.append({"name": name, "mesh": len(meshes) - 1})

    for name, mesh in scene.meshes.items():
        surface = scene.surfaces[name]
        pbr: dict[str, Any] = {"metallicFactor": 0.0}
        if np.ndim(surface.base_color) == 3:
            srgb = to_uint8(linear_to_srgb(np.asarray(surface.base_color)))
            pbr["baseColorTexture"] = {"index": texture(_png(srgb))}
        else:
            pbr["baseColorFactor"] = [float(c) for c in surface.base_color] + [1.0]
        if np.ndim(surface.roughness) == 3:
            rough = to_uint8(np.asarray(surface.roughness)[..., 0])
            packed = np.stack([np.zeros_like(rough), rough, np.zeros_like(rough)], axis=-1)  # glTF: roughness in G
            pbr["metallicRoughnessTexture"] = {"index": texture(_png(packed))}
            pbr["roughnessFactor"] = 1.0
        else:
            pbr["roughnessFactor"] = float(surface.roughness)
        f0_scale = float(surface.specular) * SPECULAR_F0 / GLTF_F0
        add(
            name,
            np.asarray(mesh.vertices),
            np.asarray(mesh.faces),
            {
                "pbrMetallicRoughness": pbr,
                "extensions": {"KHR_materials_specular": {"specularColorFactor": [f0_scale] * 3}},
            },
            surface.uv if surface.mapped else None,
        )
    lights = []
    for name, (mesh, radiance) in scene.emitters.items():
        strength = max(max(radiance), 1e-6)
        add(
            name,
            np.asarray(mesh.vertices),
            np.asarray(mesh.faces),
            {
                "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
                "emissiveFactor": [float(c) / strength for c in radiance],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": float(strength)}},
            },
            None,
        )
        centre, normal, area, _ = emitter_frame(mesh.vertices, mesh.faces)
        lights.append(
            {
                "name": f"{name}_stand_in",
                "type": "spot",
                "color": [float(c) / strength for c in radiance],
                "intensity": LUMENS_PER_WATT * strength * area / 2.0,
                "spot": {"innerConeAngle": 0.0, "outerConeAngle": math.pi / 2},
            }
        )
        nodes.append(
            {
                "name": f"{name}_stand_in",
                "matrix": _facing(centre, normal),
                "extensions": {"KHR_lights_punctual": {"light": len(lights) - 1}},
            }
        )

    pose = np.asarray(camera_to_world, dtype=np.float64) @ CV_TO_GL
    nodes.append({"name": "camera", "camera": 0, "matrix": [float(v) for v in pose.T.reshape(-1)]})
    used = ["KHR_materials_emissive_strength", "KHR_materials_specular"] + (["KHR_lights_punctual"] if lights else [])
    gltf: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": "psdr-room"},
        "extensionsUsed": used,
        "scene": 0,
        "scenes": [{"name": "psdr-room", "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [
            {
                "type": "perspective",
                "name": "photo",
                "perspective": {
                    "yfov": math.radians(camera.vfov_deg),
                    "aspectRatio": camera.width / camera.height,
                    "znear": 0.01,
                },
            }
        ],
        "buffers": [{"byteLength": 0}],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    }
    if lights:
        gltf["extensions"] = {"KHR_lights_punctual": {"lights": lights}}
    if textures:
        gltf.update(
            textures=textures,
            images=images,
            samplers=[{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        )
    while len(buf.data) % 4:
        buf.data.append(0)
    gltf["buffers"][0]["byteLength"] = len(buf.data)
    return _pack(gltf, bytes(buf.data))


def _pack(gltf: dict[str, Any], binary: bytes) -> bytes:
    """A glb: the JSON chunk (space-padded) and the binary chunk (its length a multiple of 4)."""
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(binary), b"BIN\x00") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def without_lights(glb: bytes) -> bytes:
    """``glb`` (as :func:`scene_glb` writes it) without its ``KHR_lights_punctual`` stand-ins, for a viewer that lights
    the scene itself and has no exposure for photometric intensities (viser: candela read as its own units washes
    the room out white); the emissive panels stay."""
    (length,) = struct.unpack_from("<I", glb, 12)
    gltf = json.loads(glb[20 : 20 + length])
    (binary_length,) = struct.unpack_from("<I", glb, 20 + length)
    binary = glb[28 + length : 28 + length + binary_length]
    gltf.get("extensions", {}).pop("KHR_lights_punctual", None)
    if not gltf.get("extensions"):
        gltf.pop("extensions", None)
    gltf["extensionsUsed"] = [e for e in gltf.get("extensionsUsed", []) if e != "KHR_lights_punctual"]
    for node in gltf.get("nodes", []):
        node.get("extensions", {}).pop("KHR_lights_punctual", None)
        if "extensions" in node and not node["extensions"]:
            del node["extensions"]
    return _pack(gltf, binary)


def _facing(position: np.ndarray, direction: np.ndarray) -> list[float]:
    """A node matrix (column-major) at ``position`` whose −z axis (where glTF lights point) is ``direction``."""
    back = -direction / np.linalg.norm(direction)
    helper = np.array([0.0, 1.0, 0.0]) if abs(back[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, back)
    x /= np.linalg.norm(x)
    matrix = np.eye(4)
    matrix[:3, 0], matrix[:3, 1], matrix[:3, 2], matrix[:3, 3] = x, np.cross(back, x), back, position
    return [float(v) for v in matrix.T.reshape(-1)]


def emitter_frame(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """An emitting mesh's area-weighted centre, mean emitting direction (unit; its counter-clockwise side), area,
    and flatness: the length of the area-weighted mean normal (1 for a flat panel, near 0 for a closed shape)."""
    corners = np.asarray(vertices, np.float64)[np.asarray(faces)]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    areas = np.linalg.norm(cross, axis=1) / 2
    area = float(areas.sum())
    centre = (corners.mean(axis=1) * areas[:, None]).sum(axis=0) / max(area, 1e-12)
    normal = cross.sum(axis=0) / 2
    length = float(np.linalg.norm(normal))
    direction = normal / length if length > 1e-12 else np.array([0.0, -1.0, 0.0])
    return centre, direction, area, length / max(area, 1e-12)
