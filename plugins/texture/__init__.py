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
    seed: int = setting()
    channels: int = setting(ge=1)
    kernel: int = setting(ge=1)
    levels: int = setting(ge=1)
    size: int | None = setting(ge=16)
    power: float = setting(gt=0)
    colour_weight: float = setting(ge=0)
    device: str = setting()


@dataclass
class Vgg19Settings:
    model: str = setting()
    path: str | None = setting()
    models_dir: str = setting()
    layers: list[str] = setting()
    size: int | None = setting(ge=16)
    colour_weight: float = setting(ge=0)
    device: str = setting()


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
