"""``texture=vgg19``: the paper's texture descriptor (§3.2) — Gram matrices of five VGG19 layers.

"We use 5 layers (the ones after each pooling operation in the VGG19 variant), and concatenate the
flattened Gram matrices into a single vector descriptor of the crop texture." Following Gatys et al. (2016),
whom the paper cites for it, the default layers are the first rectified convolution of each of the five
blocks (``relu1_1``, and ``relu2_1`` … ``relu5_1`` right after the four inner poolings); ``layers`` can
name any of ``conv{b}_{i}``, ``relu{b}_{i}``, ``pool{b}``. Crops are resized so that their shorter side is
``size`` (the paper: 512), normalised with the ImageNet mean and std, and each layer's Gram matrix is
divided by its pixel count, so the descriptor length does not depend on the crop size.

Weights are torchvision's ImageNet VGG19 state dict (``vgg19_imagenet`` in ``psdr-room-models list``),
read from the models directory on first use. The loader checks the state dict by its layer names and
shapes (16 convolutions at torchvision's ``features.N`` indices, 3×3 kernels, each layer's input channels
equal to the previous layer's outputs, 3 input channels) rather than against fixed widths.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch
import torch.nn.functional as F

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method import checksums, models

from .common import GramDescriptor, as_batch, colour_stats, gram, resize_short_side

MODEL = "vgg19_imagenet"
BLOCKS = (2, 2, 4, 4, 4)
"""Convolutions per block of VGG19 (configuration E)."""
CONV_INDICES = (0, 2, 5, 7, 10, 12, 14, 16, 19, 21, 23, 25, 28, 30, 32, 34)
"""Positions of the convolutions in torchvision's ``vgg19().features`` (ReLU after each, pools between)."""
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
DEFAULT_LAYERS = ("relu1_1", "relu2_1", "relu3_1", "relu4_1", "relu5_1")


def layer_names() -> list[str]:
    """Every layer name in network order (``conv1_1``, ``relu1_1``, …, ``pool5``)."""
    names = []
    for b, count in enumerate(BLOCKS, start=1):
        for i in range(1, count + 1):
            names += [f"conv{b}_{i}", f"relu{b}_{i}"]
        names.append(f"pool{b}")
    return names


def load_vgg19_features(path: Path, fix: str) -> list[tuple[torch.Tensor, torch.Tensor]]:
    """The 16 (weight, bias) pairs of VGG19's convolutions from a torchvision state dict file.

    Raises a one-line :class:`PsdrRoomError` naming the file, the offending key and ``fix`` when the file is
    missing, unreadable or not a VGG19 state dict.
    """
    path = Path(path)
    if not path.is_file():
        raise PsdrRoomError(f"{path}: VGG19 weights not found; {fix}")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # pickle, zip and torch errors of every kind
        reason = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise PsdrRoomError(
            f"{path}: not a readable torch state dict ({reason}); the file is damaged or incomplete: {fix}"
        ) from None
    if isinstance(state, Mapping) and "state_dict" in state and isinstance(state["state_dict"], Mapping):
        state = state["state_dict"]
    if not isinstance(state, Mapping):
        raise PsdrRoomError(f"{path}: expected a state dict (a mapping of tensors), got {type(state).__name__}; {fix}")
    return check_vgg19_state(state, str(path), fix)


def check_vgg19_state(state: Mapping[str, Any], where: str, fix: str) -> list[tuple[torch.Tensor, torch.Tensor]]:
    """The convolution weights of a VGG19 state dict, checked by layer names and shape rules."""
    layers = []
    previous = 3
    for n, index in enumerate(CONV_INDICES):
        w_key, b_key = f"features.{index}.weight", f"features.{index}.bias"
        for key in (w_key, b_key):
            if key not in state:
                found = sorted(k for k in state if str(k).startswith("features."))[:6]
                raise PsdrRoomError(
                    f"{where}: '{key}' is missing, so this is not a torchvision VGG19 state dict "
                    f"(features keys found: {', '.join(found) or 'none'}); {fix}"
                )
            if not isinstance(state[key], torch.Tensor):
                raise PsdrRoomError(f"{where}: '{key}' is not a tensor; {fix}")
        w, b = state[w_key], state[b_key]
        if w.dim() != 4 or tuple(w.shape[2:]) != (3, 3) or w.shape[1] != previous:
            raise PsdrRoomError(
                f"{where}: '{w_key}' has shape {list(w.shape)}, expected [out, {previous}, 3, 3] "
                f"(convolution {n + 1} of 16); {fix}"
            )
        if tuple(b.shape) != (w.shape[0],):
            raise PsdrRoomError(f"{where}: '{b_key}' has shape {list(b.shape)}, expected [{w.shape[0]}]; {fix}")
        layers.append((w.float(), b.float()))
        previous = w.shape[0]
    return layers


class Vgg19Descriptor(GramDescriptor):
    """Texture descriptor of the paper: concatenated Gram matrices of five VGG19 layers (weights required)."""

    def __init__(
        self,
        model: str = MODEL,
        path: str | None = None,
        models_dir: str | None = None,
        layers: Sequence[str] = DEFAULT_LAYERS,
        size: int | None = 512,
        colour_weight: float = 0.0,
        device: str = "cpu",
    ) -> None:
        """The settings are :class:`~psdr_room_plugins.texture.Vgg19Settings`' (``texture.vgg19.*``), checked against
        it; the layer names are checked here."""
        known = layer_names()
        unknown = [name for name in layers if name not in known]
        if unknown or not layers:
            raise PsdrRoomError(
                f"texture.vgg19.layers: unknown layer(s) {', '.join(unknown) or '(none given)'}; "
                f"use names like relu1_1, conv3_2, pool4"
            )
        self.layers = tuple(layers)
        self.size = None if size is None else int(size)
        self.colour_weight = float(colour_weight)
        self.device = torch.device(device)
        self.entry: models.ModelEntry | None = None
        if path:
            self.path = Path(path).expanduser()
            self.fix = "check texture.vgg19.path"
        else:
            entry = self.entry = models.lookup(str(model), models.load_registry(), "texture")
            self.path = entry.path(models.resolve_models_dir(models_dir))
            self.fix = (
                f"run `psdr-room-models download {entry.name}`, or set texture.vgg19.models_dir to the "
                f"directory that holds {entry.file}"
            )
        self._last = max(known.index(name) for name in self.layers)

    def unavailable(self, photo: Path | None = None) -> str | None:
        """None when the weights file exists and matches its registry entry, else why not (for
        ``texture=auto``-style fallbacks; a damaged file is logged as a warning)."""
        if not self.path.is_file():
            return f"weights not installed: {self.path}"
        return checksums.damage(self.check)

    def check(self) -> None:
        """A :class:`~psdr_room_core.method.checksums.Mismatch` where the registry's file differs from its entry
        (weights given by ``path`` have no record)."""
        if self.entry is not None:
            checksums.check_installed(self.entry, self.path.parent)

    def external_files(self, photo: Path | None = None) -> list[Path]:
        return [self.path]

    @functools.cached_property
    def weights(self) -> list[tuple[torch.Tensor, torch.Tensor]]:
        self.check()
        return [(w.to(self.device), b.to(self.device)) for w, b in load_vgg19_features(self.path, self.fix)]

    def features(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        """The requested layers' activations of normalised images ``[N, 3, H, W]``."""
        out: dict[str, torch.Tensor] = {}
        names = layer_names()
        convs = iter(self.weights)
        for _position, name in enumerate(names[: self._last + 1]):
            if name.startswith("conv"):
                w, b = next(convs)
                x = F.conv2d(x, w, b, padding=1)
            elif name.startswith("relu"):
                x = F.relu(x)
            else:
                x = F.max_pool2d(x, 2, ceil_mode=True)
            if name in self.layers:
                out[name] = x
        return out

    def describe(self, images: torch.Tensor) -> torch.Tensor:
        """Descriptor(s) of sRGB images ``[3, H, W]`` → ``[D]`` or ``[N, 3, H, W]`` → ``[N, D]``."""
        x, single = as_batch(images, "texture=vgg19")
        x = resize_short_side(x.to(self.device), self.size, minimum=32)
        mean = torch.tensor(IMAGENET_MEAN, device=self.device).reshape(1, 3, 1, 1)
        std = torch.tensor(IMAGENET_STD, device=self.device).reshape(1, 3, 1, 1)
        feats = self.features((x - mean) / std)
        parts = [gram(feats[name]).flatten(1) for name in self.layers]
        if self.colour_weight:
            parts.append(colour_stats(x) * (self.colour_weight / 9.0))
        out = torch.cat(parts, -1)
        return out[0] if single else out


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import TextureDescriptor

    _Vgg19Descriptor_is_a_texture: type[TextureDescriptor] = Vgg19Descriptor
