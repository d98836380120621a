"""``depth=onnx``: relative depth from a monocular depth network, normalised as the paper does (§4.1).

Families (all predict relative inverse depth, "disparity", up to an unknown scale):

- ``depth_anything_v2``: Depth-Anything-V2 (DINOv2 ViT + DPT head), shorter side 518, multiples of 14;
- ``dpt``: DPT-Hybrid / DPT-Large (MiDaS v3), shorter side 384, multiples of 32, mean = std = 0.5;
- ``midas``: MiDaS v2.1, a 256 (small) or 384 square.

The graph takes one float image ``[N,3,H,W]`` and returns ``[N,H',W']`` or ``[N,1,H',W']``. The disparity is
resized back to the working image (bilinear), pixels whose disparity is not above
``disparity_eps`` x its maximum are invalid, and depth is ``1 / disparity`` divided by its largest valid
value: the unit-range, scale-free depth the paper uses ("we simply used the normalised depth and do not
assume anything about absolute scale"), returned with ``metric=False``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from psdr_room_core.method.artifacts import Camera, DepthMap, Image, Panoptic

from .network import INPUTS, ModelFile, OnnxNetwork, network_size, resolve_model, to_network, unusable_reason

FAMILIES = ("depth_anything_v2", "dpt", "midas")


def disparity_to_depth(disparity: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """(depth, valid): ``1 / disparity`` normalised so the farthest valid pixel has depth 1; pixels with
    disparity <= ``eps`` x max (or not finite) are invalid and 0."""
    disparity = disparity.astype(np.float64)
    finite = np.isfinite(disparity)
    peak = float(disparity[finite].max()) if finite.any() else 0.0
    valid = finite & (disparity > max(float(eps), 0.0) * peak) & (disparity > 0)
    depth = np.zeros(disparity.shape, np.float32)
    if valid.any():
        inverse = 1.0 / disparity[valid]
        depth[valid] = (inverse / inverse.max()).astype(np.float32)
    return depth, valid


class OnnxDepth:
    """Relative depth from an ONNX depth network (Depth-Anything-V2, DPT, MiDaS), normalised to unit range."""

    def __init__(
        self,
        model: str | None = "depth_anything_v2_small",
        path: str | None = None,
        family: str | None = None,
        models_dir: str | None = None,
        input_size: int | None = None,
        intra_op_threads: int = 0,
        providers: Sequence[str] = ("CPUExecutionProvider",),
        disparity_eps: float = 0.02,
    ) -> None:
        self._params = dict(model=model, path=path, family=family, models_dir=models_dir)
        self.input_size = int(input_size) if input_size else None
        self.threads = int(intra_op_threads)
        self.providers = tuple(providers or ())
        self.disparity_eps = float(disparity_eps)
        self._network: OnnxNetwork | None = None

    @property
    def network(self) -> OnnxNetwork:
        if self._network is None:
            model: ModelFile = resolve_model("depth", FAMILIES, **self._params)
            self._network = OnnxNetwork(model, self.threads, self.providers)
        return self._network

    def external_files(self, photo: Path) -> list[Path]:
        return [self.network.model.path]

    def unavailable(self, photo: Path) -> str | None:
        return unusable_reason(resolve_model("depth", FAMILIES, **self._params))

    def estimate(self, image: Image, camera: Camera, panoptic: Panoptic, photo: Path) -> DepthMap:
        net = self.network
        spec = INPUTS[net.model.family]
        net.image_input()
        if not net.outputs or not (
            net.outputs[0].rank == 3 or (net.outputs[0].rank == 4 and net.outputs[0].shape[1] in (None, 1))
        ):
            raise net.signature_error("expected a depth output [N,H,W] or [N,1,H,W] first")
        hw = network_size(image.height, image.width, spec, self.input_size, net.fixed_size())
        output = next(iter(net.run(to_network(image.rgb, spec, hw)).values()))
        disparity = output.reshape(output.shape[0], *output.shape[-2:])[0] if output.ndim in (3, 4) else output
        if disparity.ndim != 2 or min(disparity.shape) < 1:
            raise net.signature_error(f"the depth output came back with shape {list(output.shape)}")
        disparity = cv2.resize(
            disparity.astype(np.float32), (image.width, image.height), interpolation=cv2.INTER_LINEAR
        )
        depth, valid = disparity_to_depth(disparity, self.disparity_eps)
        if not valid.any():
            raise net.error(
                "the network predicted no positive disparity for this photo; check the family "
                f"('{net.model.family}') matches the model"
            )
        return DepthMap(depth=depth, valid=valid, metric=False, source=f"onnx:{net.model.name} ({net.model.path.name})")


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import DepthEstimator

    _OnnxDepth_is_a_depth: type[DepthEstimator] = OnnxDepth
