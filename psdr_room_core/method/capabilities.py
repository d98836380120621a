"""The method's capabilities: the swappable parts of PSDR-Room, each a protocol that implementations satisfy.

An implementation is selected per capability by the config group of the same name (``fov=fixed``) and
constructed with the parameters under ``<capability>.<name>``. Implementations that read files besides
the stage's input artifacts (sidecar depth, model weights) list them in ``external_files`` so that their
content is part of the cache key.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np
    import torch

    from .artifacts import Camera, Candidate, DepthMap, Detections, Image, ObjectMesh, Panoptic
    from .geometry import TriangleMesh
    from .objects import ObjectQuery
    from .shading import Surface

CAPABILITIES: tuple[str, ...] = (
    "fov",
    "detector",
    "segmentation",
    "depth",
    "retrieval",
    "renderer",
    "material_graph",
    "texture",
    "optimizer",
    "denoiser",
)
"""Every capability, in pipeline order; each has its protocol below (:data:`PROTOCOLS`)."""

DESCRIPTIONS: dict[str, str] = {
    "fov": "camera intrinsics (vertical field of view) from the photo (§4.1)",
    "detector": "object boxes that prompt the segmentation (offline stand-in for §4.1's panoptic objects)",
    "segmentation": "panoptic segmentation with wall/floor/ceiling/object categories (§4.1)",
    "depth": "per-pixel depth (§4.1)",
    "retrieval": "object and material retrieval from a database (§4.3, §4.4)",
    "renderer": "differentiable renderer for masks, depth and RGB (§3.1)",
    "material_graph": "differentiable procedural material node graphs (§3.2, §4.4)",
    "texture": "texture descriptors for crop-to-crop losses (§3.2)",
    "optimizer": "gradient-based optimiser with per-parameter learning rates",
    "denoiser": "removes Monte-Carlo noise from finished renders (pictures and metrics, never a loss)",
}


@runtime_checkable
class FovEstimator(Protocol):
    """``fov``: estimates pinhole intrinsics (square pixels) for the working image."""

    def estimate(self, image: Image, photo: Path) -> Camera: ...


@runtime_checkable
class Detector(Protocol):
    """``detector``: object boxes in the working image, used as prompts by box-driven segmenters."""

    def detect(self, image: Image, photo: Path) -> Detections: ...


@runtime_checkable
class Segmenter(Protocol):
    """``segmentation``: a panoptic segmentation at the working image's resolution.

    ``camera`` carries the vanishing points when ``fov`` found them (``camera.vanishing_points``); ``detections``
    are box prompts (segmenters that find objects themselves may ignore them).
    """

    def segment(self, image: Image, camera: Camera, detections: Detections, photo: Path) -> Panoptic: ...


@runtime_checkable
class DepthEstimator(Protocol):
    """``depth``: z-depth at the working image's resolution (metric or normalised, see ``DepthMap``).

    ``panoptic`` lets geometric estimators use the segmentation (networks ignore it).
    """

    def estimate(self, image: Image, camera: Camera, panoptic: Panoptic, photo: Path) -> DepthMap: ...


@runtime_checkable
class ObjectRetriever(Protocol):
    """``retrieval`` for objects: ranks the models of its object database for a segmented object (§4.3)
    and hands out their meshes (the database is the capability's data side)."""

    def rank(self, query: ObjectQuery, camera: Camera, camera_to_world: np.ndarray, k: int) -> list[Candidate]:
        """The ``k`` best models for ``query`` seen by ``camera`` at ``camera_to_world``, best first."""
        ...

    def mesh(self, model_id: str) -> ObjectMesh:
        """A model's mesh in the canonical frame (see ``artifacts.ObjectMesh``)."""
        ...

    def category(self, model_id: str) -> str:
        """A model's database category (its real sizes: ``method.sizes``)."""
        ...

    def describe(self) -> str:
        """One line naming the method and database (recorded in the candidates artifact)."""
        ...

    def thumbnail(self, model_id: str) -> np.ndarray:
        """A uint8 RGB picture of the model (for reports)."""
        ...


@runtime_checkable
class Optimizer(Protocol):
    """``optimizer``: gradient descent over named torch tensors with per-tensor learning rates."""

    def minimize(
        self,
        params: dict[str, torch.Tensor],
        learning_rates: dict[str, float],
        loss: Callable[[int], tuple[torch.Tensor, dict[str, float]]],
        iterations: int,
        progress: Callable[[Iterable[int]], Iterable[int]] = iter,
        stop: Callable[[list[dict[str, float]]], bool] | None = None,
    ) -> list[dict[str, float]]:
        """Minimise ``loss(iteration) -> (scalar tensor, logged terms)`` in place for ``iterations`` steps, or
        fewer where ``stop(log so far)`` says the fit is done; return the per-iteration log (the terms, the
        ``loss``, and ``seconds`` of wall time)."""
        ...


@runtime_checkable
class GeometryRenderer(Protocol):
    """Anti-aliased per-part coverage and depth of a fixed camera's view of meshes that move."""

    n_parts: int

    def render(
        self, vertices: Mapping[str, torch.Tensor] | None = None, iteration: int = 0
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(masks [P,H,W] in [0,1], z-depth [H,W] (0 where empty), alpha [H,W]), differentiable with respect to
        the vertex tensors (N×3 world positions per mesh; meshes left out keep their last positions) including
        through visibility."""
        ...

    def render_rgb(
        self,
        vertices: dict[str, torch.Tensor] | None = None,
        base_color: dict[str, torch.Tensor] | None = None,
        roughness: dict[str, torch.Tensor] | None = None,
        specular: dict[str, torch.Tensor] | None = None,
        radiance: dict[str, torch.Tensor] | None = None,
        iteration: int = 0,
        spp: int = 0,
        grad_spp: int = 0,
    ) -> torch.Tensor:
        """Linear RGB [H,W,3] with global illumination, differentiable with respect to the surfaces'
        parameters (constant or maps, as given at construction) and the emitters' radiance."""
        ...

    def render_guides(
        self,
        base_color: dict[str, torch.Tensor] | None = None,
        roughness: dict[str, torch.Tensor] | None = None,
        specular: dict[str, torch.Tensor] | None = None,
        radiance: dict[str, torch.Tensor] | None = None,
        spp: int = 16,
    ) -> tuple[np.ndarray, np.ndarray]:
        """A denoiser's auxiliary images of what :meth:`render_rgb` shows with the same arguments: albedo and
        shading normal, float32 [H,W,3] each (not differentiable)."""
        ...


@runtime_checkable
class Denoiser(Protocol):
    """``denoiser``: a finished linear render [H,W,3] without its Monte-Carlo noise, guided by the render's
    albedo and normal when given. Used on pictures and metric images only, never inside a loss."""

    def denoise(
        self, rgb: np.ndarray, albedo: np.ndarray | None = None, normal: np.ndarray | None = None
    ) -> np.ndarray: ...

    def describe(self) -> str:
        """What ran, in a few words (``oidn 2.5.1 (high)``, or ``none`` and why)."""
        ...


@runtime_checkable
class Renderer(Protocol):
    """``renderer``: a physically based differentiable renderer."""

    def geometry(
        self,
        camera: Camera,
        camera_to_world: np.ndarray,
        meshes: dict[str, TriangleMesh],
        parts: dict[str, int],
        resolution_scale: float = 1.0,
        surfaces: dict[str, Surface] | None = None,
        emitters: dict[str, tuple[TriangleMesh, Any]] | None = None,
    ) -> GeometryRenderer:
        """A renderer of named world-space meshes seen by ``camera``; ``surfaces`` and ``emitters`` (mesh,
        linear RGB radiance) serve RGB renders."""
        ...


@runtime_checkable
class ProceduralMaterial(Protocol):
    """One procedural material: a node graph whose continuous parameters are optimised (§3.2, §4.4).

    Maps are torch tensors [C, H, W] that tile seamlessly: ``base_color`` [3] sRGB in [0, 1], ``roughness``,
    ``metallic``, ``height`` [1] in [0, 1], ``normal`` [3] unit tangent-space normals (OpenGL: +y up).
    """

    name: str
    category: str
    """What the material is (``wood floor``, ``painted wall``, ...): a room side searches the categories it may have."""
    tile_size: float
    """Metres one repeat of the maps covers in a room (the starting texture scale)."""

    def parameters(self, requires_grad: bool = True) -> dict[str, torch.Tensor]:
        """Fresh unconstrained tensors (``node.param``) at the graph's values; the nodes see them through a
        bounded reparameterisation, so any optimiser step keeps them valid. Discrete ones are not included."""
        ...

    def evaluate(
        self, size: int | tuple[int, int], params: dict[str, torch.Tensor] | None = None
    ) -> dict[str, torch.Tensor]:
        """The output maps at ``size`` (side or (H, W)), differentiable with respect to ``params``."""
        ...


@runtime_checkable
class MaterialGraph(Protocol):
    """``material_graph``: the library of differentiable procedural materials (§3.2, §4.4)."""

    def names(self) -> list[str]: ...

    def material(self, name: str) -> ProceduralMaterial: ...

    def appearance(self, name: str, size: int, values: Mapping[str, Any] | None = None) -> torch.Tensor:
        """sRGB [3, size, size] of the material at its own values (or at ``values``: ``node.param`` → value, the
        others its own), head-on under a fixed light (tileable)."""
        ...

    def sample(self, image: torch.Tensor, u: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
        """Bilinear samples of a tileable image at texture coordinates ``u``, ``v`` (1 = one tile)."""
        ...


@runtime_checkable
class TextureDescriptor(Protocol):
    """``texture``: a texture descriptor of image crops for the Gram-matrix loss of Eq. 4 (§3.2).

    ``describe`` maps sRGB crops [3, H, W] (or batches [N, 3, H, W]) in [0, 1] to vectors [D] ([N, D]) whose
    length does not depend on the crop size, differentiably; ``distance`` is the loss between descriptors.
    """

    def describe(self, images: torch.Tensor) -> torch.Tensor: ...

    def distance(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor: ...


PROTOCOLS: dict[str, type] = {
    "fov": FovEstimator,
    "detector": Detector,
    "segmentation": Segmenter,
    "depth": DepthEstimator,
    "retrieval": ObjectRetriever,
    "renderer": Renderer,
    "material_graph": MaterialGraph,
    "texture": TextureDescriptor,
    "optimizer": Optimizer,
    "denoiser": Denoiser,
}
"""Capability → the protocol its implementations satisfy: the engine checks each one it constructs, and a stage
gets it typed as such (``ctx.impl("retrieval", ObjectRetriever)``)."""
