"""LPIPS is computed only from its real weight files: the loader and the distance, on weight files the test
writes with the real key names and shapes (random values); files in the models directory must also match their
registry entries."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method import checksums, lpips

ALEXNET, LINEAR = "alexnet-owt-7be5be79.pth", "lpips_alex_v0.1.pth"


def _write_weights(directory: Path, seed: int = 0) -> None:
    generator = torch.Generator().manual_seed(seed)
    features = {}
    for index, c, o, k, _, _ in lpips.CONVS:
        features[f"features.{index}.weight"] = torch.randn(o, c, k, k, generator=generator) * (2.0 / (c * k * k)) ** 0.5
        features[f"features.{index}.bias"] = torch.zeros(o)
    torch.save(features, directory / "alexnet-owt-7be5be79.pth")
    heads = {
        f"lin{n}.model.1.weight": torch.rand(1, o, 1, 1, generator=generator)
        for n, (_, _, o, _, _, _) in enumerate(lpips.CONVS)
    }
    torch.save(heads, directory / "lpips_alex_v0.1.pth")


def test_absent_weights_give_no_scorer(tmp_path: Path) -> None:
    assert lpips.installed(tmp_path) is None
    _write_weights(tmp_path)
    (tmp_path / "lpips_alex_v0.1.pth").unlink()
    assert lpips.installed(tmp_path) is None


def test_weights_not_as_published_are_refused(tmp_path: Path) -> None:
    _write_weights(tmp_path)
    with pytest.raises(checksums.Mismatch, match=f"{ALEXNET}: sha256 .* expected 7be5be79"):
        lpips.installed(tmp_path)


def test_distance_is_zero_for_equal_images_and_grows_with_change(tmp_path: Path) -> None:
    _write_weights(tmp_path)
    scorer = lpips.Lpips(tmp_path / ALEXNET, tmp_path / LINEAR)
    rng = np.random.default_rng(0)
    image = rng.uniform(0, 1, (96, 128, 3))
    slight = np.clip(image + rng.normal(0, 0.02, image.shape), 0, 1)
    strong = np.clip(image + rng.normal(0, 0.2, image.shape), 0, 1)
    assert scorer(image, image) == pytest.approx(0.0, abs=1e-9)
    assert 0 < scorer(image, slight) < scorer(image, strong)
    assert scorer(image, strong) == pytest.approx(scorer(strong, image), rel=1e-5)


def test_a_wrong_file_is_a_one_line_error(tmp_path: Path) -> None:
    _write_weights(tmp_path)
    torch.save({"lin0.model.1.weight": torch.rand(1, 3, 1, 1)}, tmp_path / "lpips_alex_v0.1.pth")
    with pytest.raises(
        PsdrRoomError, match=r"lpips_alex_v0.1.pth: 'lin0.model.1.weight' should be a tensor of shape \[1, 64, 1, 1\]"
    ):
        lpips.Lpips(tmp_path / ALEXNET, tmp_path / LINEAR)
    (tmp_path / ALEXNET).write_bytes(b"not a torch file")
    with pytest.raises(PsdrRoomError, match="not a readable torch state dict"):
        lpips.Lpips(tmp_path / ALEXNET, tmp_path / LINEAR)
