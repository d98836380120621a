"""Capabilities: the swappable parts of the method, each a protocol that implementations satisfy.

An implementation is selected per capability by the config group of the same name (``fov=fixed``) and
constructed with the parameters under ``<capability>.<name>``. Implementations that read files besides
the stage's input artifacts (sidecar depth, model weights) list them in ``external_files`` so that their
content is part of the cache key.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np
    import torch

    from .artifacts import Camera, DepthMap, Image, Panoptic
    from .geometry import TriangleMesh

CAPABILITIES: tuple[str, ...] = (
    "fov",
    "depth",
    "segmentation",
    "retrieval",
    "renderer",
    "material_graph",
    "texture",
    "optimizer",
)
"""Every capability, in pipeline order. Protocols below exist for those the pipeline calls today."""

DESCRIPTIONS: dict[str, str] = {
    "fov": "camera intrinsics (vertical field of view) from the photo (§4.1)",
    "depth": "per-pixel depth (§4.1)",
    "segmentation": "panoptic segmentation with wall/floor/ceiling/object categories (§4.1)",
    "retrieval": "object and material retrieval from a database (§4.3, §4.4)",
    "renderer": "differentiable renderer for masks, depth and RGB (§3.1)",
    "material_graph": "differentiable procedural material node graphs (§3.2, §4.4)",
    "texture": "texture descriptors for crop-to-crop losses (§3.2)",
    "optimizer": "gradient-based optimiser with per-parameter learning rates",
}


@runtime_checkable
class ExternalFiles(Protocol):
    """Optional: files an implementation reads for a given photo, hashed into the stage's cache key."""

    def external_files(self, photo: Path) -> list[Path]: ...


@runtime_checkable
class FovEstimator(Protocol):
    """``fov``: estimates pinhole intrinsics (square pixels) for the working image."""

    def estimate(self, image: Image, photo: Path) -> Camera: ...


@runtime_checkable
class DepthEstimator(Protocol):
    """``depth``: z-depth at the working image's resolution (metric or normalised, see ``DepthMap``)."""

    def estimate(self, image: Image, camera: Camera, photo: Path) -> DepthMap: ...


@runtime_checkable
class Segmenter(Protocol):
    """``segmentation``: a panoptic segmentation at the working image's resolution."""

    def segment(self, image: Image, photo: Path) -> Panoptic: ...


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
    ) -> list[dict[str, float]]: ...


@runtime_checkable
class GeometryRenderer(Protocol):
    """Anti-aliased per-part coverage and depth of a fixed camera's view of meshes that move."""

    n_parts: int

    def render(self, vertices: dict[str, torch.Tensor], iteration: int = 0) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(masks [P,H,W] in [0,1], z-depth [H,W] (0 where empty), alpha [H,W]), differentiable with respect to
        the vertex tensors (N×3 world positions per mesh) including through visibility."""
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
    ) -> GeometryRenderer: ...
