"""The settings of ``renderer=mitsuba`` (``conf/renderer/mitsuba.yaml``), importable without Mitsuba or torch."""

from __future__ import annotations

from dataclasses import dataclass

from psdr_room_core.engine.settings import setting
from psdr_room_core.libraries.llvm import VARIANTS

GUIDING = ("none", "grid", "octree")
"""How ``rgb_sppi`` samples find indirect silhouettes."""


@dataclass
class MitsubaSettings:
    """``renderer=mitsuba``: Mitsuba 3 + Dr.Jit; projective sampling (boundary terms) for masks and depth, path
    tracing for RGB."""

    variant: str = setting(
        choices=VARIANTS,
        doc="auto (cuda_ad_rgb where a CUDA device works, else llvm_ad_rgb), llvm_ad_rgb, cuda_ad_rgb or scalar_rgb "
        "(RGB forward renders only, no gradients).",
    )
    spp: int = setting(ge=1, doc="Samples per pixel of mask and depth renders (primal and interior derivative).")
    spp_boundary: int = setting(
        ge=1, doc="Samples per pixel on silhouettes: the primarily visible boundary derivative."
    )
    rgb_spp: int = setting(ge=1, doc="Samples per pixel of RGB renders.")
    max_depth: int = setting(ge=1, doc="Path length of RGB renders (2: direct light only, 3: one indirect bounce).")
    rgb_sppi: int = setting(
        ge=0,
        doc="Samples per pixel for indirect visibility (moving shadows) in RGB renders with moving geometry; 0 drops "
        "those gradients and is 10-100x faster (RENDERING-NOTES.md).",
    )
    rgb_guiding: str = setting(
        choices=GUIDING,
        doc="How rgb_sppi samples find indirect silhouettes: none (uniform, cheap to set up), grid or octree "
        "(Mitsuba's guiding structures, rebuilt every iteration: seconds).",
    )
    rgb_geometry_gradients: bool = setting(
        doc="Allow vertex gradients through RGB renders (prb_projective), knowing they are biased for flat-shaded "
        "meshes: refused unless true."
    )
    seed: int = setting(doc="Base seed; each render's seed derives from it and the iteration number.")
    threads: int = setting(ge=0, doc="Dr.Jit worker threads (0: the run's run.threads).")
    freeze: bool = setting(
        doc="Replay each render's recorded kernels (dr.freeze) instead of tracing the integrator in Python every "
        "iteration: the same images and gradients, several times less overhead (path-traced RGB)."
    )
    reproducible: bool = setting(
        doc="Gradient passes on one Dr.Jit thread (CPU): their scatter-adds sum in one order, so a fit gives the same "
        "bits (and cache keys) on every run and machine; false: every thread, faster. CUDA's atomics are never in "
        "a fixed order."
    )
