"""Photo-like rendering of a synthetic room with Mitsuba 3's path tracer (global illumination)."""

from __future__ import annotations

import numpy as np

from psdr_room_core.method.artifacts import RoomBox, rotation_y
from psdr_room_core.method.rgb_scene import room_quads
from psdr_room_core.method.stages.export import CV_TO_MITSUBA

from .room import Box, SyntheticRoom


def _rectangle_frame(quad: np.ndarray) -> np.ndarray:
    """to_world of Mitsuba's rectangle ([-1,1]² at z=0, normal +z) onto a quad (normal = its winding's)."""
    center = quad.mean(axis=0)
    a, b = (quad[1] - quad[0]) / 2, (quad[3] - quad[0]) / 2
    normal = np.cross(a, b)
    frame = np.eye(4)
    frame[:3, :3] = np.stack([a, b, normal / np.linalg.norm(normal)], axis=1)
    frame[:3, 3] = center
    return frame


def _box_frame(box: Box) -> np.ndarray:
    frame = np.eye(4)
    frame[:3, :3] = rotation_y(box.yaw) @ np.diag(box.half)
    frame[:3, 3] = box.center
    return frame


def scene_dict(room: SyntheticRoom, spp: int, max_depth: int) -> dict:
    """The Mitsuba scene description of ``room`` (built-in shapes only)."""
    import mitsuba as mi

    def transform(m: np.ndarray) -> mi.ScalarTransform4f:
        return mi.ScalarTransform4f(np.asarray(m, dtype=np.float64).tolist())

    def diffuse(rgb: tuple[float, ...]) -> dict:
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [float(c) for c in rgb]}}

    scene: dict = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": room.vfov_deg,
            "to_world": transform(np.asarray(room.camera_to_world) @ CV_TO_MITSUBA),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": room.width, "height": room.height, "rfilter": {"type": "gaussian"}},
        },
        "ambient": {"type": "constant", "radiance": {"type": "rgb", "value": 0.02}},
    }
    box = RoomBox(
        camera_to_world=np.eye(4),
        center=np.array(room.room.center),
        half_size=np.array(room.room.half),
        yaw=room.room.yaw,
    )
    tiles = {"floor": max(room.room.half[0], room.room.half[2]) * 2.0}
    for name, quad in room_quads(box).items():
        kind = name.split("_")[0]
        bsdf = diffuse(room.albedo[kind])
        if kind in tiles:  # floor tiles: straight edges for the FoV estimator, texture for appearance
            dark = tuple(0.6 * c for c in room.albedo[kind])
            bsdf = {
                "type": "diffuse",
                "reflectance": {
                    "type": "checkerboard",
                    "color0": {"type": "rgb", "value": list(room.albedo[kind])},
                    "color1": {"type": "rgb", "value": list(dark)},
                    "to_uv": mi.ScalarTransform4f().scale([tiles[kind], tiles[kind], 1.0]),
                },
            }
        scene[name] = {"type": "rectangle", "to_world": transform(_rectangle_frame(quad)), "bsdf": bsdf}
    for piece in room.furniture:
        for k, part in enumerate(piece.parts):
            scene[f"object_{piece.id}_{k}"] = {
                "type": "cube",
                "to_world": transform(_box_frame(part)),
                "bsdf": diffuse(piece.albedo),
            }
    for k, light in enumerate(room.lights):
        frame = np.eye(4)  # a rectangle facing down (-y), at the light's height
        frame[:3, :3] = rotation_y(light.yaw) @ np.array([[light.half[0], 0, 0], [0, 0, -1], [0, light.half[1], 0]])
        frame[:3, 3] = light.center
        scene[f"light_{k}"] = {
            "type": "rectangle",
            "to_world": transform(frame),
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": light.radiance}},
        }
    return scene


def exposure(linear: np.ndarray, percentile: float = 97.0, target: float = 0.85) -> float:
    """The auto-exposure of a linear render: the factor that puts its ``percentile`` at ``target``."""
    return target / max(float(np.percentile(linear, percentile)), 1e-6)


def render_photo(
    room: SyntheticRoom, spp: int = 64, max_depth: int = 5, variant: str = "llvm_ad_rgb"
) -> tuple[np.ndarray, float]:
    """Path-traced RGB photo (uint8 HxWx3, sRGB, auto-exposed) of the synthetic room, and its exposure: photo
    values are the sRGB encoding of exposure × radiance (the scale the light intensities are compared in)."""
    import mitsuba as mi

    from psdr_room_core.method.rgb_scene import to_srgb8

    mi.set_variant(variant)
    scene = mi.load_dict(scene_dict(room, spp, max_depth))
    image = np.asarray(mi.render(scene, seed=room.seed), dtype=np.float32)[..., :3]
    scale = exposure(image)
    return to_srgb8(image * scale), scale
