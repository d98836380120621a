"""``psdr_geometry``: a projective-sampling integrator whose "radiance" is per-part coverage and z-depth.

Each render fills any number of *channels* (the film's RGB, then AOVs), chosen per integrator instance:
a part's coverage (1 where a shape of that part is the first hit, else 0), the z-depth of the first hit
(distance along the camera's optical axis, 0 where nothing is hit), or alpha (1 on any hit). The values are
constant per shape (coverage, alpha) or follow the surface along a fixed camera ray (depth), so:

* the continuous (interior) derivative is the derivative of the hit distance, through ``ray_intersect``
  with gradients resumed (only depth has one);
* the discontinuous derivative lives on the primarily visible silhouettes only: foreground minus
  background value across each silhouette edge, sampled by :class:`mitsuba.ad.integrators.common.PSIntegrator`
  (projective sampling of the camera's silhouettes). There is no shading, hence no indirect
  (shadow) boundary term: ``sppi`` is always 0.

Which part a hit belongs to is looked up from the shape pointer: in the JIT variants a shape pointer is
its registry index, and ``part_of_shape`` (an opaque float array indexed by it) maps it to a part index
(-1: no part). The channel codes are opaque as well, so scenes with the same channel count share one
compiled kernel.
"""

from __future__ import annotations

import importlib
from typing import Any

import drjit as dr
import mitsuba as mi

NAME = "psdr_geometry"

DEPTH = -1.0
"""``channels`` code for z-depth."""
ALPHA = -2.0
"""``channels`` code for alpha (any hit)."""
UNUSED = -3.0
"""``channels`` code for a channel left at 0."""


def projective_base() -> Any:
    """Mitsuba's ``PSIntegrator`` (``mitsuba.ad.integrators.common``) for the current variant. Imported by name:
    mypy 2.4 stops with an internal error resolving that import against Mitsuba's ``ad.pyi`` stub."""
    return importlib.import_module("mitsuba.ad.integrators.common").PSIntegrator


def _make_class() -> type:
    """The integrator class for the current variant (PSIntegrator derives from the variant's C++ class)."""
    PSIntegrator = projective_base()

    class GeometryIntegrator(PSIntegrator):  # type: ignore[misc,valid-type]
        """Coverage / z-depth / alpha with projective sampling of primary silhouettes (``sppi`` = 0)."""

        def __init__(self, props: mi.Properties) -> None:
            super().__init__(props)
            self.max_depth = 1
            self.rr_depth = 1
            self.radiative_backprop = False  # the continuous term goes through AD in render_ad
            self.sppi = 0
            self.guiding = "none"
            self.sample_border_warning = False
            self.part_of_shape = mi.Float(-1.0)
            self.codes = [mi.Float(UNUSED)] * 3
            self.camera_origin = mi.Point3f(0.0)
            self.camera_axis = mi.Vector3f(0.0, 0.0, 1.0)

        def configure(
            self,
            part_of_shape: list[float],
            channels: list[float],
            camera_origin: tuple[float, float, float],
            camera_axis: tuple[float, float, float],
        ) -> None:
            """Set the shape → part table (indexed by shape registry id), the channel codes (a part index,
            :data:`DEPTH` or :data:`ALPHA` each; at least 3, padded with :data:`UNUSED`), and the camera."""
            self.part_of_shape = mi.Float([float(p) for p in part_of_shape])
            dr.make_opaque(self.part_of_shape)
            codes = [float(c) for c in channels] + [UNUSED] * max(0, 3 - len(channels))
            self.codes = [dr.opaque(mi.Float, c) for c in codes]
            self.camera_origin = mi.Point3f(*(dr.opaque(mi.Float, float(c)) for c in camera_origin))
            self.camera_axis = mi.Vector3f(*(dr.opaque(mi.Float, float(c)) for c in camera_axis))

        def aov_names(self) -> list[str]:
            """Channels beyond the first three travel as AOVs (film layout R, G, B, weight, AOVs...)."""
            return [f"channel_{k}" for k in range(3, len(self.codes))]

        def sample_rays(self, scene, sensor, sampler):
            """The camera's rays with a scalar (Float) weight: ``render_ad`` multiplies each AOV by the ray
            weight, and a Spectrum weight would turn the AOVs into colours. A pinhole camera's weight is
            the same in every channel (1)."""
            ray, weight, pos = super().sample_rays(scene, sensor, sampler)
            return ray, mi.Float(weight[0]), pos

        # ------------------------------------------------------------------------------------------- values
        def _values(self, shape: mi.ShapePtr, p: mi.Point3f, valid: mi.Bool) -> list[mi.Float]:
            """Every channel's value for a hit on ``shape`` at ``p`` (0 where ``valid`` is false)."""
            shape_id = dr.reinterpret_array(mi.UInt32, shape)
            part = dr.gather(mi.Float, self.part_of_shape, shape_id, valid)
            part = dr.select(valid, part, -10.0)
            z = dr.dot(p - self.camera_origin, self.camera_axis)
            out = []
            for code in self.codes:
                v = dr.select(code == part, 1.0, 0.0)
                v = dr.select(code == DEPTH, z, v)
                v = dr.select(code == ALPHA, 1.0, v)
                out.append(dr.select(valid, v, 0.0))
            return out

        def sample(
            self,
            mode: dr.ADMode,
            scene: mi.Scene,
            sampler: mi.Sampler,
            ray: mi.Ray3f,
            depth: mi.UInt32,
            δL,
            state_in,
            active: mi.Bool,
            project: bool = False,
            si_shade=None,
            **kwargs,
        ):
            primal = mode == dr.ADMode.Primal
            if si_shade is not None:
                si = si_shade
            else:
                with dr.resume_grad(when=not primal):
                    si = scene.ray_intersect(ray, ray_flags=mi.RayFlags.All, coherent=True, active=active)
            valid = active & si.is_valid()
            with dr.resume_grad(when=not primal):
                values = self._values(si.shape, si.p, valid)
            L = mi.Spectrum(values[0], values[1], values[2])
            return L, valid, values[3:], ([] if project else None)

        def sample_radiance_difference(self, scene, ss, curr_depth, sampler, wavelengths, active):
            """Foreground minus background value of every channel across the silhouette point (a list)."""
            if curr_depth != 0:
                raise RuntimeError(f"{NAME}: only primarily visible silhouettes are sampled (got depth {curr_depth})")
            # Background: continue the camera ray just past the silhouette edge.
            ray_bg = ss.spawn_ray(wavelengths)
            si_bg = scene.ray_intersect(ray_bg, ray_flags=mi.RayFlags.All, coherent=False, active=active)
            background = self._values(si_bg.shape, si_bg.p, active & si_bg.is_valid())
            # Foreground: the silhouette point itself, on ss.shape.
            foreground = self._values(ss.shape, ss.p, active)
            diff = [f - b for f, b in zip(foreground, background)]
            nonzero = mi.Bool(False)
            for d in diff:
                nonzero |= d != 0
            return diff, active & nonzero

        def render_primarily_visible_silhouette(self, scene, sensor, sampler, spp):
            """As :class:`PSIntegrator`'s, but for any number of channels and with another visibility test.

            Upstream tests visibility with a ray whose origin is pushed *outwards* across the silhouette
            edge. Where two separate meshes meet at a concave crease (a room's wall and floor quads), that
            origin lies behind the neighbouring quad, every crease sample is declared occluded, and the
            mask gradient of moving walls is lost. Here the test ray starts on the edge itself, a small
            relative distance towards the camera. Summed over both quads' edges, the crease terms give
            (value_A − value_B) × motion, the jump of the mask across the crease; depth and alpha, which are
            continuous there, cancel.
            """
            film = sensor.film()
            with dr.suspend_grad():
                camera = sensor.world_transform() @ mi.Point3f(0)
                ss = self.proj_detail.sample_primarily_visible_silhouette(scene, camera, sampler.next_2d(), True)
                active = ss.is_valid() & (ss.pdf > 0)
                J = self.proj_detail.sensor_jacobian(sensor, ss)

                to_camera = camera - ss.p
                dist = dr.norm(to_camera)
                ray = mi.Ray3f(ss.p, to_camera / dist)
                ray.o = dr.fma(ray.d, dist * 1e-4, ray.o)
                ray.maxt = dist * (1.0 - 2e-4)
                visible = active & ~scene.ray_test(ray, active)
                it = dr.zeros(mi.Interaction3f)
                it.p = ss.p
                ds, _ = sensor.sample_direction(it, mi.Point2f(0), visible)
                visible &= ds.pdf != 0
                wavelengths, _ = sensor.sample_wavelengths(dr.zeros(mi.SurfaceInteraction3f), 0, visible)
                diff, active = self.sample_radiance_difference(scene, ss, 0, sampler, wavelengths, visible)

            si = dr.zeros(mi.SurfaceInteraction3f)
            si.p = ss.p
            si.prim_index = ss.prim_index
            si.uv = ss.uv
            motion = dr.dot(ss.shape.differential_motion(dr.detach(si), active), ss.n)
            scale = motion * dr.rcp(ss.pdf) * J * dr.rcp(mi.ScalarFloat(spp))

            film.prepare(self.aov_names())
            block = film.create_block(normalize=True)
            block.set_coalesce(block.coalesce() and spp >= 4)
            values = [d * scale for d in diff]
            # Raw channel layout of an RGB film without alpha: R, G, B, weight, AOVs...
            block.put(ds.uv, values[:3] + [mi.Float(0.0)] + values[3:], active)
            film.put_block(block)
            return film.develop()

        def sample_importance(self, *args, **kwargs):  # indirect silhouettes: never used (sppi = 0)
            raise RuntimeError(f"{NAME}: indirect silhouettes are not sampled")

        def to_string(self) -> str:
            return f"GeometryIntegrator[{NAME}]"

    return GeometryIntegrator


_classes: dict[str, type] = {}


def register() -> None:
    """Register ``psdr_geometry`` for the current variant (once per variant)."""
    variant = mi.variant()
    if variant is None:
        raise RuntimeError("set a Mitsuba variant before registering psdr_geometry")
    if variant not in _classes:
        cls = _make_class()
        mi.register_integrator(NAME, lambda props: cls(props))
        _classes[variant] = cls
