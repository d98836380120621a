"""The reconstruction as an RGB-renderable scene: the room's sides and the objects' material groups as named
meshes, their surfaces (flat or procedural maps on planar texture coordinates), the lights and the window
frames. ``init_lights``, ``fit_appearance``, ``export_scene`` and ``psdr-room-edit`` all build it here, so
they render the same scene."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import torch

from .artifacts import Camera, Light, MaterialAssignment, PartAppearance, Placement, Placements, RoomBox, vec3
from .geometry import TriangleMesh, quad_mesh, weld
from .shading import Surface, linear_to_srgb, planar_uv, srgb_to_linear, texture_transform
from .visualize import to_uint8

FIXTURE_COLOUR = (0.8, 0.8, 0.8)
"""Linear base colour of window frames."""


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


def part_meshes(room: RoomBox, placements: Placements) -> dict[str, TriangleMesh]:
    """Every scene part as exported: the room's six sides (quads facing in), then each object's material
    groups (``object_<segment>_<group>``), world space, welded."""
    meshes = {name: quad_mesh(quad) for name, quad in room_quads(room).items()}
    for placement in placements.objects:
        meshes.update({name: mesh for name, (mesh, _) in object_parts(placement).items()})
    return meshes


def render_part_ids(
    renderer: Any, camera: Camera, camera_to_world: np.ndarray, meshes: Mapping[str, TriangleMesh], width: int
) -> tuple[np.ndarray, np.ndarray]:
    """(ids, depth) at the camera's resolution: the index (in ``meshes`` order) of the part seen in each pixel
    (-1: none, or less than half covered) and the z-depth, rendered by ``renderer`` at ``width`` pixels."""
    small = camera.resized(min(int(width), camera.width))
    geometry = renderer.geometry(small, np.asarray(camera_to_world), dict(meshes), {n: i for i, n in enumerate(meshes)})
    with torch.no_grad():
        masks, depth, alpha = (t.numpy() for t in geometry.render())
    ids = np.where(masks.max(axis=0) > 0.5, masks.argmax(axis=0), -1).astype(np.int32)
    depth = np.where(alpha > 0.5, depth / np.maximum(alpha, 1e-6), 0.0).astype(np.float32)
    size = (camera.width, camera.height)
    return (
        cv2.resize(ids, size, interpolation=cv2.INTER_NEAREST),
        cv2.resize(depth, size, interpolation=cv2.INTER_NEAREST),
    )


def initial_parts(materials: MaterialAssignment, library: Any) -> list[PartAppearance]:
    """Eq. 4's starting point from the assignment: homogeneous parts at their median colour (linear),
    procedural ones at their graph's own parameter values with the searched transform."""
    parts = []
    for m in materials.parts:
        base = vec3(srgb_to_linear(np.asarray(m.albedo)))
        if m.kind == "procedural" and m.material:
            values = {k: v.value.tolist() for k, v in library.material(m.material).bounds.items()}
            parts.append(
                PartAppearance(m.part, "procedural", base, m.roughness, 0.5, m.material, m.scale, m.rotation, values)
            )
        else:
            parts.append(PartAppearance(m.part, "homogeneous", base, m.roughness, 0.5))
    return parts


def graph_maps(
    library: Any, part: PartAppearance, size: int, params: Mapping[str, torch.Tensor] | None = None
) -> tuple[torch.Tensor, torch.Tensor]:
    """(linear base colour [size, size, 3], roughness [size, size, 1]) of a procedural part's graph at the
    unconstrained ``params`` (default: the part's saved values), differentiable in ``params``."""
    material = library.material(part.material)
    if params is None:
        params = material.unconstrained(part.params) if part.params else None
    maps = material.evaluate(int(size), params, outputs=("base_color", "roughness"))
    return srgb_to_linear(maps["base_color"]).permute(1, 2, 0), maps["roughness"].permute(1, 2, 0)


@dataclass
class RgbScene:
    """Named meshes with their surfaces, and the emitters (name → (mesh, linear RGB radiance))."""

    meshes: dict[str, TriangleMesh] = field(default_factory=dict)
    surfaces: dict[str, Surface] = field(default_factory=dict)
    emitters: dict[str, tuple[TriangleMesh, tuple[float, float, float]]] = field(default_factory=dict)

    def renderer(self, renderer: Any, camera: Camera, camera_to_world: np.ndarray, width: int) -> Any:
        """A ``renderer.geometry`` of this scene at ``width`` pixels (every mesh its own part)."""
        return renderer.geometry(
            camera,
            np.asarray(camera_to_world),
            self.meshes,
            {n: i for i, n in enumerate(self.meshes)},
            resolution_scale=width / camera.width,
            surfaces=self.surfaces,
            emitters=self.emitters,
        )


def build_scene(
    meshes: Mapping[str, TriangleMesh],
    parts: Iterable[PartAppearance],
    lights: Iterable[Light],
    fixtures: Mapping[str, TriangleMesh],
    library: Any,
    map_size: int,
) -> RgbScene:
    """The scene of the part meshes (:func:`part_meshes`) with each part's material (procedural parts get
    their graph's maps at ``map_size`` on planar texture coordinates with their transform), the window
    frames, and the lights at their radiance; a lamp part that a light replaces is that light's mesh."""
    chosen = {p.part: p for p in parts}
    scene = RgbScene()
    emitting = {light.part for light in lights if light.part}
    for name, mesh in meshes.items():
        if name in emitting:
            continue
        part = chosen.get(name)
        if part is None:
            scene.meshes[name], scene.surfaces[name] = mesh, Surface()
        elif part.kind == "procedural":
            split, metres = planar_uv(mesh)
            tile = float(library.material(part.material).tile_size)
            with torch.no_grad():
                base, rough = graph_maps(library, part, map_size)
            scene.meshes[name] = split
            scene.surfaces[name] = Surface(
                base.numpy(), rough.numpy(), part.specular, texture_transform(metres, tile, part.scale, part.rotation)
            )
        else:
            scene.meshes[name] = mesh
            scene.surfaces[name] = Surface(part.base_color, part.roughness, part.specular)
    for name, mesh in fixtures.items():
        scene.meshes[name], scene.surfaces[name] = mesh, Surface(FIXTURE_COLOUR, 0.6, 0.5)
    for light in lights:
        scene.emitters[light.name] = (light.mesh, vec3(light.radiance))
    return scene


GUIDE_SPP = 16
"""Samples per pixel of a denoiser's albedo and normal guides (OIDN prefilters them)."""


def finished_render(
    geometry: Any, denoiser: Any, inputs: Mapping[str, Any], spp: int, iteration: int
) -> tuple[np.ndarray, np.ndarray]:
    """A picture of ``geometry``'s RGB scene (``inputs``: :meth:`render_rgb` keyword arguments, no gradients):
    linear (noisy, denoised) float32 [H, W, 3], the second by ``denoiser`` guided by the scene's albedo and
    normal."""
    with torch.no_grad():
        noisy = geometry.render_rgb(**inputs, iteration=iteration, spp=spp).numpy()
        albedo, normal = geometry.render_guides(**inputs, spp=GUIDE_SPP)
    return noisy, denoiser.denoise(noisy, albedo, normal)


def to_srgb8(linear: torch.Tensor | np.ndarray) -> np.ndarray:
    """A linear RGB render [H, W, 3] as displayable sRGB uint8."""
    array = linear.detach().cpu().numpy() if isinstance(linear, torch.Tensor) else np.asarray(linear)
    return to_uint8(linear_to_srgb(array))
