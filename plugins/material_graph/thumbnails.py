"""Pictures of materials: a fast torch shading of the maps, and Mitsuba thumbnails.

:func:`shade` lights the maps of a flat patch with one directional light and an ambient term (Lambert +
GGX specular): cheap, differentiable, used by the retrieval benchmark and for quick looks.
:class:`ThumbnailRenderer` renders the paper-style thumbnail with Mitsuba's own ``principled`` BSDF (base
colour, roughness and metallic bitmaps, under a ``normalmap``): a textured plane and a sphere under fixed
lighting (a large soft key light and a sky-like environment), path traced. The scene is built once; each
material only replaces the bitmaps, so Dr.Jit's compiled kernels are reused.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch

from psdr_room_core.method.shading import linear_to_srgb, srgb_to_linear
from psdr_room_core.method.visualize import to_uint8

DEFAULT_LIGHT = (-0.45, 0.55, 0.70)
"""Direction towards the light in the patch's tangent frame (x right, y up the image, z out)."""


def shade(
    maps: Mapping[str, torch.Tensor],
    light: Sequence[float] = DEFAULT_LIGHT,
    intensity: float = 2.6,
    ambient: float = 0.35,
    light_colour: Sequence[float] = (1.0, 1.0, 1.0),
    exposure: float = 1.0,
) -> torch.Tensor:
    """An sRGB image [3, H, W] of the material seen head-on, lit from direction ``light`` (differentiable)."""
    base = srgb_to_linear(maps["base_color"])
    n = maps["normal"]
    rough = maps["roughness"].clamp(min=0.04)
    metal = maps["metallic"]
    dev, dt = base.device, base.dtype
    l = torch.tensor(light, dtype=dt, device=dev)
    l = (l / l.norm()).reshape(3, 1, 1)
    v = torch.tensor([0.0, 0.0, 1.0], dtype=dt, device=dev).reshape(3, 1, 1)
    h = (l + v) / (l + v).norm()
    n_l = (n * l).sum(0, keepdim=True).clamp(min=0.0)
    n_h = (n * h).sum(0, keepdim=True).clamp(min=0.0)
    alpha2 = (rough * rough) ** 2
    ggx = alpha2 / (math.pi * ((n_h * n_h) * (alpha2 - 1.0) + 1.0) ** 2)
    f0 = torch.lerp(torch.full_like(base, 0.04), base, metal)
    specular = f0 * ggx * n_l * (0.25 / max(float((l * v).sum()), 0.3))
    diffuse = base * (1.0 - metal) * n_l / math.pi
    colour = torch.tensor(light_colour, dtype=dt, device=dev).reshape(3, 1, 1)
    env = ambient * torch.lerp(base, f0 * 0.6 + 0.02, metal)
    radiance = (diffuse + specular) * intensity * colour + env
    return linear_to_srgb(radiance * exposure)


def tensor_to_uint8(image: torch.Tensor) -> np.ndarray:
    """A [3, H, W] tensor in [0, 1] as H×W×3 uint8 (:func:`~psdr_room_core.method.visualize.to_uint8`)."""
    return to_uint8(image.detach().permute(1, 2, 0).cpu().numpy())


def map_images(maps: Mapping[str, torch.Tensor]) -> dict[str, np.ndarray]:
    """Each output map as an RGB uint8 image (normals encoded as (n + 1) / 2)."""
    out = {}
    for name, x in maps.items():
        x = x.detach()
        if name == "normal":
            x = x * 0.5 + 0.5
        if x.shape[0] == 1:
            x = x.expand(3, -1, -1)
        out[name] = tensor_to_uint8(x)
    return out


# ------------------------------------------------------------------------------------------ Mitsuba
class ThumbnailRenderer:
    """Mitsuba thumbnails: a plane and a sphere with the material under fixed lighting."""

    def __init__(self, size: int = 256, spp: int = 64, map_size: int = 512, variant: str = "auto") -> None:
        self.size = int(size)
        self.spp = int(spp)
        self.map_size = int(map_size)
        self.requested_variant = variant
        self._scene: Any = None
        self._shapes: dict[str, tuple[int, ...]] = {}
        self._keys: dict[str, list[str]] = {}

    def _mi(self) -> Any:
        from psdr_room_core.libraries.llvm import resolve_variant

        variant = resolve_variant(self.requested_variant)
        import mitsuba as mi

        if mi.variant() != variant:
            mi.set_variant(variant)
        return mi

    @staticmethod
    def _bitmaps(maps: Mapping[str, torch.Tensor]) -> dict[str, np.ndarray]:
        """H×W×C float32 arrays as the principled BSDF reads them (linear base colour, Mitsuba's tangent
        frame: its v, hence the frame's y, grows down the image, so the normal's y is negated)."""
        normal = maps["normal"].detach().clone()
        normal[1] = -normal[1]
        arrays = {
            "base_color": srgb_to_linear(maps["base_color"].detach()),
            "roughness": maps["roughness"].detach(),
            "metallic": maps["metallic"].detach(),
            "normal": normal * 0.5 + 0.5,
        }
        return {k: np.ascontiguousarray(v.permute(1, 2, 0).cpu().numpy(), dtype=np.float32) for k, v in arrays.items()}

    def _build(self, mi: Any, bitmaps: Mapping[str, np.ndarray]) -> Any:
        def bsdf(uv_scale: tuple[float, float]) -> dict[str, Any]:
            to_uv = mi.ScalarTransform4f().scale([uv_scale[0], uv_scale[1], 1.0])

            def tex(name: str) -> dict[str, Any]:
                return {
                    "type": "bitmap",
                    "bitmap": mi.Bitmap(bitmaps[name]),
                    "raw": True,
                    "to_uv": to_uv,
                    "wrap_mode": "repeat",
                    "filter_type": "bilinear",
                }

            return {
                "type": "normalmap",
                "normalmap": tex("normal"),
                "bsdf": {
                    "type": "principled",
                    "base_color": tex("base_color"),
                    "roughness": tex("roughness"),
                    "metallic": tex("metallic"),
                },
            }

        sky = np.zeros((32, 64, 3), np.float32)
        elevation = np.cos(np.linspace(0.0, math.pi, 32))[:, None, None]  # +1 at the zenith row
        sky[:] = np.where(elevation > 0, 0.55 + 0.35 * elevation, 0.25 + 0.1 * (1 + elevation)) * np.array(
            [0.95, 1.0, 1.08], np.float32
        )
        camera = mi.ScalarTransform4f().look_at(origin=[0.0, 2.3, 3.4], target=[0.0, 0.55, 0.0], up=[0.0, 1.0, 0.0])
        scene = {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 4},
            "sensor": {
                "type": "perspective",
                "fov": 36.0,
                "to_world": camera,
                "film": {
                    "type": "hdrfilm",
                    "width": self.size,
                    "height": self.size,
                    "pixel_format": "rgb",
                    "rfilter": {"type": "gaussian"},
                },
                "sampler": {"type": "independent", "sample_count": self.spp},
            },
            "sky": {"type": "envmap", "bitmap": mi.Bitmap(sky), "scale": 0.55},
            "key": {
                "type": "rectangle",
                "to_world": mi.ScalarTransform4f()
                .look_at(origin=[-2.2, 3.6, 2.0], target=[0.0, 0.4, 0.0], up=[0.0, 1.0, 0.0])
                .scale([1.1, 1.1, 1.0]),
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [5.5, 5.3, 5.0]}},
            },
            "floor": {
                "type": "rectangle",
                "to_world": mi.ScalarTransform4f().rotate([1.0, 0.0, 0.0], -90.0).scale([2.2, 2.2, 1.0]),
                "bsdf": bsdf((2.0, 2.0)),
            },
            "ball": {
                "type": "sphere",  # poles along y, so the camera sees the texture's equator band
                "to_world": mi.ScalarTransform4f()
                .translate([0.0, 0.62, 0.0])
                .rotate([1.0, 0.0, 0.0], -90.0)
                .rotate([0.0, 0.0, 1.0], 60.0)
                .scale(0.62),
                "bsdf": bsdf((3.0, 1.5)),
            },
        }
        return mi.load_dict(scene, optimize=False)

    def render(self, maps: Mapping[str, torch.Tensor]) -> np.ndarray:
        """The thumbnail of one material's maps (as evaluated at ``map_size``): H×W×3 sRGB uint8."""
        mi = self._mi()
        bitmaps = self._bitmaps(maps)
        if self._scene is None or any(bitmaps[k].shape != self._shapes[k] for k in bitmaps):
            self._scene = self._build(mi, bitmaps)
            self._shapes = {k: v.shape for k, v in bitmaps.items()}
            params = mi.traverse(self._scene)
            self._params = params
            self._keys = {
                name: [k for k in params.keys() if k.endswith(f"{name}.data")]  # noqa: SIM118 (iterating SceneParameters yields (key, value))
                for name in ("base_color", "roughness", "metallic", "normalmap")
            }
        else:
            params = self._params
            for name, keys in self._keys.items():
                array = bitmaps["normal" if name == "normalmap" else name]
                for key in keys:
                    params[key] = type(params[key])(array)
            params.update()
        image = np.array(mi.render(self._scene, spp=self.spp, seed=0))
        return to_uint8(linear_to_srgb(torch.from_numpy(image)).numpy())
