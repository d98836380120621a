"""``texture=random_cnn``: Gram matrices of a fixed-seed, multi-scale random-filter CNN (offline, no weights).

Ustyuzhaninov et al. (2017, "What does it take to generate natural textures?") showed that Gram matrices
of a single layer of *random* convolution filters at several scales describe textures nearly as well as a
trained VGG for synthesis. Here the scales come from an image pyramid: at each of ``levels`` levels (the
crop average-pooled by 2^level) a bank of ``channels`` random k×k filters (zero mean per input channel, so
a uniform colour gives no response; unit norm) is applied without padding, rectified, and summarised by its
Gram matrix divided by the pixel count, so the descriptor length does not depend on the crop size.
Entries are raised to ``power`` (0.5: the square root, which makes the descriptor scale with contrast
rather than its square and balances bright and dark textures), and each level's block is weighted so that
the L1 distance is the mean over its entries. Simple colour statistics (:func:`.common.colour_stats`) are
appended with weight ``colour_weight``. The filters depend only on ``seed``: every process and machine
gets the same descriptor.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch
import torch.nn.functional as F

from psdr_room_core.engine.errors import PsdrRoomError

from .common import GramDescriptor, as_batch, colour_stats, gram, resize_short_side, upper


class RandomCnnDescriptor(GramDescriptor):
    """Texture descriptor: Gram matrices of fixed random filters on an image pyramid, plus colour statistics."""

    def __init__(
        self,
        seed: int = 0,
        channels: int = 32,
        kernel: int = 5,
        levels: int = 5,
        size: int | None = 256,
        power: float = 0.5,
        colour_weight: float = 0.5,
        device: str = "cpu",
    ) -> None:
        """The settings are :class:`~psdr_room_plugins.texture.RandomCnnSettings`' (``texture.random_cnn.*``),
        checked against it; what it cannot check (an odd kernel, a size the pyramid fits in) is checked here."""
        if kernel % 2 == 0:
            raise PsdrRoomError(f"texture.random_cnn.kernel={kernel} must be odd")
        if size is not None and (int(size) != size or size < kernel * 2 ** (levels - 1)):
            raise PsdrRoomError(
                f"texture.random_cnn.size={size!r} must be null or at least kernel·2^(levels−1) = "
                f"{kernel * 2 ** (levels - 1)} pixels"
            )
        self.seed, self.channels, self.kernel, self.levels = int(seed), int(channels), int(kernel), int(levels)
        self.size = None if size is None else int(size)
        self.power = float(power)
        self.colour_weight = float(colour_weight)
        self.device = torch.device(device)
        generator = torch.Generator().manual_seed(self.seed)
        banks = []
        for _ in range(self.levels):
            w = torch.randn(self.channels, 3, self.kernel, self.kernel, generator=generator)
            w = w - w.mean(dim=(2, 3), keepdim=True)
            banks.append((w / w.flatten(1).norm(dim=1).reshape(-1, 1, 1, 1)).to(self.device))
        self.banks = banks
        self.block = self.channels * (self.channels + 1) // 2
        self.dim = self.levels * self.block + 9

    @property
    def min_size(self) -> int:
        """The smallest crop side the coarsest level can still filter."""
        return self.kernel * 2 ** (self.levels - 1)

    def describe(self, images: torch.Tensor) -> torch.Tensor:
        """Descriptor(s) of sRGB images ``[3, H, W]`` → ``[D]`` or ``[N, 3, H, W]`` → ``[N, D]``,
        differentiable with respect to the images."""
        x, single = as_batch(images, "texture=random_cnn")
        x = resize_short_side(x.to(self.device), self.size, self.min_size)
        parts = []
        level = x
        for index, bank in enumerate(self.banks):
            if index:
                level = F.avg_pool2d(level, 2, ceil_mode=True)
            features = F.relu(F.conv2d(level, bank))
            g = upper(gram(features))
            if self.power != 1.0:
                g = (g + 1e-8).pow(self.power)
            parts.append(g / self.block)
        parts.append(colour_stats(x) * (self.colour_weight / 9.0))
        out = torch.cat(parts, -1)
        return out[0] if single else out


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import TextureDescriptor

    _RandomCnnDescriptor_is_a_texture: type[TextureDescriptor] = RandomCnnDescriptor
