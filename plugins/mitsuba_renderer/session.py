"""The ``renderer=mitsuba`` implementation: scenes for masks/depth and RGB, differentiable through torch.

:class:`MitsubaRenderer` is the capability object (cheap to construct; Mitsuba and Dr.Jit are imported on
first use). :meth:`MitsubaRenderer.geometry` builds a :class:`MitsubaGeometryRenderer` for one camera and a
set of named meshes, whose :meth:`~MitsubaGeometryRenderer.render` returns per-part coverage, z-depth and
alpha, and :meth:`~MitsubaGeometryRenderer.render_rgb` a path-traced image, both as torch tensors
differentiable with respect to the vertex tensors (and, for RGB, every shape's principled-BSDF parameters:
base colour and roughness, constant or UV-mapped, specular; and emitter radiance).

Torch ↔ Dr.Jit: a ``torch.autograd.Function`` copies the inputs into the Mitsuba scene, renders the primal
image with the iteration's seed and, in ``backward``, sets the *same* inputs again with gradients enabled
and calls the integrators' ``render_backward`` with the image gradients. Re-setting the inputs in backward
makes the gradient right even when other renders (of other vertex positions) happened in between, which
``mi.render`` + ``dr.wrap`` would not be (its backward reads whatever the scene holds then). The path tracer's
passes are frozen (``dr.freeze``, renderer setting ``freeze``): recorded on first use and replayed after, which
halves a ``fit_appearance`` iteration; the inputs are copied into Dr.Jit's own memory for it.
"""

from __future__ import annotations

import contextlib
import gc
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from psdr_room_core.engine import threads as run_threads
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.libraries.llvm import resolve_variant
from psdr_room_core.method.artifacts import Camera
from psdr_room_core.method.geometry import TriangleMesh
from psdr_room_core.method.rgb_scene import GUIDE_SPP
from psdr_room_core.method.shading import Surface

if TYPE_CHECKING:
    import torch

GUIDES = {"type": "aov", "aovs": "albedo:albedo,normal:sh_normal"}
"""Mitsuba's ``aov`` integrator giving a denoiser's guides: albedo (channels 0-2) and shading normal (3-5)."""

CV_TO_MITSUBA = np.diag([-1.0, -1.0, 1.0, 1.0])
"""OpenCV camera axes (x right, y down, z forward) → Mitsuba's (x left, y up, z forward)."""


@dataclass(frozen=True)
class _Shape:
    name: str
    vertices: np.ndarray
    """Welded vertices (float32, N'×3) as first set in the scene."""
    faces: np.ndarray
    """Faces into the welded vertices (uint32, M×3)."""
    first: np.ndarray
    """For each welded vertex, the index of the caller's vertex it is taken from (N' indices into N)."""
    n_input: int
    """Vertex count of the caller's mesh (the row count its vertex tensors must have)."""
    uv: np.ndarray | None = None
    """Texture coordinates of the welded vertices (float32, N'×2), for shapes with maps."""


def weld_map(
    mesh: TriangleMesh, tolerance: float = 1e-6, uv: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(first, faces): indices of the vertices kept when welding ``mesh`` (the first of each group of
    coincident vertices, as :func:`psdr_room_core.method.geometry.weld`; with ``uv``, of coincident position and
    texture coordinates), and the faces renumbered onto them with degenerate ones dropped. Split vertices
    would double boundary gradients (``RENDERING-NOTES.md``)."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    extent = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    keys = np.round(vertices / (tolerance * (extent or 1.0))).astype(np.int64)
    if uv is not None:
        keys = np.concatenate([keys, np.round(np.asarray(uv, np.float64) / tolerance).astype(np.int64)], axis=1)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    welded = inverse.reshape(-1)[faces]
    keep = (welded[:, 0] != welded[:, 1]) & (welded[:, 1] != welded[:, 2]) & (welded[:, 0] != welded[:, 2])
    return first, welded[keep]


def _rgb(value: Any, what: str) -> tuple[float, float, float]:
    arr = np.asarray(value.detach().cpu() if hasattr(value, "detach") else value, dtype=np.float64).reshape(-1)
    if arr.size == 1:
        arr = np.repeat(arr, 3)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise PsdrRoomError(f"{what}: expected an RGB triple of finite numbers, got {value!r}")
    return float(arr[0]), float(arr[1]), float(arr[2])


class MitsubaRenderer:
    """Mitsuba 3 differentiable renderer (projective sampling for geometry, path tracing for RGB)."""

    def __init__(
        self,
        variant: str = "auto",
        spp: int = 4,
        spp_boundary: int = 16,
        rgb_spp: int = 16,
        max_depth: int = 3,
        rgb_sppi: int = 0,
        rgb_guiding: str = "none",
        rgb_geometry_gradients: bool = False,
        seed: int = 0,
        threads: int = 0,
        freeze: bool = True,
        reproducible: bool = True,
    ) -> None:
        """The settings are :class:`~.settings.MitsubaSettings`'s (``renderer.mitsuba.*``), checked against it."""
        self.requested_variant = str(variant)
        self.spp = int(spp)
        self.spp_boundary = int(spp_boundary)
        self.rgb_spp = int(rgb_spp)
        self.max_depth = int(max_depth)
        self.rgb_sppi = int(rgb_sppi)
        self.rgb_guiding = str(rgb_guiding)
        self.rgb_geometry_gradients = bool(rgb_geometry_gradients)
        self.seed = int(seed)
        self.threads = int(threads)
        self.freeze = bool(freeze)
        self.reproducible = bool(reproducible)
        self._variant: str | None = None

    # ---------------------------------------------------------------------------------------- set-up
    @property
    def variant(self) -> str:
        """The Mitsuba variant in use (resolved on first access)."""
        if self._variant is None:
            self._variant = resolve_variant(self.requested_variant)
        return self._variant

    def activate(self) -> Any:
        """Select this renderer's variant (Mitsuba's variant is process-global), register the integrator,
        and return the ``mitsuba`` module."""
        variant = self.variant
        import drjit as dr
        import mitsuba as mi

        if mi.variant() != variant:
            mi.set_variant(variant)
        # Furniture meshes are rarely manifold (parts meet at shared vertices); Mitsuba warns about each one
        # when it builds silhouette edges, which is expected here and would drown the run's own log.
        mi.set_log_level(mi.LogLevel.Error)
        if variant != "scalar_rgb":
            from . import integrator

            integrator.register()
        wanted = self.threads or run_threads.count()
        if dr.thread_count() != wanted:
            dr.set_thread_count(wanted)
        return mi

    @property
    def device(self) -> str:
        """torch device of the returned tensors."""
        return "cuda" if self.variant.startswith("cuda") else "cpu"

    def render_file(self, xml: Path, spp: int, **size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A Mitsuba scene file (an exported ``scene.xml``) rendered at ``spp`` (``size``: ``width`` /
        ``height`` overriding its own): linear RGB, and the albedo and normal a denoiser is guided by,
        float32 [H, W, 3] each."""
        mi = self.activate()
        scene = mi.load_file(str(xml), spp=spp, **size)
        rgb = np.array(mi.render(scene, spp=spp), dtype=np.float32)
        aux = np.array(mi.render(scene, integrator=mi.load_dict(GUIDES), spp=GUIDE_SPP), dtype=np.float32)
        return rgb, aux[..., :3], aux[..., 3:6]

    def geometry(
        self,
        camera: Camera,
        camera_to_world: np.ndarray,
        meshes: Mapping[str, TriangleMesh],
        parts: Mapping[str, int],
        resolution_scale: float = 1.0,
        surfaces: Mapping[str, Surface] | None = None,
        emitters: Mapping[str, tuple[TriangleMesh, Any]] | None = None,
    ) -> MitsubaGeometryRenderer:
        """A renderer of ``meshes`` (name → world-space mesh) seen by ``camera`` at ``camera_to_world``
        (4×4, OpenCV camera axes), at ``resolution_scale`` × the camera's resolution.

        ``parts`` maps shape names to part indices 0..P-1 (several shapes may share one; a shape without an
        entry occludes but belongs to no mask). ``surfaces`` (shape → :class:`~psdr_room_core.method.shading.Surface`,
        default grey) and ``emitters`` (name → (mesh, RGB radiance); emitting on the side its triangles face
        counter-clockwise) are used only by :meth:`MitsubaGeometryRenderer.render_rgb`.
        """
        return MitsubaGeometryRenderer(
            self, camera, camera_to_world, meshes, parts, resolution_scale, surfaces or {}, emitters or {}
        )


class MitsubaGeometryRenderer:
    """One camera, named welded meshes: per-part masks, z-depth and alpha; RGB on demand."""

    def __init__(
        self,
        renderer: MitsubaRenderer,
        camera: Camera,
        camera_to_world: np.ndarray,
        meshes: Mapping[str, TriangleMesh],
        parts: Mapping[str, int],
        resolution_scale: float,
        surfaces: Mapping[str, Surface],
        emitters: Mapping[str, tuple[TriangleMesh, Any]],
    ) -> None:
        self.renderer = renderer
        if not meshes:
            raise PsdrRoomError("renderer.geometry: no meshes given; pass at least one named mesh")
        unknown = sorted(set(parts) - set(meshes))
        if unknown:
            raise PsdrRoomError(f"renderer.geometry: parts name shapes that are not in meshes: {', '.join(unknown)}")
        values = sorted(set(int(p) for p in parts.values()))
        if values and (values[0] < 0):
            raise PsdrRoomError(f"renderer.geometry: part indices must be >= 0, got {values[0]}")
        self.n_parts = (values[-1] + 1) if values else 0
        self.parts = {name: int(parts[name]) if name in parts else -1 for name in meshes}
        for name, surface in surfaces.items():
            if name not in meshes:
                raise PsdrRoomError(f"renderer.geometry: surface given for '{name}', which is not a mesh")
            if surface.mapped and (surface.uv is None or np.shape(surface.uv) != (len(meshes[name].vertices), 2)):
                raise PsdrRoomError(
                    f"renderer.geometry: surface of '{name}' has maps but no N×2 uv for its "
                    f"{len(meshes[name].vertices)} vertices"
                )
        clash = sorted(set(emitters) & set(meshes))
        if clash:
            raise PsdrRoomError(f"renderer.geometry: emitter names clash with mesh names: {', '.join(clash)}")
        reserved = sorted((set(meshes) | set(emitters)) & {"type", "sensor", "integrator"})
        if reserved:
            raise PsdrRoomError(f"renderer.geometry: shape name(s) {', '.join(reserved)} are reserved; rename them")

        # Camera at the working resolution.
        scale = float(resolution_scale)
        if not (scale > 0 and math.isfinite(scale)):
            raise PsdrRoomError(f"renderer.geometry: resolution_scale={resolution_scale!r} must be > 0")
        if abs(camera.fx / camera.fy - 1.0) > 1e-3:
            raise PsdrRoomError(
                f"renderer=mitsuba needs square pixels, but the camera has fx={camera.fx:.6g}, fy={camera.fy:.6g}; "
                "resample the image to square pixels"
            )
        self.width = max(1, int(round(camera.width * scale)))
        self.height = max(1, int(round(camera.height * scale)))
        self.camera = camera
        c2w = np.asarray(camera_to_world, dtype=np.float64)
        if c2w.shape != (4, 4) or not np.all(np.isfinite(c2w)):
            raise PsdrRoomError(f"renderer.geometry: camera_to_world must be a finite 4x4 matrix, got {c2w.shape}")
        self.camera_to_world = c2w
        self.camera_origin = tuple(float(x) for x in c2w[:3, 3])
        axis = c2w[:3, 2] / np.linalg.norm(c2w[:3, 2])
        self.camera_axis = tuple(float(x) for x in axis)

        # Welded shapes (index maps kept so the caller's vertex tensors can be used as they are).
        self.surfaces = {name: surfaces.get(name, Surface()) for name in meshes}
        self.shapes: dict[str, _Shape] = {}
        for name, mesh in meshes.items():
            vertices = np.asarray(mesh.vertices, dtype=np.float64)
            if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.all(np.isfinite(vertices)):
                raise PsdrRoomError(f"renderer.geometry: mesh '{name}' needs finite N×3 vertices")
            uv = self.surfaces[name].uv if self.surfaces[name].mapped else None
            first, faces = weld_map(mesh, uv=uv)
            if len(faces) == 0:
                raise PsdrRoomError(f"renderer.geometry: mesh '{name}' has no non-degenerate triangle")
            self.shapes[name] = _Shape(
                name,
                vertices[first].astype(np.float32),
                faces.astype(np.uint32),
                first.astype(np.int64),
                len(vertices),
                None if uv is None else np.asarray(uv, np.float32)[first],
            )
        self.emitters = {}
        for name, (mesh, radiance) in emitters.items():
            first, faces = weld_map(mesh)
            self.emitters[name] = (
                _Shape(
                    name,
                    np.asarray(mesh.vertices, np.float32)[first],
                    faces.astype(np.uint32),
                    first,
                    len(mesh.vertices),
                ),
                _rgb(radiance, f"radiance of '{name}'"),
            )

        # Channels of the geometry render: P part masks, then depth and alpha (one pass: RGB + AOVs).
        self._channels: list[float | str] = [float(p) for p in range(self.n_parts)] + ["depth", "alpha"]
        self._geometry: _MitsubaScene | None = None
        self._rgb: _MitsubaScene | None = None

    # -------------------------------------------------------------------------------------- helpers
    @property
    def device(self) -> str:
        return self.renderer.device

    def _seed(self, iteration: int) -> int:
        """A 31-bit seed for (base seed, iteration); the gradient pass uses a decorrelated one."""
        return int((self.renderer.seed * 0x9E3779B1 + int(iteration) * 2 + 1) & 0x7FFFFFFF)

    def _inputs(self, vertices: Mapping[str, torch.Tensor] | None) -> list[tuple[str, torch.Tensor]]:
        import torch

        out = []
        for name, tensor in (vertices or {}).items():
            if name not in self.shapes:
                known = ", ".join(self.shapes)
                raise PsdrRoomError(f"renderer.render: unknown shape '{name}' in vertices; known: {known}")
            shape = self.shapes[name]
            if not isinstance(tensor, torch.Tensor) or tuple(tensor.shape) != (shape.n_input, 3):
                got = tuple(tensor.shape) if hasattr(tensor, "shape") else type(tensor).__name__
                raise PsdrRoomError(
                    f"renderer.render: vertices['{name}'] must be a torch tensor of shape ({shape.n_input}, 3), got {got}"
                )
            welded = tensor[torch.as_tensor(shape.first, device=tensor.device)]
            out.append((f"{name}.vertex_positions", welded))
        return out

    def _geometry_scene(self) -> _MitsubaScene:
        if self._geometry is None:
            if self.renderer.variant == "scalar_rgb":
                raise PsdrRoomError(
                    "renderer.mitsuba.variant=scalar_rgb renders RGB only, without gradients; use variant=auto or "
                    "llvm_ad_rgb for masks and depth"
                )
            self._geometry = _MitsubaScene.build(self, rgb=False)
        return self._geometry

    def _rgb_scene(self) -> _MitsubaScene:
        if self._rgb is None:
            self._rgb = _MitsubaScene.build(self, rgb=True)
        return self._rgb

    # ---------------------------------------------------------------------------------------- renders
    def render(
        self, vertices: Mapping[str, torch.Tensor] | None = None, iteration: int = 0
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(masks [P,H,W], depth [H,W], alpha [H,W]) as float32 torch tensors.

        ``vertices`` maps shape names to N×3 world positions (the mesh's vertex order) replacing the
        meshes' own; shapes left out keep the positions last given to this method (initially the meshes'). Masks are anti-aliased coverage in
        [0, 1] of each part; depth is the coverage-weighted z-depth along the optical axis (0 where nothing
        is hit: divide by alpha for the depth of covered pixels); alpha is the coverage of any shape.
        Gradients flow to every vertex tensor that requires grad, through visibility (silhouettes, sampled
        with ``spp_boundary`` per pixel) and through depth (interior). The seed depends on ``iteration``.
        ``backward`` re-renders the derivative with the vertices of this call (other renders may come in
        between), but shapes *not* passed here are taken where they are at ``backward`` time.
        """
        import torch

        scene = self._geometry_scene()
        inputs = self._inputs(vertices)
        keys = [k for k, _ in inputs]
        images = _RenderFunction.apply(scene, keys, self._seed(iteration), (0, 0), *[t for _, t in inputs])
        flat = torch.cat([img.permute(2, 0, 1) for img in images], dim=0)  # [P + 2 (or 3), H, W]
        p = self.n_parts
        return flat[:p], flat[p], flat[p + 1]

    def render_rgb(
        self,
        vertices: Mapping[str, torch.Tensor] | None = None,
        base_color: Mapping[str, torch.Tensor] | None = None,
        roughness: Mapping[str, torch.Tensor] | None = None,
        specular: Mapping[str, torch.Tensor] | None = None,
        radiance: Mapping[str, torch.Tensor] | None = None,
        iteration: int = 0,
        spp: int = 0,
        grad_spp: int = 0,
    ) -> torch.Tensor:
        """Path-traced linear RGB [H,W,3] (``max_depth``; ``spp`` samples per pixel, default ``rgb_spp``; its
        gradient pass ``grad_spp``, default the same) with the shapes' surfaces and the emitters given to
        :meth:`MitsubaRenderer.geometry`.

        ``base_color`` (shape → linear RGB [3], or [H, W, 3] for a mapped one), ``roughness`` ([1] or
        [H, W, 1]), ``specular`` ([1]) and ``radiance`` (emitter → RGB [3]) override the values given at
        construction, differentiably (``prb``: exact for fixed geometry). ``vertices`` move the shapes;
        their gradients are refused unless ``rgb_geometry_gradients`` is set, because Mitsuba 3.9.1's
        ``prb_projective`` gets them wrong for flat-shaded (position-only) meshes: it samples silhouettes
        only, not the shading jump at a box's creases, and drops moving shadows unless ``rgb_sppi`` > 0
        (measured 0.2-0.45x of central finite differences on a lit box). Fit geometry with :meth:`render`'s
        masks and depth, as the paper does.
        """
        import torch

        scene = self._rgb_scene()
        inputs = self._inputs(vertices) + self._surface_inputs(scene, base_color, roughness, specular, radiance)
        if self.renderer.variant == "scalar_rgb" and any(t.requires_grad for _, t in inputs):
            raise PsdrRoomError(
                "renderer.mitsuba.variant=scalar_rgb has no gradients; use variant=auto or llvm_ad_rgb, or pass "
                "tensors that do not require grad"
            )
        moving = any(t.requires_grad for k, t in inputs if k.endswith(".vertex_positions"))
        if moving and not self.renderer.rgb_geometry_gradients:
            raise PsdrRoomError(
                "renderer.render_rgb: vertex gradients through RGB renders are biased for flat-shaded meshes "
                "(creases and shadows are not sampled); fit geometry with render() masks/depth, pass detached "
                "vertices, or set renderer.mitsuba.rgb_geometry_gradients=true to accept the bias"
            )
        keys = [k for k, _ in inputs]
        (image,) = _RenderFunction.apply(
            scene.with_mode("projective" if moving else "plain"),
            keys,
            self._seed(iteration),
            (int(spp), int(grad_spp or spp)),
            *[t for _, t in inputs],
        )
        return image if image.dtype == torch.float32 else image.float()

    def render_guides(
        self,
        base_color: Mapping[str, torch.Tensor] | None = None,
        roughness: Mapping[str, torch.Tensor] | None = None,
        specular: Mapping[str, torch.Tensor] | None = None,
        radiance: Mapping[str, torch.Tensor] | None = None,
        spp: int = 16,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Albedo (the principled BSDF's base colour; black on emitters) and shading normal (world space) of
        the RGB scene with the surfaces :meth:`render_rgb` would get from the same arguments, float32
        [H,W,3] each, ``spp`` samples per pixel of Mitsuba's ``aov`` integrator: a denoiser's guides."""
        scene = self._rgb_scene()
        mi = self.renderer.activate()
        inputs = self._surface_inputs(scene, base_color, roughness, specular, radiance)
        scene.set_inputs([k for k, _ in inputs], [t.detach().to("cpu").float().numpy() for _, t in inputs])
        if scene.guides is None:
            scene.guides = mi.load_dict(GUIDES)
        image = np.array(
            scene.guides.render(scene.scene, sensor=0, seed=_opaque_seed(0), spp=int(spp)), dtype=np.float32
        )
        return image[..., :3], image[..., 3:6]

    def _surface_inputs(
        self,
        scene: _MitsubaScene,
        base_color: Mapping[str, Any] | None,
        roughness: Mapping[str, Any] | None,
        specular: Mapping[str, Any] | None,
        radiance: Mapping[str, Any] | None,
    ) -> list[tuple[str, torch.Tensor]]:
        """(parameter key, tensor) of every surface and emitter value given, checked against the scene."""
        inputs = []
        for channel, values in (("base_color", base_color), ("roughness", roughness), ("specular", specular)):
            for name, value in (values or {}).items():
                if name not in self.shapes:
                    raise PsdrRoomError(f"renderer.render_rgb: {channel} for unknown shape '{name}'")
                key = scene.surface_keys[name][channel]
                inputs.append((key, _as_input(value, scene.params[key], f"{channel}['{name}']")))
        for name, value in (radiance or {}).items():
            if name not in self.emitters:
                raise PsdrRoomError(f"renderer.render_rgb: radiance for unknown emitter '{name}'")
            key = scene.radiance_keys[name]
            inputs.append((key, _as_input(value, scene.params[key], f"radiance['{name}']")))
        return inputs


def _as_input(value: Any, current: Any, what: str) -> torch.Tensor:
    """``value`` as a float tensor shaped like the scene parameter it replaces (a colour [3], a number [1],
    or a map [H, W, C] of the size given at construction)."""
    import torch

    tensor = value if isinstance(value, torch.Tensor) else torch.as_tensor(np.asarray(value, np.float32))
    expected = tuple(current.shape) if hasattr(current, "ndim") and current.ndim == 3 else None
    if expected is not None:
        if tuple(tensor.shape) != expected:
            raise PsdrRoomError(
                f"renderer.render_rgb: {what} must be a map of shape {expected}, got {tuple(tensor.shape)}"
            )
        return tensor
    size = 3 if "Color" in type(current).__name__ else 1
    if tensor.numel() == 1 and size == 3:
        tensor = tensor.reshape(1).expand(3)
    if tensor.numel() != size:
        raise PsdrRoomError(f"renderer.render_rgb: {what} must have {size} value(s), got shape {tuple(tensor.shape)}")
    return tensor.reshape(size)


class _MitsubaScene:
    """A loaded Mitsuba scene, its parameters and the integrator pass(es) that render it."""

    def __init__(
        self,
        owner: MitsubaGeometryRenderer,
        mi: Any,
        scene: Any,
        passes: list[Any],
        projective: list[Any] | None = None,
    ) -> None:
        self.owner = owner
        self.mi = mi
        self.scene = scene
        self.params = mi.traverse(scene)
        self.passes = passes
        self._plain = passes
        self._projective = projective or passes
        self.surface_keys: dict[str, dict[str, str]] = {}
        self.radiance_keys: dict[str, str] = {}
        self.guides: Any = None  # the aov integrator of render_guides, made on first use
        self._frozen: dict[tuple[str, int], Any] = {}

    def with_mode(self, mode: str) -> _MitsubaScene:
        self.passes = self._projective if mode == "projective" else self._plain
        return self

    @classmethod
    def build(cls, owner: MitsubaGeometryRenderer, rgb: bool) -> _MitsubaScene:
        r = owner.renderer
        mi = r.activate()
        cam = owner.camera
        to_world = owner.camera_to_world @ CV_TO_MITSUBA
        spp = r.rgb_spp if rgb else r.spp
        sensor = {
            "type": "perspective",
            "fov_axis": "y",
            "fov": cam.vfov_deg,
            "principal_point_offset_x": (cam.width / 2.0 - cam.cx) / cam.width,
            "principal_point_offset_y": (cam.height / 2.0 - cam.cy) / cam.height,
            "near_clip": 1e-3,
            "far_clip": 1e4,
            "to_world": mi.ScalarTransform4f(to_world.tolist()),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {
                "type": "hdrfilm",
                "width": owner.width,
                "height": owner.height,
                "pixel_format": "rgb",
                "rfilter": {"type": "box"},
                "sample_border": True,
            },
        }
        desc: dict[str, Any] = {"type": "scene", "sensor": sensor}
        for name, shape in owner.shapes.items():
            bsdf = _principled(mi, owner.surfaces[name]) if rgb else _diffuse(mi, (0.5, 0.5, 0.5))
            desc[name] = _mesh(mi, name, shape, bsdf=bsdf)
        if rgb:
            for name, (shape, radiance) in owner.emitters.items():
                emitter = mi.load_dict({"type": "area", "radiance": {"type": "rgb", "value": list(radiance)}})
                desc[name] = _mesh(mi, name, shape, bsdf=_diffuse(mi, (0.0, 0.0, 0.0)), emitter=emitter)
        try:
            scene = mi.load_dict(desc, optimize=False)  # keep shapes apart: their parameter keys must persist
        except Exception as exc:
            raise PsdrRoomError(f"renderer=mitsuba could not build the scene: {type(exc).__name__}: {exc}") from None

        if rgb:
            if r.variant == "scalar_rgb":  # no AD: Mitsuba's C++ path tracer
                out = cls(owner, mi, scene, [mi.load_dict({"type": "path", "max_depth": r.max_depth})])
            else:
                plain = [mi.load_dict({"type": "prb", "max_depth": r.max_depth})]
                projective = [
                    mi.load_dict(
                        {
                            "type": "prb_projective",
                            "max_depth": r.max_depth,
                            "sppc": r.rgb_spp,
                            "sppp": r.spp_boundary,
                            "sppi": r.rgb_sppi,
                            "guiding": r.rgb_guiding,
                        }
                    )
                ]
                out = cls(owner, mi, scene, plain, projective)
            for name in owner.shapes:
                out.surface_keys[name] = {
                    "base_color": _find_key(out.params, name + ".bsdf.", ("base_color.value", "base_color.data")),
                    "roughness": _find_key(out.params, name + ".bsdf.", ("roughness.value", "roughness.data")),
                    "specular": _find_key(out.params, name + ".bsdf.", (".specular",)),
                }
            for name in owner.emitters:
                out.radiance_keys[name] = _find_key(out.params, name + ".emitter.", ("radiance.value",))
        else:
            import drjit as dr

            from .integrator import ALPHA, DEPTH, NAME

            ids = {s.id(): int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))[0]) for s in scene.shapes()}
            table = [-1.0] * (max(ids.values()) + 1)
            for name, part in owner.parts.items():
                table[ids[name]] = float(part)
            codes = [c if isinstance(c, float) else (DEPTH if c == "depth" else ALPHA) for c in owner._channels]
            integrator = mi.load_dict({"type": NAME, "sppc": r.spp, "sppp": r.spp_boundary, "sppi": 0})
            integrator.configure(table, codes, owner.camera_origin, owner.camera_axis)
            out = cls(owner, mi, scene, [integrator])
        return out

    # ------------------------------------------------------------------------------- torch bridge
    def set_inputs(self, keys: Sequence[str], arrays: Sequence[np.ndarray], attach: Sequence[bool] = ()) -> list[Any]:
        """Write float32 arrays into the scene parameters, each converted to the parameter's own type
        (with gradients enabled where ``attach``); returns the Dr.Jit variables written."""
        mi = self.mi
        import drjit as dr

        written = []
        attach = list(attach) or [False] * len(keys)
        scalar = mi.variant().startswith("scalar")
        for key, array, grad in zip(keys, arrays, attach):
            current = self.params[key]
            flat = np.ascontiguousarray(array, dtype=np.float32).reshape(-1)
            if isinstance(current, mi.TensorXf):  # a map
                value = mi.TensorXf(_owned(mi, flat), current.shape)
            elif "Color" in type(current).__name__:
                value = mi.Color3f(*(float(x) if scalar else _opaque(mi.Float, x) for x in flat))
            elif key.endswith(".vertex_positions"):
                value = _owned(mi, flat)
            else:  # a number (a Float of one entry)
                value = float(flat[0]) if scalar else _opaque(mi.Float, flat[0])
            if grad:
                dr.enable_grad(value)
            self.params[key] = value
            written.append(value)
        self.params.update()
        return written

    def render_pass(self, integrator: Any, seed: int, spp: int) -> Any:
        """``integrator``'s primal image of the scene with the parameters it now holds (``spp`` 0: the
        integrator's own count)."""
        render = self._pass(
            "render", integrator, lambda scene, seed, spp: integrator.render(scene, sensor=0, seed=seed, spp=spp)
        )
        return render(self.scene, _opaque_seed(seed), int(spp))

    def backward_pass(self, integrator: Any, grad_in: Any, seed: int, spp: int) -> None:
        """``integrator.render_backward`` of the image gradient ``grad_in``: accumulates into the gradients of
        the parameters :meth:`set_inputs` attached (read them after this returns: a frozen pass hands them
        back to the caller's variables at its end)."""

        def backward(scene: Any, grad_in: Any, seed: Any, spp: int) -> None:
            integrator.render_backward(scene, self.params, grad_in, sensor=0, seed=seed, spp=spp)

        self._pass("backward", integrator, backward)(self.scene, grad_in, _opaque_seed(seed), int(spp))

    def _pass(self, kind: str, integrator: Any, fn: Any) -> Any:
        """``fn``, frozen (``dr.freeze``) when the renderer's ``freeze`` is on and ``integrator`` is a path
        tracer (``prb``): traced on its first call and on any call whose inputs differ in structure (another
        ``spp``, other parameters attached), replayed otherwise. Projective integrators (masks and depth,
        moving geometry) are traced every time: Mitsuba 3.9 refuses to record their gradient pass, and
        their primal pass re-records whenever the vertices move."""
        if not self.owner.renderer.freeze or self.mi.variant().startswith("scalar"):
            return fn
        import drjit as dr

        from .integrator import projective_base

        if isinstance(integrator, projective_base()):
            return fn
        key = (kind, id(integrator))
        if key not in self._frozen:
            frozen = dr.freeze(fn)

            def call(*args: Any) -> Any:
                # A collection while recording may free a Dr.Jit array that maps NumPy memory (anywhere in the
                # process); its release cannot be recorded and Dr.Jit aborts the process
                enabled = gc.isenabled()
                gc.disable()
                try:
                    return frozen(*args)
                finally:
                    if enabled:
                        gc.enable()

            self._frozen[key] = call
        return self._frozen[key]

    def detach_all(self, keys: Sequence[str]) -> None:
        import drjit as dr

        for key in keys:
            value = self.params[key]
            if dr.grad_enabled(value):
                self.params[key] = dr.detach(value)
        self.params.update()


def _opaque(kind: Any, value: Any) -> Any:
    """A one-entry Dr.Jit array held in memory: a literal (or memory Dr.Jit did not allocate) is baked
    into the kernel, so every new value would compile a new kernel (measured 0.45-0.5 s per backward pass)."""
    import drjit as dr

    return dr.opaque(kind, value)


def _owned(mi: Any, array: np.ndarray) -> Any:
    """A flat Dr.Jit ``Float`` holding a copy of ``array``. Dr.Jit maps NumPy memory instead of copying it,
    and frozen passes replayed on mapped inputs rendered NaN now and then (measured); the sum with an opaque
    zero is a kernel that writes Dr.Jit's own memory."""
    return mi.Float(np.ascontiguousarray(array, dtype=np.float32).reshape(-1)) + _opaque(mi.Float, 0.0)


def _opaque_seed(seed: int) -> Any:
    import mitsuba as mi

    return _opaque(mi.UInt32, seed) if not (mi.variant() or "").startswith("scalar") else seed


@contextlib.contextmanager
def _one_thread(enabled: bool) -> Iterator[None]:
    """Dr.Jit on one worker thread inside (when ``enabled``), so that scatter-adds sum in one order; the
    thread count is restored however the block ends."""
    import drjit as dr

    threads = dr.thread_count()
    if enabled:
        dr.set_thread_count(1)
    try:
        yield
    finally:
        dr.set_thread_count(threads)


def _make_function() -> Any:
    import torch

    class RenderFunction(torch.autograd.Function):
        """Primal render of every pass; backward = ``render_backward`` of every pass on the same inputs."""

        @staticmethod
        def forward(
            ctx: Any, scene: _MitsubaScene, keys: list[str], seed: int, spp: tuple[int, int], *tensors: torch.Tensor
        ):
            arrays = [t.detach().to("cpu", torch.float32).numpy().copy() for t in tensors]
            scene.owner.renderer.activate()
            scene.set_inputs(keys, arrays)
            passes = list(scene.passes)
            outputs = []
            device = tensors[0].device if tensors else torch.device(scene.owner.device)
            for integrator in passes:
                image = scene.render_pass(integrator, seed, spp[0])
                outputs.append(torch.from_numpy(np.array(image, dtype=np.float32)).to(device))
            ctx.scene, ctx.keys, ctx.seed, ctx.arrays, ctx.passes, ctx.spp = scene, keys, seed, arrays, passes, spp
            ctx.shapes = [tuple(t.shape) for t in tensors]
            ctx.types = [(t.dtype, t.device) for t in tensors]
            return tuple(outputs)

        @staticmethod
        def backward(ctx: Any, *grad_outputs: torch.Tensor):
            import drjit as dr

            scene: _MitsubaScene = ctx.scene
            mi = scene.owner.renderer.activate()
            needs = list(ctx.needs_input_grad[4:])
            grads: list[torch.Tensor | None] = [None] * len(ctx.keys)
            if any(needs):
                with _one_thread(scene.owner.renderer.reproducible):
                    values = scene.set_inputs(ctx.keys, ctx.arrays, needs)
                    seed_grad = int(mi.sample_tea_32(ctx.seed, 1)[0]) & 0x7FFFFFFF
                    for integrator, grad in zip(ctx.passes, grad_outputs):
                        if grad is None:
                            continue
                        grad_np = grad.detach().to("cpu", torch.float32).numpy()
                        grad_in = mi.TensorXf(_owned(mi, grad_np), grad_np.shape)
                        scene.backward_pass(integrator, grad_in, seed_grad, ctx.spp[1])
                    flat = {i: dr.ravel(dr.grad(value)) for i, (value, need) in enumerate(zip(values, needs)) if need}
                    dr.eval(*flat.values())  # one kernel for every gradient, not one per parameter
                    for i, g_flat in flat.items():
                        g = np.array(g_flat, dtype=np.float32).reshape(ctx.shapes[i])
                        dtype, device = ctx.types[i]
                        grads[i] = torch.from_numpy(g).to(device=device, dtype=dtype)
                    scene.detach_all(ctx.keys)
            return (None, None, None, None, *grads)

    return RenderFunction


class _LazyFunction:
    _fn: Any = None

    def apply(self, *args: Any) -> Any:
        if self._fn is None:
            type(self)._fn = _make_function()
        return self._fn.apply(*args)


_RenderFunction = _LazyFunction()


def _find_key(params: Any, prefix: str, suffixes: tuple[str, ...]) -> str:
    for key in params.keys():  # noqa: SIM118 (iterating Mitsuba's SceneParameters yields (key, value) pairs)
        if key.startswith(prefix) and key.endswith(suffixes):
            return key
    raise PsdrRoomError(f"renderer=mitsuba: no scene parameter {prefix}*{suffixes[0]} (Mitsuba version mismatch?)")


def _diffuse(mi: Any, rgb: tuple[float, float, float]) -> Any:
    return mi.load_dict(
        {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(rgb)}}}
    )


def _principled(mi: Any, surface: Surface) -> Any:
    """A two-sided principled BSDF for ``surface`` (maps as repeating, bilinear bitmaps of linear values)."""

    def texture(value: Any, channels: int) -> dict[str, Any]:
        array = np.asarray(value, dtype=np.float32)
        if array.ndim == 3:
            return {
                "type": "bitmap",
                "data": mi.TensorXf(np.ascontiguousarray(array)),
                "raw": True,
                "filter_type": "bilinear",
                "wrap_mode": "repeat",
            }
        values = [float(v) for v in np.broadcast_to(array.reshape(-1), (channels,))]
        return {"type": "rgb", "value": values} if channels == 3 else {"type": "uniform", "value": values[0]}

    return mi.load_dict(
        {
            "type": "twosided",
            "bsdf": {
                "type": "principled",
                "base_color": texture(surface.base_color, 3),
                "roughness": texture(surface.roughness, 1),
                "specular": float(surface.specular),
            },
        }
    )


def _mesh(mi: Any, name: str, shape: _Shape, bsdf: Any, emitter: Any = None) -> Any:
    """A Mitsuba mesh with face normals (and texture coordinates when the shape has them) built from arrays."""
    props = mi.Properties()
    props["bsdf"] = bsdf
    if emitter is not None:
        props["emitter"] = emitter
    mesh = mi.Mesh(
        name,
        len(shape.vertices),
        len(shape.faces),
        props=props,
        has_vertex_normals=False,
        has_vertex_texcoords=shape.uv is not None,
    )
    params = mi.traverse(mesh)
    # The parameters' own types: mi.Float / mi.UInt32 in JIT variants, dynamic arrays in scalar ones.
    params["vertex_positions"] = type(params["vertex_positions"])(
        np.ascontiguousarray(shape.vertices, dtype=np.float32).reshape(-1)
    )
    params["faces"] = type(params["faces"])(np.ascontiguousarray(shape.faces, dtype=np.uint32).reshape(-1))
    if shape.uv is not None:
        params["vertex_texcoords"] = type(params["vertex_texcoords"])(
            np.ascontiguousarray(shape.uv, dtype=np.float32).reshape(-1)
        )
    params.update()
    return mesh


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Renderer

    _MitsubaRenderer_is_a_renderer: type[Renderer] = MitsubaRenderer
