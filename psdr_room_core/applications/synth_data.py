"""The data engine of psdr-room's own eyes (``psdr-room-synth-data``): randomised rooms furnished from the object
database (:mod:`psdr_room_core.libraries.synth.furnish`), dressed in the material library's graphs, photo
textures and random colours, lit by ceiling panels and daylight windows, path traced with the Mitsuba plugin and
denoised, with exact per-pixel labels from one primary ray per pixel.

One sample ``<seed>`` of a data set folder:

    <seed>.jpg    the photo (sRGB, auto-exposed; quality 95: noise, blur and JPEG are the trainer's augmentation)
    <seed>.npz    surface (uint8, :data:`~psdr_room_plugins.eyes.labels.SURFACES`), category (uint8: 0 none, k =
                  :data:`~psdr_room_plugins.eyes.labels.CATEGORIES` [k-1]),
                  instance (uint16: 0 none, one id per object), depth (float16 z-depth, m; 0 across edges), all H×W;
                  room (center xyz, half sizes, yaw), camera (fx, fy, cx, cy), camera_to_world (4×4);
                  camera_pitch, camera_roll (radians);
                  per instance id of the instance map (every one the generator placed, seen or not), in id order:
                  instance_ids (uint16), instance_center (camera frame, m), instance_size (w, h, d along the
                  model's own axes, m), instance_yaw (radians in [-π, π)) (all float32), instance_model (catalogue
                  model id; empty for a ceiling panel), instance_category (uint8, as category), instance_visible
                  (float32 share of its silhouette seen), instance_cut (bool: the frame cuts it); the frames and
                  angles as :mod:`psdr_room_core.libraries.synth.instances` defines them

Deterministic by seed: the same seed gives the same room, camera, labels and (Mitsuba's seeded sampler) photo.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.registry import Registry
from psdr_room_core.libraries.object_db import ObjectDatabase
from psdr_room_core.libraries.synth.furnish import THEMES, Furnisher, to_world
from psdr_room_core.libraries.synth.instances import InstanceBox, camera_angles, camera_frame_boxes, visibility
from psdr_room_core.libraries.synth.room import camera_pose
from psdr_room_core.method.artifacts import Camera, RoomBox, rotation_y, vec3
from psdr_room_core.method.capabilities import Denoiser, Renderer
from psdr_room_core.method.geometry import TriangleMesh, box_mesh, quad_mesh
from psdr_room_core.method.rgb_scene import object_parts, room_quads, to_srgb8
from psdr_room_core.method.shading import Surface, planar_uv, srgb_to_linear, texture_transform
from psdr_room_plugins.eyes.labels import CATEGORIES, OBJECT

if TYPE_CHECKING:
    from psdr_room_plugins.material_graph.library import TorchGraphLibrary

PURE_PIXEL = 0.999
"""A pixel gets a depth label when one part covers at least this fraction of it."""
TEXTURE_SIZE = 128
"""Pixels of a texture map (material graphs and photo textures) on a shape."""
PHOTO_TEXTURE_NAMES = ("diff", "col", "albedo", "basecolor")
"""A photo texture set's colour map has one of these in its file name (or it is a single image)."""


@dataclass
class Sample:
    """One randomised room: the RGB scene, what each shape is, the camera."""

    seed: int
    camera: Camera
    camera_to_world: np.ndarray
    room: RoomBox
    meshes: dict[str, TriangleMesh] = field(default_factory=dict)
    surfaces: dict[str, Surface] = field(default_factory=dict)
    emitters: dict[str, tuple[TriangleMesh, tuple[float, float, float]]] = field(default_factory=dict)
    labels: dict[str, tuple[int, int, int]] = field(default_factory=dict)
    """Shape (or emitter) name → (surface class, category value, instance id)."""
    boxes: dict[int, InstanceBox] = field(default_factory=dict)
    """Instance id → its box as placed (world frame), model and category value."""


class Looks:
    """Random surfaces: flat colours, the material library's graphs at random parameters, photo textures."""

    def __init__(self, library: TorchGraphLibrary, textures: Sequence[Path], rng: np.random.Generator) -> None:
        self.library = library
        self.names = list(library.names())
        self.textures = list(textures)
        self.rng = rng

    def colour(self, kind: str) -> tuple[float, float, float]:
        """A linear base colour: pale paints for walls and ceilings, anything for the rest."""
        if kind in ("wall", "ceiling"):
            hsv = np.array(
                [
                    [
                        [
                            self.rng.uniform(0, 180),
                            self.rng.uniform(0, 90 if kind == "wall" else 20),
                            self.rng.uniform(170, 250),
                        ]
                    ]
                ],
                np.uint8,
            )
        else:
            hsv = np.array(
                [[[self.rng.uniform(0, 180), self.rng.uniform(0, 255), self.rng.uniform(30, 240)]]], np.uint8
            )
        rgb = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0, 0] / 255.0
        return vec3(srgb_to_linear(rgb))

    def _map(self) -> tuple[np.ndarray, np.ndarray, float]:
        """(linear base colour map, roughness map, tile size m) from a graph or a photo texture."""
        if self.textures and self.rng.random() < 0.4:
            path = self.textures[int(self.rng.integers(len(self.textures)))]
            read = cv2.imread(str(path), cv2.IMREAD_COLOR)
            if read is None:
                raise PsdrRoomError(f"{path}: not a readable image; remove it from the textures folder")
            image = cv2.resize(read, (TEXTURE_SIZE, TEXTURE_SIZE), interpolation=cv2.INTER_AREA)[..., ::-1] / 255.0
            image = image * self.rng.uniform(0.7, 1.2, 3)  # tinted
            rough = np.full((TEXTURE_SIZE, TEXTURE_SIZE, 1), self.rng.uniform(0.3, 0.9), np.float32)
            return srgb_to_linear(np.clip(image, 0, 1)).astype(np.float32), rough, float(self.rng.uniform(0.4, 2.0))
        import torch

        material = self.library.material(self.names[int(self.rng.integers(len(self.names)))])
        values = {}  # half way from the graph's own values towards random ones in range
        for key, b in material.bounds.items():
            value, lo, hi = (t.numpy().astype(float) for t in (b.value, b.lo, b.hi))
            values[key] = (value if b.fixed else value + 0.5 * (self.rng.uniform(lo, hi) - value)).tolist()
        with torch.no_grad():
            maps = material.evaluate(TEXTURE_SIZE, material.unconstrained(values), outputs=("base_color", "roughness"))
        base = srgb_to_linear(maps["base_color"]).permute(1, 2, 0).numpy().astype(np.float32)
        return base, maps["roughness"].permute(1, 2, 0).numpy().astype(np.float32), float(material.tile_size)

    def surface(self, kind: str, mesh: TriangleMesh, mapped: float) -> tuple[TriangleMesh, Surface]:
        """The mesh (split for texture coordinates when mapped, with probability ``mapped``) and its surface."""
        if self.rng.random() < mapped:
            base, rough, tile = self._map()
            split, metres = planar_uv(mesh)
            uv = texture_transform(metres, tile, float(self.rng.uniform(0.7, 1.5)), float(self.rng.choice([0, 90])))
            return split, Surface(base, rough, float(self.rng.uniform(0.3, 0.6)), uv)
        return mesh, Surface(self.colour(kind), float(self.rng.uniform(0.3, 0.95)), float(self.rng.uniform(0.3, 0.6)))


def photo_textures(folder: Path | None) -> list[Path]:
    """The colour maps under ``folder`` (none when None): single images, or the colour map of a map set."""
    if folder is None:
        return []
    files = sorted(p for p in folder.rglob("*") if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
    sets: dict[Path, list[Path]] = {}
    for path in files:
        sets.setdefault(path.parent, []).append(path)
    chosen = []
    for _parent, members in sets.items():
        colour = [p for p in members if any(n in p.stem.lower() for n in PHOTO_TEXTURE_NAMES)]
        chosen += colour[:1] if colour else [p for p in members if "_" not in p.stem or len(members) > 3]
    return chosen


def _rectangle(center: np.ndarray, u: np.ndarray, v: np.ndarray, normal: np.ndarray) -> TriangleMesh:
    """A rectangle centre ± u ± v whose front faces ``normal``."""
    quad = np.array([center - u - v, center + u - v, center + u + v, center - u + v])
    if np.dot(np.cross(quad[1] - quad[0], quad[2] - quad[0]), normal) < 0:
        quad = quad[::-1]
    return quad_mesh(quad)


def _merge(meshes: Sequence[TriangleMesh]) -> TriangleMesh:
    """One mesh of several (vertices stacked, faces renumbered)."""
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return TriangleMesh(
        vertices=np.concatenate([m.vertices for m in meshes]),
        faces=np.concatenate([m.faces + o for m, o in zip(meshes, offsets, strict=True)]),
    )


WallBox = Callable[[float, float, float, float, float, float], TriangleMesh]
"""``(along, bottom, top, half_width, inset, depth)`` → a box on a wall, ``inset`` in front of it."""


def window_dressing(
    rng: np.random.Generator, box: WallBox, along: float, sill: float, top: float, half_width: float, reach: float
) -> dict[str, TriangleMesh]:
    """What real windows have round and over their glass, all labelled window: a frame with mullions and
    transoms, and (by chance) a blind of slats lowered part way or curtains hanging beside (and over) it, cut
    to the wall (``along`` within ±``reach``)."""
    bar, depth = float(rng.uniform(0.025, 0.07)), float(rng.uniform(0.02, 0.08))
    parts = [
        box(along - half_width + bar / 2, sill, top, bar / 2, 0.0, depth),
        box(along + half_width - bar / 2, sill, top, bar / 2, 0.0, depth),
        box(along, sill, sill + bar, half_width, 0.0, depth),
        box(along, top - bar, top, half_width, 0.0, depth),
    ]
    columns, rows = int(rng.choice([0, 1, 1, 2, 3])), int(rng.choice([0, 0, 1, 2]))
    thin = 0.6 * bar
    parts += [
        box(along - half_width + 2 * half_width * (i + 1) / (columns + 1), sill, top, thin / 2, 0.0, depth)
        for i in range(columns)
    ]
    parts += [
        box(along, y - thin / 2, y + thin / 2, half_width, 0.0, depth)
        for y in sill + (top - sill) * (np.arange(rows) + 1) / (rows + 1)
    ]
    dressing = {"frame": _merge(parts)}
    if rng.random() < 0.25:  # a blind, lowered part way
        pitch = float(rng.uniform(0.025, 0.06))
        bottom = top - float(rng.uniform(0.3, 1.0)) * (top - sill)
        slats = [
            box(along, y, y + 0.85 * pitch, half_width - bar, depth + 0.01, 0.004)
            for y in np.arange(top - bar - pitch, bottom, -pitch)
        ]
        if slats:
            dressing["blind"] = _merge(slats)
    if rng.random() < 0.35:  # curtains: one or two folded panels, from above the window to the sill or floor
        drop = 0.02 if rng.random() < 0.6 else max(sill - 0.15, 0.02)
        for side in [-1, 1] if rng.random() < 0.7 else [int(rng.choice([-1, 1]))]:
            width = float(rng.uniform(0.15, 0.55))
            centre = along + side * (half_width + width / 2 - float(rng.uniform(0.0, 0.6)) * width)
            left, right = max(centre - width / 2, -reach), min(centre + width / 2, reach)
            if right - left < 0.1:
                continue
            folds = [
                box(
                    left + (right - left) * (i + 0.5) / 6,
                    drop,
                    top + 0.12,
                    (right - left) / 12,
                    depth + 0.04 + 0.03 * (i % 2),
                    0.03,
                )
                for i in range(6)
            ]
            dressing[f"curtain_{side:+d}"] = _merge(folds)
    return dressing


def _light_colour(rng: np.random.Generator, daylight: bool) -> np.ndarray:
    """A light's RGB tint: warm to cool white (daylight cooler)."""
    warm = rng.uniform(0.0, 0.4) if daylight else rng.uniform(0.0, 1.0)
    return np.array([1.0, 1.0 - 0.15 * warm, 1.0 - 0.4 * warm]) * (np.array([0.9, 0.95, 1.0]) if daylight else 1.0)


def sample_room(
    seed: int,
    database: ObjectDatabase,
    library: TorchGraphLibrary,
    textures: Sequence[Path],
    width: int = 320,
    height: int = 240,
) -> Sample:
    """A random furnished room and camera for ``seed``: room size and shape (corridors too), camera height,
    pitch, roll and FoV, a theme's furniture arrangement, materials, windows, a door and lights."""
    rng = np.random.default_rng(seed)
    corridor = rng.random() < 0.1
    half = np.array([rng.uniform(1.4, 4.0), rng.uniform(1.2, 1.7), rng.uniform(1.8, 4.5)])
    if corridor:
        half[0] = rng.uniform(0.6, 1.0)
    vfov = float(rng.uniform(40.0, 80.0))
    cam_height = float(rng.uniform(0.8, 1.9))
    pitch = float(np.clip(rng.normal(-12.0, 12.0), -50.0, 25.0))
    roll = float(rng.normal(0.0, 2.5)) if rng.random() < 0.7 else 0.0
    yaw = math.radians(rng.uniform(-45.0, 45.0))
    camera_local = np.array([rng.uniform(-0.5, 0.5) * half[0], cam_height, -half[2] + rng.uniform(0.2, 1.5)])
    center = -(rotation_y(yaw) @ (camera_local * np.array([1.0, 0.0, 1.0])))
    room = RoomBox(camera_to_world=np.eye(4), center=np.array([center[0], half[1], center[2]]), half_size=half, yaw=yaw)
    fy = 0.5 * height / math.tan(math.radians(vfov) / 2)
    camera = Camera(width=width, height=height, fx=fy, fy=fy, cx=width / 2, cy=height / 2, method="synthetic")
    c2w = camera_pose(cam_height, pitch, roll)
    looks = Looks(library, textures, rng)
    sample = Sample(seed, camera, c2w, room)

    def local_to_world(p: np.ndarray) -> np.ndarray:
        return np.array([center[0], 0.0, center[2]]) + rotation_y(yaw) @ p

    def axis_to_world(v: np.ndarray) -> np.ndarray:
        return rotation_y(yaw) @ v

    surface_of = {"floor": 2, "ceiling": 3}
    for name, quad in room_quads(room).items():
        kind = name.split("_")[0]
        mesh, look = looks.surface(kind, quad_mesh(quad), {"floor": 0.85, "wall": 0.3, "ceiling": 0.1}[kind])
        sample.meshes[name], sample.surfaces[name] = mesh, look
        sample.labels[name] = (surface_of.get(kind, 1), 0, 0)

    walls = {0: np.array([0.0, 0.0, 1.0]), 1: np.array([-1.0, 0.0, 0.0]), 2: np.array([1.0, 0.0, 0.0])}  # outward
    openings: list[tuple[int, float, float]] = []  # wall, centre along, half width

    def opening(wall: int, half_width: float) -> float | None:
        """A free spot (coordinate along the wall) for a window or door ``half_width`` wide."""
        span = (half[2] if wall else half[0]) - half_width - 0.1
        if span <= 0:
            return None
        for _ in range(10):
            along = float(rng.uniform(-span, span))
            if all(w != wall or abs(a - along) > h + half_width + 0.1 for w, a, h in openings):
                openings.append((wall, along, half_width))
                return along
        return None

    def on_wall(
        wall: int, along: float, bottom: float, top: float, inset: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(the room-local centre of a span from ``bottom`` to ``top`` at ``along``, ``inset`` in front of the
        wall; the wall's outward normal; its tangent)."""
        direction = walls[wall]
        tangent = np.array([1.0, 0.0, 0.0]) if wall == 0 else np.array([0.0, 0.0, 1.0])
        centre = direction * (half[2] if wall == 0 else half[0]) - direction * inset + tangent * along
        centre[1] = (bottom + top) / 2
        return centre, direction, tangent

    def wall_rect(wall: int, along: float, bottom: float, top: float, half_width: float, inset: float) -> TriangleMesh:
        centre, direction, tangent = on_wall(wall, along, bottom, top, inset)
        return _rectangle(
            local_to_world(centre),
            axis_to_world(tangent * half_width),
            np.array([0.0, (top - bottom) / 2, 0.0]),
            axis_to_world(-direction),
        )

    def wall_box(
        wall: int, along: float, bottom: float, top: float, half_width: float, inset: float, depth: float
    ) -> TriangleMesh:
        centre, direction, tangent = on_wall(wall, along, bottom, top, inset)
        size = tangent * half_width + np.array([0.0, (top - bottom) / 2, 0.0]) + np.abs(direction) * depth / 2
        return box_mesh(local_to_world(centre - direction * depth / 2), size, rotation_y(yaw))

    for k in range(int(rng.choice([0, 1, 1, 2, 3]))):  # windows, daylight
        wall, half_width = int(rng.integers(3)), float(rng.uniform(0.4, 1.1))
        along = opening(wall, half_width)
        if along is None:
            continue
        sill = float(rng.uniform(0.4, 1.0))
        top = min(sill + rng.uniform(1.0, 1.8), 2 * half[1] - 0.15)
        name = f"window_{k}"
        radiance = _light_colour(rng, True) * rng.uniform(3.0, 25.0)
        horizon = float(rng.uniform(sill, top)) if rng.random() < 0.6 else sill  # a view: sky above, darker below
        sample.emitters[name] = (wall_rect(wall, along, horizon, top, half_width, 0.004), vec3(radiance))
        sample.labels[name] = (4, 0, 0)
        if horizon > sill:
            ground = np.asarray(looks.colour("object")) * radiance.max() * rng.uniform(0.2, 0.8)
            sample.emitters[f"{name}_view"] = (wall_rect(wall, along, sill, horizon, half_width, 0.004), vec3(ground))
            sample.labels[f"{name}_view"] = (4, 0, 0)
        box = partial(wall_box, wall)
        reach = (half[2] if wall else half[0]) - 0.02
        for part, mesh in window_dressing(rng, box, along, sill, top, half_width, reach).items():
            kind = "object" if part.startswith("curtain") else "door"
            sample.meshes[f"{name}_{part}"], sample.surfaces[f"{name}_{part}"] = looks.surface(kind, mesh, 0.4)
            sample.labels[f"{name}_{part}"] = (4, 0, 0)
    if rng.random() < 0.5:  # a door
        wall, half_width = int(rng.integers(3)), float(rng.uniform(0.4, 0.5))
        along = opening(wall, half_width)
        if along is not None:
            door_top = min(2.05, 2 * half[1] - 0.1)
            mesh, look = looks.surface("door", wall_rect(wall, along, 0.0, door_top, half_width, 0.008), 0.5)
            sample.meshes["door"], sample.surfaces["door"] = mesh, look
            sample.labels["door"] = (5, 0, 0)
            casing = float(rng.uniform(0.04, 0.1))
            trim = [
                wall_box(wall, along - half_width - casing / 2, 0.0, door_top + casing, casing / 2, 0.0, 0.02),
                wall_box(wall, along + half_width + casing / 2, 0.0, door_top + casing, casing / 2, 0.0, 0.02),
                wall_box(wall, along, door_top, door_top + casing, half_width, 0.0, 0.02),
            ]
            side = float(rng.choice([-1.0, 1.0]))
            handle = wall_box(wall, along + side * (half_width - 0.08), 0.95, 1.0, 0.05, 0.008, 0.05)
            sample.meshes["door_trim"], sample.surfaces["door_trim"] = looks.surface("door", _merge(trim), 0.3)
            sample.meshes["door_handle"] = handle
            sample.surfaces["door_handle"] = Surface(looks.colour("object"), 0.3, 0.5)
            sample.labels["door_trim"] = sample.labels["door_handle"] = (5, 0, 0)

    furnisher = Furnisher(database, half, camera_local, rng)
    for placement, _ in furnisher.furnish(str(rng.choice(THEMES))):
        world = to_world(placement, center, yaw)
        for name, (mesh, srgb) in object_parts(world).items():
            if rng.random() < 0.35:  # the model's own colour, varied
                colour = srgb_to_linear(np.clip(np.asarray(srgb) * rng.uniform(0.7, 1.3, 3), 0, 1))
                mesh_, look = mesh, Surface(vec3(colour), float(rng.uniform(0.3, 0.9)), 0.5)
            else:
                mesh_, look = looks.surface("object", mesh, 0.5)
            sample.meshes[name], sample.surfaces[name] = mesh_, look
            sample.labels[name] = (OBJECT, CATEGORIES.index(world.category) + 1, world.segment_id)
        sample.boxes[world.segment_id] = InstanceBox.of_placement(world, CATEGORIES.index(world.category) + 1)

    panels = int(rng.choice([0, 1, 1, 2, 2, 3, 4])) if sample.emitters else int(rng.integers(1, 5))
    for k in range(panels):  # ceiling panels facing down
        size = rng.uniform(0.15, 0.6, 2)
        spot = np.array([rng.uniform(-0.7, 0.7) * half[0], 2 * half[1] - 0.01, rng.uniform(-0.6, 0.8) * half[2]])
        name = f"light_{k}"
        radiance = _light_colour(rng, False) * rng.uniform(5.0, 30.0) * (0.1 / (size[0] * size[1])) ** 0.5
        sample.emitters[name] = (
            _rectangle(
                local_to_world(spot),
                axis_to_world(np.array([size[0], 0, 0])),
                axis_to_world(np.array([0, 0, size[1]])),
                np.array([0.0, -1.0, 0.0]),
            ),
            vec3(radiance),
        )
        sample.labels[name] = (OBJECT, CATEGORIES.index("lamp") + 1, 1000 + k)
        sample.boxes[1000 + k] = InstanceBox(
            local_to_world(spot), np.array([2 * size[0], 0.0, 2 * size[1]]), yaw, "", CATEGORIES.index("lamp") + 1
        )
    return sample


def label_maps(sample: Sample, renderer: Renderer) -> dict[str, np.ndarray]:
    """Exact labels of ``sample`` from one render of every shape and emitter as its own part: a pixel's
    surface, category and instance are those of the part covering most of it, its depth the z-depth averaged
    over its area (the renderer's samples) where one part covers it (:data:`PURE_PIXEL`), else 0 (none)."""
    import torch

    meshes = {**sample.meshes, **{name: mesh for name, (mesh, _) in sample.emitters.items()}}
    names = list(meshes)
    geometry = renderer.geometry(
        sample.camera,
        sample.camera_to_world,
        meshes,
        {n: i for i, n in enumerate(names)},
    )
    with torch.no_grad():
        masks, depth, alpha = (t.numpy() for t in geometry.render())
    part = np.where(alpha > 0.5, masks.argmax(axis=0), -1)
    table = np.array([(0, 0, 0)] + [sample.labels[n] for n in names], dtype=np.int64)
    values = table[part + 1]
    single = masks.max(axis=0) > PURE_PIXEL  # a pixel across an edge mixes two depths: no depth label
    return {
        "surface": values[..., 0].astype(np.uint8),
        "category": values[..., 1].astype(np.uint8),
        "instance": values[..., 2].astype(np.uint16),
        "depth": np.where(single, depth / np.maximum(alpha, 1e-6), 0.0).astype(np.float16),
    }


def instance_labels(sample: Sample) -> dict[str, np.ndarray]:
    """The 3D labels of ``sample``'s instances in id order and the camera's pitch and roll, exact from the
    generator (:mod:`psdr_room_core.libraries.synth.instances`), under the keys of the sample file."""
    meshes = {**sample.meshes, **{name: mesh for name, (mesh, _) in sample.emitters.items()}}
    ids = sorted(sample.boxes)
    parts: dict[int, list[TriangleMesh]] = {k: [] for k in ids}
    others: list[TriangleMesh] = []
    for name, mesh in meshes.items():
        instance = sample.labels[name][2]
        (parts[instance] if instance else others).append(mesh)
    boxes = camera_frame_boxes({k: sample.boxes[k] for k in ids}, sample.camera_to_world)
    visible, cut = visibility(sample.camera, sample.camera_to_world, {k: _merge(parts[k]) for k in ids}, _merge(others))
    _, pitch, roll = camera_angles(sample.camera_to_world)
    return {
        "camera_pitch": np.array(pitch),
        "camera_roll": np.array(roll),
        "instance_ids": np.array(ids, np.uint16),
        **{f"instance_{key}": value for key, value in boxes.items()},
        "instance_visible": visible,
        "instance_cut": cut,
    }


def render_photo(sample: Sample, renderer: Renderer, denoiser: Denoiser, spp: int) -> np.ndarray:
    """The sample's photo: path traced at ``spp``, denoised, auto-exposed to a random brightness, sRGB uint8."""
    import torch

    geometry = renderer.geometry(
        sample.camera,
        sample.camera_to_world,
        sample.meshes,
        {},
        surfaces=sample.surfaces,
        emitters=sample.emitters,
    )
    with torch.no_grad():
        noisy = geometry.render_rgb(spp=spp).numpy()
    clean = denoiser.denoise(noisy, *geometry.render_guides(spp=4))
    rng = np.random.default_rng(sample.seed + 7)
    scale = rng.uniform(0.6, 1.0) / max(float(np.percentile(clean, 97)), 1e-6)
    return to_srgb8(np.clip(clean * scale, 0.0, 1.0))


def write_sample(seed: int, out: Path, spp: int, width: int, height: int, textures: Sequence[Path]) -> float:
    """Make and write sample ``seed`` into ``out`` (skipped when both files exist); seconds taken."""
    from psdr_room_core.engine.plugins import plugin_system

    start = time.monotonic()
    photo, labels = out / f"{seed:06d}.jpg", out / f"{seed:06d}.npz"
    if photo.is_file() and labels.is_file():
        return 0.0
    registry = plugin_system().registry
    made = tools(registry)
    sample = sample_room(seed, made.database, made.library, textures, width, height)
    maps = label_maps(sample, made.renderer)
    image = render_photo(sample, made.renderer, made.denoiser, spp)
    unfinished = labels.with_suffix(".part.npz")
    arrays: dict[str, Any] = {  # Any: numpy's stub would read a dict of arrays as its allow_pickle flag
        **maps,
        "room": np.r_[sample.room.center, sample.room.half_size, sample.room.yaw],
        "camera": np.array([sample.camera.fx, sample.camera.fy, sample.camera.cx, sample.camera.cy]),
        "camera_to_world": sample.camera_to_world,
        **instance_labels(sample),
    }
    np.savez_compressed(unfinished, **arrays)
    cv2.imwrite(str(photo.with_suffix(".part.jpg")), image[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 95])
    os.replace(unfinished, labels)
    os.replace(photo.with_suffix(".part.jpg"), photo)
    return time.monotonic() - start


@dataclass(frozen=True)
class Tools:
    """What a worker process renders samples with: the object database, the material library, a one-thread
    renderer and the denoiser."""

    database: ObjectDatabase
    library: TorchGraphLibrary
    renderer: Renderer
    denoiser: Denoiser


_TOOLS: list[Tools] = []
"""This process's tools, made on its first sample."""


def tools(registry: Registry) -> Tools:
    """This process's :class:`Tools`, made once."""
    if not _TOOLS:
        from psdr_room_core.libraries.object_db.builtin import builtin_database

        _TOOLS.append(
            Tools(
                database=builtin_database(),
                library=registry.implementation("material_graph", "torch_graph").factory(),
                renderer=registry.implementation("renderer", "mitsuba").factory(
                    variant="llvm_ad_rgb", max_depth=4, threads=1
                ),
                denoiser=registry.implementation("denoiser", "oidn").factory(),
            )
        )
    return _TOOLS[0]


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of ``psdr-room-synth-data``: render a data set for the eyes network."""
    from joblib import Parallel, delayed

    from psdr_room_core.applications.synth import parse_seeds

    parser = argparse.ArgumentParser(
        description="Render randomised furnished rooms with exact labels (a data set "
        "for the eyes network; samples already there are kept)."
    )
    parser.add_argument("--out", type=Path, required=True, help="data set folder (<seed>.jpg + <seed>.npz)")
    parser.add_argument("--seeds", default="0-4999", help="e.g. 0-4999 or 1,5,7")
    parser.add_argument("--spp", type=int, default=16, help="path tracer samples per pixel (denoised after)")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--textures", type=Path, help="a folder of photo textures to use beside the material graphs")
    parser.add_argument("--jobs", type=int, default=1, help="parallel processes (joblib)")
    args = parser.parse_args(argv)
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError:
        parser.error(f"--seeds {args.seeds}: give a range like 0-4999 or a list like 1,5,7")
    if args.textures is not None and not args.textures.is_dir():
        parser.error(f"--textures {args.textures}: no such folder")
    if min(args.width, args.height, args.spp, args.jobs) < 1:
        parser.error("--width, --height, --spp and --jobs must be at least 1")
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {args.out}: a file is in the way; name a folder")
    args.out.mkdir(parents=True, exist_ok=True)
    textures = photo_textures(args.textures)
    start = time.monotonic()
    try:
        times = Parallel(n_jobs=args.jobs, batch_size=4)(
            delayed(write_sample)(seed, args.out, args.spp, args.width, args.height, textures) for seed in seeds
        )
    except PsdrRoomError as exc:
        parser.exit(PsdrRoomError.exit_code, f"psdr-room-synth-data: error: {exc}\n")
    made = sum(t > 0 for t in times)
    minutes = (time.monotonic() - start) / 60.0
    print(
        f"psdr-room-synth-data: {made} samples made ({len(seeds) - made} already there) in {minutes:.1f} min: "
        f"{made / max(minutes, 1e-9):.1f} images/min with {args.jobs} process(es) into {args.out}"
    )
