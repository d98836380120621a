"""texture=random_cnn and texture=vgg19: crop-size-independent descriptors, telling real textures apart,
gradients, and the VGG19 weight loader (on tiny generated state dicts with torchvision's layout)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import torch
import torch.nn as nn
import yaml

from conftest import REPO, SHARED_DATA
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.plugins import load_plugins
from psdr_room_plugins.texture.common import colour_stats, gram
from psdr_room_plugins.texture.random_cnn import RandomCnnDescriptor
from psdr_room_plugins.texture.vgg19 import BLOCKS, CONV_INDICES, Vgg19Descriptor, layer_names

torch.set_num_threads(1)

TEXTURES = SHARED_DATA / "textures"


def real_textures() -> list[Path]:
    files = sorted((TEXTURES / "robosuite_mit").glob("*.png"))
    files += sorted((TEXTURES / "cc0textures_yuki-koyama").glob("*/*_col.jpg"))
    files += sorted((TEXTURES / "polyhaven_robotlocomotion").glob("*/*diff*.jpg"))
    return files


def load(path: Path, width: int = 384) -> torch.Tensor:
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)[:, :, ::-1].astype(np.float32) / 255.0
    height = round(image.shape[0] * width / image.shape[1])
    image = cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)
    return torch.from_numpy(np.ascontiguousarray(image)).permute(2, 0, 1)


# ------------------------------------------------------------------------------------- random_cnn
def test_descriptor_length_does_not_depend_on_the_crop_size() -> None:
    descriptor = RandomCnnDescriptor(size=None)
    generator = torch.Generator().manual_seed(0)
    sizes = [(80, 80), (100, 150), (257, 191)]
    lengths = {descriptor.describe(torch.rand(3, h, w, generator=generator)).shape[0] for h, w in sizes}
    assert lengths == {descriptor.dim}
    batch = descriptor.describe(torch.rand(4, 3, 96, 96, generator=generator))
    assert batch.shape == (4, descriptor.dim)
    resized = RandomCnnDescriptor(size=128)
    assert resized.describe(torch.rand(3, 300, 200, generator=generator)).shape == (resized.dim,)


def test_descriptor_is_fixed_by_its_seed() -> None:
    image = torch.rand(3, 96, 96, generator=torch.Generator().manual_seed(1))
    a, b = RandomCnnDescriptor(seed=7), RandomCnnDescriptor(seed=7)
    assert torch.equal(a.describe(image), b.describe(image))
    assert not torch.equal(a.describe(image), RandomCnnDescriptor(seed=8).describe(image))


def test_crops_of_the_same_real_texture_are_nearest_neighbours() -> None:
    """Two disjoint crops of each of 21 real texture photos: each first crop's nearest second crop is its own."""
    files = real_textures()
    if len(files) < 20:
        pytest.skip("the shared real textures (../shared/data/textures) are not here")
    descriptor = RandomCnnDescriptor()
    first, second = [], []
    for path in files:
        image = load(path)
        first.append(descriptor.describe(image[:, :160, :160]))
        second.append(descriptor.describe(image[:, -128:, -200:]))  # another place and shape
    distances = descriptor.distance(torch.stack(first)[:, None], torch.stack(second)[None])
    correct = (distances.argmin(1) == torch.arange(len(files))).float().mean()
    assert float(correct) >= 0.9, f"top-1 {float(correct):.2f}"
    assert torch.allclose(
        torch.diagonal(descriptor.distance(torch.stack(first)[:, None], torch.stack(first)[None])),
        torch.zeros(len(files)),
    )


def test_texture_part_tells_structure_apart_without_colour() -> None:
    descriptor = RandomCnnDescriptor(colour_weight=0.0, size=None)
    generator = torch.Generator().manual_seed(3)
    noise = torch.rand(1, 128, 128, generator=generator).expand(3, -1, -1)
    stripes = (torch.sin(torch.arange(128) * 0.6) * 0.5 + 0.5).reshape(1, 1, 128).expand(3, 128, 128)
    noise2 = torch.rand(1, 128, 128, generator=generator).expand(3, -1, -1)
    d = descriptor.describe(torch.stack([noise, stripes, noise2]))
    assert descriptor.distance(d[0], d[2]) < 0.2 * descriptor.distance(d[0], d[1])


def test_gradients_reach_the_image() -> None:
    descriptor = RandomCnnDescriptor()
    target = descriptor.describe(torch.rand(3, 120, 120, generator=torch.Generator().manual_seed(4)))
    image = torch.full((3, 90, 110), 0.5, requires_grad=True)
    with torch.no_grad():
        image += 0.1 * torch.rand(3, 90, 110, generator=torch.Generator().manual_seed(5))
    descriptor.loss(image, target).backward()
    assert image.grad is not None and torch.isfinite(image.grad).all() and float(image.grad.abs().sum()) > 0


def test_colour_statistics() -> None:
    image = torch.zeros(1, 3, 8, 8)
    image[:, 0] = 0.25
    image[:, 2, :, :4] = 1.0
    stats = colour_stats(image)[0]
    assert stats.shape == (9,)
    assert stats[:3].tolist() == pytest.approx([0.25, 0.0, 0.5])
    assert stats[3:6].tolist() == pytest.approx([0.0, 0.0, 0.5], abs=1e-3)


def test_random_cnn_rejects_bad_settings_and_inputs() -> None:
    with pytest.raises(PsdrRoomError, match="kernel=4 must be odd"):
        RandomCnnDescriptor(kernel=4)
    with pytest.raises(PsdrRoomError, match="size=32 must be null or at least"):
        RandomCnnDescriptor(size=32)
    with pytest.raises(PsdrRoomError, match=r"expected an RGB image \[3, H, W\]"):
        RandomCnnDescriptor().describe(torch.rand(4, 32, 32))


# ------------------------------------------------------------------------------------------- vgg19
WIDTHS = (4, 4, 6, 6, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8)
"""Tiny stand-in widths of the 16 VGG19 convolutions (the real ones are 64 ... 512)."""


def tiny_state_dict(widths: tuple[int, ...] = WIDTHS, seed: int = 0) -> dict[str, torch.Tensor]:
    """A state dict with torchvision's VGG19 key names and shape rules, small random weights, plus a classifier
    entry (real files have one) that the loader must ignore."""
    generator = torch.Generator().manual_seed(seed)
    state, previous = {}, 3
    for index, width in zip(CONV_INDICES, widths):
        state[f"features.{index}.weight"] = torch.randn(width, previous, 3, 3, generator=generator) * 0.3
        state[f"features.{index}.bias"] = torch.randn(width, generator=generator) * 0.1
        previous = width
    state["classifier.0.weight"] = torch.randn(5, 7, generator=generator)
    return state


def reference_features(state: dict[str, torch.Tensor]) -> nn.Sequential:
    """torchvision's ``vgg19().features`` layer by layer (conv, ReLU, …, max-pool), with the same weights."""
    layers: list[nn.Module] = []
    convs = iter(CONV_INDICES)
    for count in BLOCKS:
        for _ in range(count):
            index = next(convs)
            weight = state[f"features.{index}.weight"]
            conv = nn.Conv2d(weight.shape[1], weight.shape[0], 3, padding=1)
            conv.weight.data, conv.bias.data = weight.clone(), state[f"features.{index}.bias"].clone()
            layers += [conv, nn.ReLU()]
        layers.append(nn.MaxPool2d(2, ceil_mode=True))
    return nn.Sequential(*layers)


def test_vgg19_loader_matches_the_torchvision_layout(tmp_path: Path) -> None:
    state = tiny_state_dict()
    path = tmp_path / "vgg19-tiny.pth"
    torch.save(state, path)
    descriptor = Vgg19Descriptor(path=str(path), size=None)
    image = torch.rand(2, 3, 48, 40, generator=torch.Generator().manual_seed(6))
    out = descriptor.describe(image)
    widths = {name: w for name, w in zip([n for n in layer_names() if n.startswith("relu")], WIDTHS)}
    assert out.shape == (2, sum(widths[n] ** 2 for n in descriptor.layers))
    # the same activations as the reference network at the positions of relu1_1, relu2_1, ..., relu5_1
    mean = torch.tensor([0.485, 0.456, 0.406]).reshape(1, 3, 1, 1)
    std = torch.tensor([0.229, 0.224, 0.225]).reshape(1, 3, 1, 1)
    x = (image - mean) / std
    expected, names = [], [n for n in layer_names()]
    for name, layer in zip(names, reference_features(state)):
        x = layer(x)
        if name in descriptor.layers:
            expected.append(gram(x).flatten(1))
    assert torch.allclose(out, torch.cat(expected, -1), atol=1e-5)
    leaf = image.clone().requires_grad_(True)
    descriptor.describe(leaf).sum().backward()
    assert torch.isfinite(leaf.grad).all() and float(leaf.grad.abs().sum()) > 0


def test_vgg19_missing_weights_name_the_file_and_the_command(tmp_path: Path) -> None:
    descriptor = Vgg19Descriptor(models_dir=str(tmp_path))  # construction is cheap: nothing read yet
    assert descriptor.unavailable() == f"weights not installed: {tmp_path / 'vgg19-dcbb9e9d.pth'}"
    with pytest.raises(PsdrRoomError) as info:
        descriptor.describe(torch.rand(3, 64, 64))
    message = str(info.value)
    assert "vgg19-dcbb9e9d.pth" in message and "psdr-room-models download vgg19_imagenet" in message
    assert "\n" not in message


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda s: s.pop("features.21.weight"), r"'features.21.weight' is missing, so this is not a torchvision VGG19"),
        (
            lambda s: s.__setitem__("features.5.weight", torch.zeros(6, 5, 3, 3)),
            r"'features.5.weight' has shape \[6, 5, 3, 3\], expected \[out, 4, 3, 3\] \(convolution 3 of 16\)",
        ),
        (
            lambda s: s.__setitem__("features.0.bias", torch.zeros(3)),
            r"'features.0.bias' has shape \[3\], expected \[4\]",
        ),
    ],
)
def test_vgg19_rejects_state_dicts_of_another_network(tmp_path: Path, damage, message: str) -> None:  # noqa: ANN001
    state = tiny_state_dict()
    damage(state)
    path = tmp_path / "vgg19-dcbb9e9d.pth"
    torch.save(state, path)
    with pytest.raises(PsdrRoomError, match=message) as info:
        Vgg19Descriptor(path=str(path)).describe(torch.rand(3, 64, 64))
    assert str(info.value).startswith(str(path)) and "check texture.vgg19.path" in str(info.value)
    with pytest.raises(PsdrRoomError, match="psdr-room-models download vgg19_imagenet --force"):
        Vgg19Descriptor(models_dir=str(tmp_path)).describe(torch.rand(3, 64, 64))  # not the published file


def test_vgg19_rejects_damaged_files_and_unknown_layers(tmp_path: Path) -> None:
    path = tmp_path / "vgg19-dcbb9e9d.pth"
    path.write_bytes(b"not a checkpoint at all")
    with pytest.raises(PsdrRoomError, match="not a readable torch state dict"):
        Vgg19Descriptor(path=str(path)).describe(torch.rand(3, 64, 64))
    with pytest.raises(PsdrRoomError, match="unknown layer"):
        Vgg19Descriptor(models_dir=str(tmp_path), layers=["relu6_1"])


# --------------------------------------------------------------------------------------- registry
def test_registered_and_constructible_from_their_config_files(tmp_path: Path) -> None:
    from psdr_room_core.method.capabilities import TextureDescriptor

    registry = load_plugins().registry
    for name in ("random_cnn", "vgg19"):
        conf = yaml.safe_load((REPO / "conf" / "texture" / f"{name}.yaml").read_text())
        assert conf["impl"] == name
        params = dict(conf[name])
        if name == "vgg19":
            params["models_dir"] = str(tmp_path)  # the YAML's value is an interpolation Hydra resolves
        descriptor = registry.implementation("texture", name).factory(**params)
        assert isinstance(descriptor, TextureDescriptor)
