"""LPIPS (Zhang et al. 2018, AlexNet, v0.1), the perceptual distance the paper reports: computed only when its
two weight files are installed (``psdr-room-models download alexnet_imagenet lpips_alex_v01``); never
replaced by a stand-in under its name.

The distance is the spatial mean, summed over AlexNet's five ReLU outputs, of the channel-weighted squared
difference of the unit-normalised features of the two images (inputs scaled to [−1, 1], then shifted and
scaled as the reference implementation does).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F

from psdr_room_core.engine.errors import PsdrRoomError

from . import checksums, models

ALEXNET = "alexnet_imagenet"
LINEAR = "lpips_alex_v01"
CONVS = (
    (0, 3, 64, 11, 4, 2),
    (3, 64, 192, 5, 1, 2),
    (6, 192, 384, 3, 1, 1),
    (8, 384, 256, 3, 1, 1),
    (10, 256, 256, 3, 1, 1),
)
"""(index in torchvision's ``alexnet().features``, in, out, kernel, stride, padding) of the convolutions."""
SHIFT = (-0.030, -0.088, -0.188)
SCALE = (0.458, 0.448, 0.450)


def _load(path: Path, what: str, fix: str) -> Mapping[str, Any]:
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # pickle, zip and torch errors of every kind
        raise PsdrRoomError(f"{path}: not a readable torch state dict ({type(exc).__name__}); {fix}") from None
    if not isinstance(state, Mapping):
        raise PsdrRoomError(f"{path}: expected a state dict of {what}, got {type(state).__name__}; {fix}")
    return state


def _tensor(state: Mapping[str, Any], key: str, shape: tuple[int, ...], path: Path, fix: str) -> torch.Tensor:
    value = state.get(key)
    if not isinstance(value, torch.Tensor) or tuple(value.shape) != shape:
        got = tuple(value.shape) if isinstance(value, torch.Tensor) else "missing"
        raise PsdrRoomError(f"{path}: '{key}' should be a tensor of shape {list(shape)}, is {got}; {fix}")
    return value.float()


class Lpips:
    """LPIPS-Alex distance between two sRGB images."""

    def __init__(self, alexnet: Path, linear: Path) -> None:
        fix = "download it again with psdr-room-models"
        features = _load(alexnet, "AlexNet", fix)
        self.convs = [
            (
                _tensor(features, f"features.{i}.weight", (o, c, k, k), alexnet, fix),
                _tensor(features, f"features.{i}.bias", (o,), alexnet, fix),
                s,
                p,
            )
            for i, c, o, k, s, p in CONVS
        ]
        heads = _load(linear, "LPIPS linear layers", fix)
        self.heads = [
            _tensor(heads, f"lin{n}.model.1.weight", (1, o, 1, 1), linear, fix)
            for n, (_, _, o, _, _, _) in enumerate(CONVS)
        ]

    def features(self, x: torch.Tensor) -> list[torch.Tensor]:
        """The five ReLU outputs of AlexNet for [N, 3, H, W] inputs in the network's range."""
        out = []
        for n, (w, b, stride, padding) in enumerate(self.convs):
            if n in (1, 2):
                x = F.max_pool2d(x, 3, 2)
            x = F.relu(F.conv2d(x, w, b, stride=stride, padding=padding))
            out.append(x)
        return out

    def __call__(self, a: np.ndarray, b: np.ndarray) -> float:
        """The distance between two [H, W, 3] sRGB images in [0, 1] (0 for identical images)."""
        shift = torch.tensor(SHIFT).reshape(1, 3, 1, 1)
        scale = torch.tensor(SCALE).reshape(1, 3, 1, 1)
        batch = torch.from_numpy(np.stack([a, b]).astype(np.float32)).permute(0, 3, 1, 2)
        with torch.no_grad():
            feats = self.features(((batch * 2.0 - 1.0) - shift) / scale)
            total = 0.0
            for f, head in zip(feats, self.heads):
                unit = f / (f.pow(2).sum(dim=1, keepdim=True).sqrt() + 1e-10)
                total += float(F.conv2d((unit[0:1] - unit[1:2]) ** 2, head).mean())
        return total


def installed(models_dir: str | Path | None = None) -> Lpips | None:
    """The LPIPS scorer when both weight files are in the models directory, else None; a
    :class:`~.checksums.Mismatch` where one differs from its registry entry."""
    directory = models.resolve_models_dir(models_dir)
    registry = models.load_registry()
    entries = [models.lookup(name, registry) for name in (ALEXNET, LINEAR)]
    paths = [entry.path(directory) for entry in entries]
    if not all(p.is_file() for p in paths):
        return None
    for entry in entries:
        checksums.check_installed(entry, directory)
    return Lpips(*paths)
