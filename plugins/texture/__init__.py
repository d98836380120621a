"""``texture`` implementations: descriptors for the crop-to-crop Gram loss of the appearance stage (§3.2).

``texture=random_cnn`` (the offline default) needs no weights; ``texture=vgg19`` is the paper's descriptor
and reads torchvision's VGG19 weights (``psdr-room-models download vgg19_imagenet``). Both map sRGB crops
``[3, H, W]`` / ``[N, 3, H, W]`` to vectors whose length does not depend on the crop size, with
``distance(a, b)`` the L1 norm of their difference (the ``TextureDescriptor`` protocol). Both are registered by reference: torch loads when one is constructed.
"""

from __future__ import annotations

from dataclasses import dataclass

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry
from psdr_room_core.engine.settings import setting


@dataclass
class RandomCnnSettings:
    """``texture=random_cnn``: the random filters, the pyramid, and how crops are described."""

    seed: int = setting(doc="Seed of the random filters (another seed is another descriptor).")
    channels: int = setting(ge=1, doc="Random filters per pyramid level.")
    kernel: int = setting(ge=1, doc="Filter size in pixels (odd).")
    levels: int = setting(ge=1, doc="Pyramid levels, each half the resolution of the previous.")
    size: int | None = setting(
        ge=16,
        doc="Crops are resized to this shorter side, pixels (null: as given; at least kernel·2^(levels-1)); the paper "
        "resizes its VGG crops to 512.",
    )
    power: float = setting(gt=0, le=2, doc="Exponent on the Gram entries (1: plain Gram matrices, as VGG's).")
    colour_weight: float = setting(
        ge=0, doc="Weight of the mean/std/correlation colour statistics against the Gram part."
    )
    device: str = setting(doc="Torch device of the filters (cpu, cuda); inputs are moved there.")


@dataclass
class Vgg19Settings:
    """``texture=vgg19``: the paper's descriptor (§3.2) and its weights."""

    model: str = setting(doc="A texture model of `psdr-room-models list` (torchvision's ImageNet state dict).")
    path: str | None = setting(doc="Or a torchvision-layout VGG19 state dict of your own.")
    models_dir: str = setting(doc="Where downloaded models live.")
    layers: list[str] = setting(
        doc="Layers whose Gram matrices are concatenated: the first of each block (Gatys et al.); any conv, relu or "
        "pool name."
    )
    size: int | None = setting(
        ge=16, doc="Crops are resized to this shorter side, pixels (null: as given), as the paper."
    )
    colour_weight: float = setting(
        ge=0, doc="Weight of appended colour statistics (0: Gram matrices only, as the paper)."
    )
    device: str = setting(doc="Torch device (cpu, cuda).")


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation(
        "texture",
        "random_cnn",
        "psdr_room_plugins.texture.random_cnn:RandomCnnDescriptor",
        params=RandomCnnSettings,
        reads_files=False,
    )
    registry.add_implementation(
        "texture", "vgg19", "psdr_room_plugins.texture.vgg19:Vgg19Descriptor", params=Vgg19Settings, reads_files=True
    )
