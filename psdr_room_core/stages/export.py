"""Export: the reconstructed scene as Mitsuba 3 XML with separate, welded room and object meshes, plus the
point cloud.

The room box is written as one quad mesh per side (floor, ceiling, four walls) with normals facing into
the room: separate meshes keep each side's parameters addressable, and welded quads give correct
boundary gradients in differentiable renders (``RENDERING-NOTES.md``). Each object is written as one
world-space mesh per material group (``object_<segment>_<group>``), so each part can get its own material.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from xml.sax.saxutils import quoteattr

import numpy as np

from ..artifacts import (Camera, MaterialAssignment, Placement, Placements, PointCloud, RoomBox, SceneFiles,
                         ply_bytes)
from ..errors import PsdrRoomError
from ..dag import StageContext
from ..geometry import TriangleMesh, weld

CV_TO_MITSUBA = np.diag([-1.0, -1.0, 1.0, 1.0])
"""OpenCV camera axes (x right, y down, z forward) → Mitsuba's (x left, y up, z forward)."""

ROOM_SIDES = {
    # side name: (axis, sign) of the box face in the box's local frame
    "floor": (1, -1),
    "ceiling": (1, 1),
    "wall_x_neg": (0, -1),
    "wall_x_pos": (0, 1),
    "wall_z_neg": (2, -1),
    "wall_z_pos": (2, 1),
}


def room_quad_indices(room: RoomBox) -> dict[str, np.ndarray]:
    """Corner indices (into ``room.corners()``) of each side's quad, counter-clockwise seen from inside."""
    corners = room.corners()
    indices = {}
    for name, (axis, sign) in ROOM_SIDES.items():
        base = (1 << axis) if sign > 0 else 0
        bit_u, bit_v = (1 << a for a in range(3) if a != axis)
        quad = np.array([base, base | bit_u, base | bit_u | bit_v, base | bit_v])
        normal = np.cross(corners[quad[1]] - corners[quad[0]], corners[quad[2]] - corners[quad[0]])
        if np.dot(normal, room.center - corners[quad].mean(axis=0)) < 0:  # face the inside of the room
            quad = quad[::-1]
        indices[name] = quad
    return indices


def room_quads(room: RoomBox) -> dict[str, np.ndarray]:
    """World-space quads (4x3, counter-clockwise seen from inside the room) for each side of the box."""
    corners = room.corners()
    return {name: corners[index] for name, index in room_quad_indices(room).items()}


def mesh_ply(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """A binary PLY triangle mesh with positions only (welded: one vertex per corner)."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(vertices)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    tris = np.empty(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    tris["n"], tris["i"] = 3, faces
    return header.encode("ascii") + vertices.astype("<f4").tobytes() + tris.tobytes()


def _matrix(m: np.ndarray) -> str:
    return " ".join(f"{float(x):.9g}" for x in np.asarray(m).reshape(-1))


def object_parts(placement: Placement) -> dict[str, tuple[TriangleMesh, np.ndarray]]:
    """Shape id → (welded world-space mesh, sRGB base colour) for each material group of an object."""
    world = placement.world_vertices()
    parts = {}
    for g, group in enumerate(placement.mesh.groups):
        faces = placement.mesh.faces[placement.mesh.face_group == g]
        if len(faces):
            used, local = np.unique(faces, return_inverse=True)
            mesh = weld(TriangleMesh(world[used], local.reshape(-1, 3)))
            safe = "".join(ch if ch.isalnum() else "_" for ch in group)
            parts[f"object_{placement.segment_id}_{safe}"] = (mesh, placement.mesh.colors[g])
    return parts


def srgb_to_linear(rgb: np.ndarray) -> np.ndarray:
    rgb = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)
    return np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)


def scene_xml(camera: Camera, room: RoomBox, params: dict, albedo: dict[str, np.ndarray]) -> str:
    """Mitsuba 3 scene description for the camera, the room sides and the object parts (shape id → linear
    albedo, room sides first) written by :func:`export_scene`."""
    to_world = np.asarray(room.camera_to_world) @ CV_TO_MITSUBA
    offset_x = (camera.width / 2.0 - camera.cx) / camera.width
    offset_y = (camera.height / 2.0 - camera.cy) / camera.height
    lines = [
        '<scene version="3.0.0">',
        f'    <default name="spp" value="{int(params["spp"])}"/>',
        '    <integrator type="path">',
        f'        <integer name="max_depth" value="{int(params["max_depth"])}"/>',
        "    </integrator>",
        '    <sensor type="perspective" id="camera">',
        '        <string name="fov_axis" value="y"/>',
        f'        <float name="fov" value="{camera.vfov_deg:.9g}"/>',
        f'        <float name="principal_point_offset_x" value="{offset_x:.9g}"/>',
        f'        <float name="principal_point_offset_y" value="{offset_y:.9g}"/>',
        '        <float name="near_clip" value="0.01"/>',
        '        <float name="far_clip" value="1000"/>',
        f'        <transform name="to_world"><matrix value="{_matrix(to_world)}"/></transform>',
        '        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>',
        '        <film type="hdrfilm">',
        f'            <integer name="width" value="{camera.width}"/>',
        f'            <integer name="height" value="{camera.height}"/>',
        '            <rfilter type="box"/>',
        "        </film>",
        "    </sensor>",
    ]
    for name, albedo_rgb in albedo.items():
        rgb = " ".join(f"{a:.6g}" for a in albedo_rgb)
        lines += [
            f'    <shape type="ply" id={quoteattr(name)}>',
            f'        <string name="filename" value="meshes/{name}.ply"/>',
            f'        <bsdf type="diffuse"><rgb name="reflectance" value="{rgb}"/></bsdf>',
            "    </shape>",
        ]
    # An initial light until the lighting stage places real ones: a panel just below the ceiling centre.
    top = room.center + np.array([0.0, room.half_size[1] * 0.98, 0.0])
    size = 0.25 * float(min(room.half_size[0], room.half_size[2]))
    panel = np.array([[size, 0, 0, top[0]], [0, -1e-3, 0, top[1]], [0, 0, size, top[2]], [0, 0, 0, 1]])
    rotate = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1.0]])  # +z normal → -y (down)
    lines += [
        '    <shape type="rectangle" id="ceiling_light">',
        f'        <transform name="to_world"><matrix value="{_matrix(panel @ rotate)}"/></transform>',
        f'        <emitter type="area"><rgb name="radiance" value="{float(params["light_radiance"]):.6g}"/></emitter>',
        "    </shape>",
        "</scene>",
    ]
    return "\n".join(lines) + "\n"


def export_scene(ctx: StageContext, camera: Camera, room: RoomBox, cloud: PointCloud, placements: Placements,
                 materials: MaterialAssignment) -> SceneFiles:
    """Write ``scene.xml`` (Mitsuba 3: camera, room meshes, object parts with the albedo of their assigned
    material, an initial light), the meshes, the materials (``materials.json``: kind, albedo, graph and
    texture transform per part) and the segmented point cloud in world coordinates (``point_cloud.ply``).

    Params: ``spp``, ``max_depth`` (path tracer defaults in the XML), ``light_radiance``.
    """
    files: dict[str, bytes] = {}
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    meshes: dict[str, TriangleMesh] = {name: TriangleMesh(quad, faces) for name, quad in room_quads(room).items()}
    colours: dict[str, np.ndarray] = {}
    for placement in placements.objects:
        for name, (mesh, colour) in object_parts(placement).items():
            meshes[name], colours[name] = mesh, colour
    albedo = {}
    for name, mesh in meshes.items():
        files[f"meshes/{name}.ply"] = mesh_ply(mesh.vertices, mesh.faces)
        assigned = materials.part(name)
        if assigned is None and name not in colours:
            raise PsdrRoomError(f"materials artifact has no part '{name}'; rerun assign_materials (+run.from=assign_materials)")
        albedo[name] = srgb_to_linear(assigned.albedo if assigned is not None else colours[name])
    files["scene.xml"] = scene_xml(camera, room, ctx.params, albedo).encode()
    files["materials.json"] = json.dumps({"parts": [asdict(p) for p in materials.parts]}, indent=1).encode()
    c2w = np.asarray(room.camera_to_world)
    world = cloud.points @ c2w[:3, :3].T + c2w[:3, 3]
    files["point_cloud.ply"] = ply_bytes(world, cloud.colors, cloud.segment)
    return SceneFiles(files=files)
