"""Build ``psdr_room_core/libraries/object_db/library/polyhaven/`` (OBJ + MTL per model, and the licence) from Poly Haven's glTF
furniture as stored in ``../shared/data/meshes/polyhaven_robotlocomotion`` (CC0).

A one-off build step, not run by the tests or at run time. For each model of :data:`MODELS`:

1. the glTF 2.0 JSON and its external ``.bin`` are read (node translations, rotations and scales applied;
   triangle primitives only);
2. each node's triangles form a material group named by :data:`MODELS` (a cabinet's ``body``, ``doors`` and
   ``drawers``; a sofa's ``frame`` and ``cushions`` by material); the group's colour (MTL ``Kd``, sRGB) is
   the area-weighted mean of the base-colour texture sampled at the triangles' UV centroids, times the
   material's ``baseColorFactor``: the database keeps flat colours, the textures stay behind;
3. ``<name>.obj`` + ``<name>.mtl`` are written in the file's own axes and metres (+Y up, front +Z), and
   ``License.txt`` with the licence statements of the source.

Run with the project's environment from the repository root::

    python tools/convert_polyhaven.py [--source DIR]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.libraries.object_db.objio import write_obj

REPO = Path(__file__).resolve().parents[1]
SOURCE = REPO.parent / "shared" / "data" / "meshes" / "polyhaven_robotlocomotion"
OUT = REPO / "psdr_room_core" / "libraries" / "object_db" / "library" / "polyhaven"

MODELS: dict[str, tuple[str, dict[str, str]]] = {
    "painted_wooden_cabinet_1k.gltf": (
        "painted_wooden_cabinet",
        {
            "painted_wooden_cabinet": "body",
            "painted_wooden_cabinet_door_01": "doors",
            "painted_wooden_cabinet_door_02": "doors",
            "painted_wooden_cabinet_drawer_01": "drawers",
            "painted_wooden_cabinet_drawer_02": "drawers",
        },
    ),
    "painted_wooden_cabinet_02_1k.gltf": (
        "painted_wooden_cabinet_02",
        {
            "painted_wooden_cabinet_02": "body",
            "painted_wooden_cabinet_02_door": "door",
            "painted_wooden_cabinet_02_drawer": "drawer",
        },
    ),
    "painted_wooden_stool_1k.gltf": ("painted_wooden_stool", {"painted_wooden_stool": "body"}),
    "sofa_03_1k.gltf": ("sofa_03", {"sofa_03": "frame", "sofa_03_fringe": "fringe"}),
    "wooden_bookshelf_worn_1k.gltf": ("wooden_bookshelf_worn", {"wooden_bookshelf_worn": "body"}),
    "wooden_table_02_1k.gltf": ("wooden_table_02", {"wooden_table_02": "body"}),
}
"""Source file → (output name, node name → group; for a node with several primitives, material name → group)."""

LICENCE = """Poly Haven furniture (CC0 1.0), converted by psdr-room's tools/convert_polyhaven.py
Source: github.com/RobotLocomotion/models @ 4723170e1c8ee8bc59c342bb5c491ab8f263f1fb, tutorials/models/assets/
Models: polyhaven.com/a/painted_wooden_cabinet, polyhaven.com/a/painted_wooden_cabinet_02,
polyhaven.com/a/painted_wooden_stool, polyhaven.com/a/sofa_03, polyhaven.com/a/wooden_bookshelf_worn,
polyhaven.com/a/wooden_table_02

"The license for Poly Haven data is CC0 (https://polyhaven.com/license)." (RobotLocomotion/models README)
"The contents of this directory and its child directories (unless otherwise indicated) is marked with CC0 1.0."
(RobotLocomotion/models tutorials/LICENSE)

CC0 1.0 Universal: https://creativecommons.org/publicdomain/zero/1.0/
Only positions, material groups and one flat colour per group are kept; the textures are not included.
"""

COMPONENTS = {5126: np.float32, 5123: np.uint16, 5125: np.uint32, 5121: np.uint8}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def accessor(gltf: dict, buffers: list[bytes], index: int) -> np.ndarray:
    """(count, n) array of a glTF accessor (strided buffer views included)."""
    a = gltf["accessors"][index]
    view = gltf["bufferViews"][a["bufferView"]]
    dtype, n = np.dtype(COMPONENTS[a["componentType"]]), WIDTH[a["type"]]
    offset = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    stride = view.get("byteStride") or n * dtype.itemsize
    raw = np.frombuffer(buffers[view["buffer"]], np.uint8)
    rows = np.stack([raw[offset + i * stride : offset + i * stride + n * dtype.itemsize] for i in range(a["count"])])
    return rows.view(dtype).reshape(a["count"], n)


def node_matrix(node: dict) -> np.ndarray:
    """4x4 local transform of a node (``matrix``, or translation · rotation · scale)."""
    if "matrix" in node:
        return np.asarray(node["matrix"], np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", (0.0, 0.0, 0.0, 1.0))
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    matrix = np.eye(4)
    matrix[:3, :3] = rotation * np.asarray(node.get("scale", (1.0, 1.0, 1.0)))
    matrix[:3, 3] = node.get("translation", (0.0, 0.0, 0.0))
    return matrix


def texture_colour(gltf: dict, folder: Path, material: dict, uv: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """sRGB colour of a material over triangles: the base-colour texture at their UV centroids (area-weighted)
    times ``baseColorFactor`` (converted in linear RGB)."""
    pbr = material.get("pbrMetallicRoughness", {})
    factor = np.asarray(pbr.get("baseColorFactor", (1.0, 1.0, 1.0, 1.0))[:3])
    linear = factor
    if "baseColorTexture" in pbr:
        image = gltf["images"][gltf["textures"][pbr["baseColorTexture"]["index"]]["source"]]
        rgb = cv2.imread(str(folder / image["uri"]), cv2.IMREAD_COLOR)[..., ::-1].astype(np.float64) / 255.0
        h, w = rgb.shape[:2]
        cols = np.clip((np.mod(uv[:, 0], 1.0) * w).astype(int), 0, w - 1)
        rows = np.clip((np.mod(uv[:, 1], 1.0) * h).astype(int), 0, h - 1)
        texels = rgb[rows, cols]
        lin = np.where(texels <= 0.04045, texels / 12.92, ((texels + 0.055) / 1.055) ** 2.4)
        linear = factor * (lin * weights[:, None]).sum(0) / max(weights.sum(), 1e-12)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    return np.clip(srgb, 0.0, 1.0)


def convert(path: Path, name: str, groups: dict[str, str], out: Path) -> None:
    gltf = json.loads(path.read_text())
    buffers = [(path.parent / b["uri"]).read_bytes() for b in gltf["buffers"]]
    names: list[str] = []
    vertices, faces, face_group, colour_parts = [], [], [], {}
    offset = 0

    def visit(index: int, parent: np.ndarray) -> None:
        nonlocal offset
        node = gltf["nodes"][index]
        matrix = parent @ node_matrix(node)
        primitives = gltf["meshes"][node["mesh"]]["primitives"] if "mesh" in node else []
        for primitive in primitives:
            if primitive.get("mode", 4) != 4:
                continue
            material = gltf["materials"][primitive["material"]]
            key = material.get("name", "") if len(primitives) > 1 else node.get("name", "")
            group = groups.get(key, "body")
            if group not in names:
                names.append(group)
            positions = accessor(gltf, buffers, primitive["attributes"]["POSITION"]).astype(np.float64)
            tris = accessor(gltf, buffers, primitive["indices"]).reshape(-1, 3).astype(np.int64)
            world = positions @ matrix[:3, :3].T + matrix[:3, 3]
            a, b, c = (world[tris[:, k]] for k in range(3))
            area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
            uv = accessor(gltf, buffers, primitive["attributes"]["TEXCOORD_0"])[tris].mean(axis=1)
            colour = texture_colour(gltf, path.parent, material, uv, area)
            colour_parts.setdefault(group, []).append((colour, area.sum()))
            vertices.append(world)
            faces.append(tris + offset)
            face_group.append(np.full(len(tris), names.index(group)))
            offset += len(world)
        for child in node.get("children", []):
            visit(child, matrix)

    for root in gltf["scenes"][gltf.get("scene", 0)]["nodes"]:
        visit(root, np.eye(4))
    colours = np.array([sum(c * w for c, w in colour_parts[g]) / sum(w for _, w in colour_parts[g]) for g in names])
    write_obj(
        out / f"{name}.obj",
        np.concatenate(vertices),
        np.concatenate(faces),
        np.concatenate(face_group),
        names,
        colours,
        header=f"{name}: Poly Haven (CC0 1.0), converted by tools/convert_polyhaven.py; see License.txt",
    )
    print(
        f"{name}: {offset} vertices, {sum(len(f) for f in faces)} triangles, groups "
        + ", ".join(f"{g} {np.round(c, 3).tolist()}" for g, c in zip(names, colours))
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=SOURCE, help="folder of the glTF files (default: %(default)s)")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    for file, (name, groups) in MODELS.items():
        convert(args.source / file, name, groups, OUT)
    (OUT / "License.txt").write_text(LICENCE)
    for file in OUT.iterdir():
        file.chmod(0o644)


if __name__ == "__main__":
    main()
