"""``detector`` implementations: NanoDet decoding on a hand-built graph, boxes files, the bundled model.

The decoding tests run a tiny ONNX graph with the bundled model's signature (``image [1,3,416,416]`` →
``cls_pred_stride_{8,16,32} [1,cells,80]`` + ``dis_pred_stride_{8,16,32} [1,cells,44]``) whose outputs are
constants written so that known boxes must come out: bin logits with equal values on two bins put a
side's expectation halfway between them, cells sit at known grid positions, one box is a lower-scored
duplicate NMS must remove, others test the threshold, the class filter, clipping and the mapping to a
non-square working image.
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import onnx
import pytest
from omegaconf import OmegaConf
from onnx import TensorProto, helper, numpy_helper

from conftest import REPO, SHARED_DATA
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.registry import Registry
from psdr_room_core.method.artifacts import Image
from psdr_room_core.method.image_boxes import box_iou
from psdr_room_core.method.photo import read_photo, resize_to_working
from psdr_room_core.method.plugin import register_capabilities
from psdr_room_plugins.detectors import BoxesFile, NanodetOnnx, NoDetector, register_implementations
from psdr_room_plugins.detectors.coco import COCO_80, INDOOR
from psdr_room_plugins.detectors.nanodet import BUNDLED, to_input

PHOTO = Path("photo.jpg")
SIZE = 416
GRIDS = {8: 52, 16: 26, 32: 13}
BINS = 11
WORKING = (832, 624)  # width, height: x scale 2, y scale 1.5 from the 416x416 input


def one_line(exc: pytest.ExceptionInfo, *parts: str) -> None:
    message = str(exc.value)
    assert "\n" not in message
    for part in parts:
        assert part in message, message


# ============================================================================ NanoDet decoding
def side_logits(bins: tuple[float, ...]) -> np.ndarray:
    """Logits whose softmax is uniform over ``bins`` (integers) and ~0 elsewhere: expectation = their mean."""
    logits = np.full(BINS, -40.0, np.float32)
    logits[list(map(int, bins))] = 5.0
    return logits


def nanodet_graph(
    path: Path, objects: list[tuple[int, int, int, int, float, tuple]], signature: str = "nanodet"
) -> Path:
    """A graph returning constant NanoDet outputs: ``objects`` are (stride, column, row, class, score,
    (left, top, right, bottom) bins); ``signature="wrong"`` gives a classifier-like single output."""
    image = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, SIZE, SIZE])
    values: dict[str, np.ndarray] = {}
    for stride, grid in GRIDS.items():
        values[f"cls_pred_stride_{stride}"] = np.zeros((1, grid * grid, 80), np.float32)
        values[f"dis_pred_stride_{stride}"] = np.tile(side_logits((0,)), (1, grid * grid, 4))
    for stride, col, row, cls, score, sides in objects:
        cell = row * GRIDS[stride] + col
        values[f"cls_pred_stride_{stride}"][0, cell, cls] = score
        values[f"dis_pred_stride_{stride}"][0, cell] = np.concatenate([side_logits(s) for s in sides])
    if signature == "wrong":
        values = {"logits": np.zeros((1, 1000), np.float32)}
    # out = constant + 0 * mean(image): the outputs depend on the input, as a real network's do
    nodes = [
        helper.make_node("ReduceMean", ["image"], ["mean"], keepdims=0),
        helper.make_node("Mul", ["mean", "zero"], ["nothing"]),
    ]
    inits = [numpy_helper.from_array(np.zeros((), np.float32), "zero")]
    outputs = []
    for name, value in values.items():
        inits.append(numpy_helper.from_array(value, f"{name}_value"))
        nodes.append(helper.make_node("Add", [f"{name}_value", "nothing"], [name]))
        outputs.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, list(value.shape)))
    model = helper.make_model(
        helper.make_graph(nodes, "nanodet_like", [image], outputs, inits), opset_imports=[helper.make_opsetid("", 13)]
    )
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


# stride, column, row, class, score, (left, top, right, bottom) bins
CHAIR = (8, 10, 20, COCO_80.index("chair"), 0.9, ((2, 3), (1,), (4, 6), (0, 1, 2)))
# centre (84, 164); sides 2.5, 1, 5, 1 bins x 8 → (64, 156, 124, 172) in the input
CHAIR_AS_TV = (8, 10, 20, COCO_80.index("tv"), 0.7, CHAIR[5])  # same box, another class: kept
CHAIR_DUPLICATE = (16, 5, 10, COCO_80.index("chair"), 0.6, ((1, 2), (0, 1), (2, 3), (0, 1)))
# centre (88, 168); sides 1.5, 0.5, 2.5, 0.5 bins x 16 → (64, 160, 128, 176): IoU 0.57 with the chair
COUCH = (32, 3, 5, COCO_80.index("couch"), 0.8, ((2,), (2,), (2,), (2,)))
# centre (112, 176) ± 64 → (48, 112, 176, 240)
CLOCK_AT_CORNER = (32, 0, 0, COCO_80.index("clock"), 0.5, ((2,), (0, 1), (1,), (1,)))
# centre (16, 16); sides 64, 16, 32, 32 → (-48, 0, 48, 48): clipped at x = 0
FAINT_BED = (8, 40, 40, COCO_80.index("bed"), 0.25, ((1,), (1,), (1,), (1,)))  # below the 0.3 threshold
PERSON = (16, 20, 20, COCO_80.index("person"), 0.95, ((1,), (1,), (1,), (1,)))  # not an indoor class


def to_working(box: tuple[float, ...]) -> tuple[float, ...]:
    sx, sy = WORKING[0] / SIZE, WORKING[1] / SIZE
    return (box[0] * sx, box[1] * sy, box[2] * sx, box[3] * sy)


@pytest.fixture(scope="module")
def fake_nanodet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("nanodet") / "fake_nanodet.onnx"
    return nanodet_graph(path, [CHAIR, CHAIR_AS_TV, CHAIR_DUPLICATE, COUCH, CLOCK_AT_CORNER, FAINT_BED, PERSON])


def working_image() -> Image:
    return Image(rgb=np.full((WORKING[1], WORKING[0], 3), 0.5, np.float32), original_size=WORKING)


def run(path: Path, **params: object) -> list[tuple[str, tuple[float, ...], float]]:
    """The fake network's detections at threshold 0.3 without the mirrored run, unless ``params`` say otherwise."""
    params = {"score_threshold": 0.3, "flip": False, **params}
    detections = NanodetOnnx(path=str(path), intra_op_threads=1, **params).detect(working_image(), PHOTO)
    assert all(d.category == "object" for d in detections.items)
    return [(d.label, d.box, d.score) for d in detections.items]


def test_decoding_gives_the_constructed_boxes(fake_nanodet: Path) -> None:
    found = run(fake_nanodet)
    assert [label for label, _, _ in found] == ["chair", "couch", "tv", "clock"]  # best first
    assert [score for _, _, score in found] == pytest.approx([0.9, 0.8, 0.7, 0.5])
    boxes = {label: box for label, box, _ in found}
    assert boxes["chair"] == pytest.approx(to_working((64, 156, 124, 172)), abs=1e-3)
    assert boxes["tv"] == pytest.approx(boxes["chair"])  # class-wise NMS: the tv on the chair stays
    assert boxes["couch"] == pytest.approx(to_working((48, 112, 176, 240)), abs=1e-3)
    assert boxes["clock"] == pytest.approx((0.0, 0.0, 48 * 2.0, 48 * 1.5), abs=1e-3)  # clipped to the image


def test_flip_adds_the_boxes_of_the_mirrored_photo(fake_nanodet: Path) -> None:
    """The fake network answers the same boxes whatever the input, so the mirrored run's boxes come back
    mirrored: each box and its mirror image, merged by class-wise NMS where they overlap."""
    plain = {(label, box) for label, box, _ in run(fake_nanodet)}
    flipped = run(fake_nanodet, flip=True)
    chair = next(box for label, box in plain if label == "chair")
    mirrored = (WORKING[0] - chair[2], chair[1], WORKING[0] - chair[0], chair[3])
    assert plain <= {(label, box) for label, box, _ in flipped}
    assert any(label == "chair" and box == pytest.approx(mirrored, abs=1e-3) for label, box, _ in flipped)
    scores = [score for _, _, score in flipped]
    assert scores == sorted(scores, reverse=True)


def test_decoding_parameters(fake_nanodet: Path) -> None:
    assert [label for label, _, _ in run(fake_nanodet, nms_iou=0.6)].count("chair") == 2  # duplicate kept
    assert "bed" in [label for label, _, _ in run(fake_nanodet, score_threshold=0.2)]
    assert [label for label, _, _ in run(fake_nanodet, classes=None)][0] == "person"
    assert [label for label, _, _ in run(fake_nanodet, classes=["couch"])] == ["couch"]
    assert [label for label, _, _ in run(fake_nanodet, max_detections=2)] == ["chair", "couch"]
    assert run(fake_nanodet, score_threshold=0.99) == []


def test_unknown_class_names_the_setting_and_a_close_match() -> None:
    with pytest.raises(PsdrRoomError) as exc:
        NanodetOnnx(classes=["chair", "sofa", "tvv"])
    one_line(exc, "detector.nanodet_onnx.classes", "'sofa' is not a COCO class")
    with pytest.raises(PsdrRoomError, match="did you mean 'tv'"):
        NanodetOnnx(classes=["tvv"])


def test_input_is_stretched_bgr_and_normalised() -> None:
    rgb = np.zeros((30, 60, 3), np.float32)
    rgb[:, :30] = (0.2, 0.4, 0.6)
    x = to_input(rgb, (SIZE, SIZE))
    assert x.shape == (1, 3, SIZE, SIZE) and x.dtype == np.float32
    bgr = np.array([0.6, 0.4, 0.2]) * 255.0
    expected = (bgr - (103.53, 116.28, 123.675)) / (57.375, 57.12, 58.395)
    assert x[0, :, 200, 10] == pytest.approx(expected, abs=1e-4)  # left half of the stretched input
    assert x[0, :, 200, 400] == pytest.approx(-np.array((103.53, 116.28, 123.675)) / (57.375, 57.12, 58.395), abs=1e-4)


def test_wrong_signature_corrupt_and_missing_models(tmp_path: Path) -> None:
    wrong = nanodet_graph(tmp_path / "classifier.onnx", [], signature="wrong")
    corrupt = tmp_path / "corrupt.onnx"
    corrupt.write_bytes(b"\x08\x07 this is not a protobuf")
    missing = tmp_path / "missing.onnx"
    for path, problem in (
        (wrong, "not a NanoDet-style detector"),
        (corrupt, "not a loadable ONNX model"),
        (missing, "no such model file"),
    ):
        detector = NanodetOnnx(path=str(path), intra_op_threads=1)
        with pytest.raises(PsdrRoomError) as exc:
            detector.detect(working_image(), PHOTO)
        one_line(exc, str(path), problem, "detector.nanodet_onnx.path")
        reason = detector.unavailable(PHOTO)
        assert reason is not None and str(path) in reason and problem in reason
        assert detector.external_files(PHOTO) == [path]


# ============================================================================ boxes_file
def photo_with_boxes(tmp_path: Path, text: str) -> Path:
    photo = tmp_path / "room.jpg"
    (tmp_path / "room.boxes.yaml").write_text(text)
    return photo


def half_size_image() -> Image:
    """The working image of a 1000x800 photo (after EXIF orientation), resized to 500x400."""
    return Image(rgb=np.zeros((400, 500, 3), np.float32), original_size=(1000, 800))


def test_boxes_file_scales_photo_pixels_to_the_working_image(tmp_path: Path) -> None:
    photo = photo_with_boxes(
        tmp_path,
        "boxes:\n"
        "  - {label: sofa, category: object, box: [100, 200, 300, 400]}\n"
        "  - {label: floor lamp, category: lamp, box: [0, 0, 1000, 800.0]}\n"
        "  - {label: vase, box: [10, 20, 30, 40]}\n",
    )
    detector = BoxesFile()
    assert detector.unavailable(photo) is None
    assert detector.external_files(photo) == [tmp_path / "room.boxes.yaml"]
    detections = detector.detect(half_size_image(), photo)
    assert [(d.label, d.category, d.box, d.score) for d in detections.items] == [
        ("sofa", "object", (50.0, 100.0, 150.0, 200.0), 1.0),
        ("floor lamp", "lamp", (0.0, 0.0, 500.0, 400.0), 1.0),
        ("vase", "object", (5.0, 10.0, 15.0, 20.0), 1.0),
    ]
    assert detections.source == str(tmp_path / "room.boxes.yaml")


def test_boxes_file_path_parameter_and_missing_file(tmp_path: Path) -> None:
    elsewhere = tmp_path / "mine.yaml"
    elsewhere.write_text("boxes: []\n")
    photo = tmp_path / "room.jpg"
    assert BoxesFile(path=str(elsewhere)).detect(half_size_image(), photo).items == []
    assert BoxesFile(path=str(elsewhere)).external_files(photo) == [elsewhere]
    reason = BoxesFile().unavailable(photo)
    assert reason is not None and "room.boxes.yaml" in reason
    with pytest.raises(PsdrRoomError) as exc:
        BoxesFile().detect(half_size_image(), photo)
    one_line(exc, str(tmp_path / "room.boxes.yaml"), "no such boxes file")


@pytest.mark.parametrize(
    "text, parts",
    [
        ("boxes: [{label: sofa, box: [1, 2, 3, 4]}\n", ("not valid YAML", "line")),
        ("- {label: sofa, box: [1, 2, 3, 4]}\n", ("expected a single key 'boxes'",)),
        ("boxes: {label: sofa}\n", ("expected a single key 'boxes'",)),
        ("boxes: []\nscale: 2\n", ("expected a single key 'boxes'",)),
        ("boxes: [[1, 2, 3, 4]]\n", ("boxes[0] is not a mapping",)),
        (
            "boxes: [{label: a, box: [1, 2, 3, 4]}, {label: b, bbox: [1, 2, 3, 4]}]\n",
            ("boxes[1] has unknown key(s) bbox",),
        ),
        ("boxes: [{box: [1, 2, 3, 4]}]\n", ("boxes[0].label is missing",)),
        (
            "boxes: [{label: sofa, category: furniture, box: [1, 2, 3, 4]}]\n",
            ("boxes[0].category 'furniture' is unknown", "wall, floor, ceiling, window, door, lamp, object"),
        ),
        ("boxes: [{label: sofa, box: [1, 2, 3]}]\n", ("boxes[0].box [1, 2, 3] is not four numbers",)),
        ("boxes: [{label: sofa, box: [1, 2, true, 4]}]\n", ("boxes[0].box", "not four numbers")),
        ("boxes: [{label: sofa, box: '1 2 3 4'}]\n", ("boxes[0].box", "not four numbers")),
        ("boxes: [{label: sofa, box: [300, 200, 100, 400]}]\n", ("boxes[0].box [300, 200, 100, 400] is inverted",)),
        ("boxes: [{label: sofa, box: [100, 400, 300, 400]}]\n", ("is inverted or empty",)),
        ("boxes: [{label: sofa, box: [100, 200, 1001, 400]}]\n", ("is outside the 1000x800 photo", "EXIF")),
        ("boxes: [{label: sofa, box: [-1, 200, 300, 400]}]\n", ("is outside the 1000x800 photo",)),
    ],
)
def test_boxes_file_errors_name_the_file_the_entry_and_the_fix(
    tmp_path: Path, text: str, parts: tuple[str, ...]
) -> None:
    photo = photo_with_boxes(tmp_path, text)
    with pytest.raises(PsdrRoomError) as exc:
        BoxesFile().detect(half_size_image(), photo)
    one_line(exc, str(tmp_path / "room.boxes.yaml"), *parts)


# ============================================================================ registration and config
def test_registered_through_the_entry_point_with_config_files_that_construct() -> None:
    assert any(ep.value == "psdr_room_plugins.detectors" for ep in importlib.metadata.entry_points(group="psdr_room"))
    registry = Registry()
    register_capabilities(registry)  # the method declares the capability, then the plugin implements it
    register_implementations(registry)
    names = {name for capability, name in registry.implementations if capability == "detector"}
    assert names == {"nanodet_onnx", "boxes_file", "none"}
    for name in names:
        cfg = OmegaConf.to_container(OmegaConf.load(REPO / "conf" / "detector" / f"{name}.yaml"))
        assert cfg["impl"] == name
        implementation = registry.implementation("detector", name)
        assert implementation.version and implementation.description
        instance = implementation.factory(**cfg[name])
        if name == "nanodet_onnx":
            assert instance.path == BUNDLED and [COCO_80[i] for i in instance.class_ids] == list(INDOOR)
    assert NoDetector().detect(working_image(), PHOTO).items == []


# ============================================================================ the bundled model
def test_bundled_nanodet_finds_the_chairs_of_a_real_photo() -> None:
    photo = SHARED_DATA / "photos" / "sunrgbd_total3d_02" / "img.jpg"
    if not photo.is_file():
        pytest.skip(f"{photo} is not here")
    rgb = read_photo(photo, 10**8)
    image = Image(rgb=resize_to_working(rgb, 800), original_size=(rgb.shape[1], rgb.shape[0]))
    detector = NanodetOnnx(intra_op_threads=1, score_threshold=0.3, flip=False)
    assert detector.unavailable(photo) is None and detector.external_files(photo) == [BUNDLED]
    detections = detector.detect(image, photo)
    chairs = np.array([d.box for d in detections.items if d.label == "chair"])
    # the white chair in front of the table, in the reference boxes of SUN RGB-D: [198, 263, 401, 528]
    assert len(chairs) and box_iou(np.array([198.0, 263, 401, 528]), chairs).max() > 0.5
    assert all(
        0 <= d.box[0] < d.box[2] <= image.width and 0 <= d.box[1] < d.box[3] <= image.height for d in detections.items
    )
    assert {d.label for d in detections.items} <= set(INDOOR)
    scores = [d.score for d in detections.items]
    assert scores == sorted(scores, reverse=True) and min(scores) >= 0.3
