"""retrieval=clip_onnx on a tiny CLIP-signature model the test builds: preprocessing, ranking, errors."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import Camera
from psdr_room_core.method.objects import ObjectQuery
from psdr_room_plugins.onnx_models.clip import ClipRetrieval, clip_input

COLOURS = {"red_sofa": (200, 30, 30), "green_chair": (30, 180, 40), "blue_bed": (40, 50, 210)}


def tiny_clip(path: Path, output: str = "image_embeds") -> Path:
    """pixel_values [N,3,224,224] → mean colour per channel → a fixed 3→4 linear map: [N,4] (CLIP's signature)."""
    weight = numpy_helper.from_array(np.array([[1, 0, 0, 0.5], [0, 1, 0, 0.5], [0, 0, 1, 0.5]], np.float32), "w")
    graph = helper.make_graph(
        [
            helper.make_node("GlobalAveragePool", ["pixel_values"], ["pooled"]),
            helper.make_node("Flatten", ["pooled"], ["flat"], axis=1),
            helper.make_node("MatMul", ["flat", "w"], [output]),
        ],
        "tiny_clip",
        [helper.make_tensor_value_info("pixel_values", TensorProto.FLOAT, ["batch", 3, 224, 224])],
        [helper.make_tensor_value_info(output, TensorProto.FLOAT, ["batch", 4])],
        initializer=[weight],
    )
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)]), path)
    return path


@dataclass(frozen=True)
class Record:
    id: str
    category: str


class ColourDatabase:
    """Three models whose thumbnails are views of one flat colour each (the database interface only)."""

    records = [Record(name, name.split("_")[1]) for name in COLOURS]

    def category(self, name: str) -> list[Record]:
        return [r for r in self.records if r.category == name]

    def thumbnails(self, model_id: str) -> list[np.ndarray]:
        base = np.full((96, 96, 3), COLOURS[model_id], np.uint8)
        return [base, (base * 0.8).astype(np.uint8)]


def retrieval(model: Path, tmp_path: Path) -> ClipRetrieval:
    impl = ClipRetrieval(
        model=None, path=str(model), family="clip_vit_b32_image", intra_op_threads=1, cache_dir=str(tmp_path / "cache")
    )
    impl._db = ColourDatabase()
    return impl


def query(colour: tuple[int, int, int], category: str | None = None) -> ObjectQuery:
    crop = np.full((60, 120, 3), colour, np.uint8)
    crop[:, :10] = 255  # some background context
    return ObjectQuery(
        1, "thing", (category,) if category else (), np.ones((4, 4), bool), np.zeros((1, 3)), crop, np.zeros((1, 3))
    )


def test_clip_input_is_a_centre_crop_with_clip_statistics() -> None:
    rgb8 = np.zeros((100, 300, 3), np.uint8)
    rgb8[:, 130:170] = 255  # a white stripe in the middle of the centre crop
    x = clip_input(rgb8)
    assert x.shape == (1, 3, 224, 224) and x.dtype == np.float32
    white = (1.0 - 0.48145466) / 0.26862954
    assert x[0, 0, 112, 112] == pytest.approx(white, abs=1e-3)
    assert x[0, 0, 112, 5] == pytest.approx(-0.48145466 / 0.26862954, abs=1e-3)  # the crop keeps black sides


def test_ranks_the_matching_model_first_and_caches_thumbnail_embeddings(tmp_path: Path) -> None:
    impl = retrieval(tiny_clip(tmp_path / "clip.onnx"), tmp_path)
    camera, c2w = Camera.from_vfov(32, 24, 50.0), np.eye(4)
    for name, colour in COLOURS.items():
        ranked = impl.rank(query(colour), camera, c2w, k=3)
        assert ranked[0].model_id == name and ranked[0].score > ranked[1].score
    assert len(list((tmp_path / "cache" / "clip").glob("*.npz"))) == 1
    again = retrieval(tmp_path / "clip.onnx", tmp_path)

    def no_network(images: list) -> np.ndarray:
        raise AssertionError("thumbnail embeddings should come from the cache")

    again.embed = no_network
    cached = again._thumbnail_embeddings(list(COLOURS))
    assert set(cached) == set(COLOURS) and all(v.shape == (2, 4) for v in cached.values())


def test_category_filter(tmp_path: Path) -> None:
    impl = retrieval(tiny_clip(tmp_path / "clip.onnx"), tmp_path)
    impl.category_filter = True
    ranked = impl.rank(query(COLOURS["red_sofa"], category="chair"), Camera.from_vfov(32, 24, 50.0), np.eye(4), k=3)
    assert [c.model_id for c in ranked] == ["green_chair"]


def test_wrong_signature_and_missing_file_are_one_line_errors(tmp_path: Path) -> None:
    impl = retrieval(tiny_clip(tmp_path / "other.onnx", output="logits"), tmp_path)
    with pytest.raises(PsdrRoomError, match=r"other\.onnx: the ONNX signature does not fit.*image_embeds"):
        impl.embed([np.zeros((8, 8, 3), np.uint8)])
    missing = ClipRetrieval(model="clip_vit_b32_image", models_dir=str(tmp_path / "none"))
    assert "weights not installed" in missing.unavailable(Path("photo.jpg"))
