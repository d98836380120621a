"""What the texture descriptors share: input preparation, Gram matrices, colour statistics, distance.

Images are sRGB-encoded tensors in [0, 1], ``[3, H, W]`` or ``[N, 3, H, W]`` (crops of different sizes go
one at a time). A descriptor is a flat vector whose length does not depend on the crop size: Gram matrices
are divided by the number of pixels they sum over. The distance between descriptors is the L1 norm of the
difference (the paper's Gram loss, Eq. 4), with the block weights folded into the vectors.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from psdr_room_core.engine.errors import PsdrRoomError


def as_batch(images: torch.Tensor, what: str = "texture descriptor") -> tuple[torch.Tensor, bool]:
    """``[N, 3, H, W]`` float images and whether the input was a single ``[3, H, W]`` image."""
    if images.dim() == 3:
        images, single = images[None], True
    else:
        single = False
    if images.dim() != 4 or images.shape[1] != 3:
        raise PsdrRoomError(
            f"{what}: expected an RGB image [3, H, W] or a batch [N, 3, H, W], got shape {list(images.shape)}"
        )
    return images.float(), single


def resize_short_side(images: torch.Tensor, size: int | None, minimum: int = 1) -> torch.Tensor:
    """Resize so that the shorter side is ``size`` (None: unchanged, but at least ``minimum``)."""
    h, w = images.shape[-2:]
    target = size if size else max(minimum, min(h, w))
    if min(h, w) == target:
        return images
    scale = target / min(h, w)
    out_hw = (max(1, round(h * scale)), max(1, round(w * scale)))
    return F.interpolate(images, size=out_hw, mode="bilinear", align_corners=False, antialias=scale < 1)


def gram(features: torch.Tensor) -> torch.Tensor:
    """Gram matrices ``F Fᵀ / (H·W)`` of ``[N, C, H, W]`` features → ``[N, C, C]``."""
    n, c, h, w = features.shape
    flat = features.reshape(n, c, h * w)
    return torch.bmm(flat, flat.transpose(1, 2)) / float(h * w)


def upper(matrices: torch.Tensor) -> torch.Tensor:
    """The upper triangle (with the diagonal) of symmetric ``[N, C, C]`` matrices → ``[N, C(C+1)/2]``."""
    c = matrices.shape[-1]
    i, j = torch.triu_indices(c, c, device=matrices.device)
    return matrices[:, i, j]


def colour_stats(images: torch.Tensor) -> torch.Tensor:
    """Simple colour statistics of ``[N, 3, H, W]`` images: per-channel mean and standard deviation and the
    three channel correlations (scaled by the stds) → ``[N, 9]``."""
    flat = images.flatten(2)
    mean = flat.mean(-1)
    centred = flat - mean[..., None]
    cov = torch.bmm(centred, centred.transpose(1, 2)) / flat.shape[-1]
    std = torch.sqrt(torch.diagonal(cov, dim1=1, dim2=2) + 1e-8)
    cross = torch.stack([cov[:, 0, 1], cov[:, 0, 2], cov[:, 1, 2]], -1)
    return torch.cat([mean, std, cross / (std.mean(-1, keepdim=True) + 1e-3)], -1)


def l1_distance(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Sum of absolute differences over the last dimension (broadcasting over batches)."""
    return (a - b).abs().sum(-1)


class GramDescriptor:
    """What every texture descriptor shares: the L1 distance and the loss (subclasses define ``describe``)."""

    def describe(self, images: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def distance(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        """L1 distance between descriptors (broadcast over leading dimensions)."""
        return l1_distance(a, b)

    def loss(self, images: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
        """Mean descriptor distance between images and targets (images, or their precomputed descriptors)."""
        target = targets if targets.dim() <= 2 else self.describe(targets)
        return self.distance(self.describe(images), target).mean()
