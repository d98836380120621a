"""``depth=onnx`` and ``segmentation=onnx`` on tiny ONNX graphs built here with the real models' signatures.

No real weights can be downloaded here, so each family gets a graph with the same inputs and outputs
(``pixel_values [N,3,H,W]`` → ``predicted_depth [N,H,W]``, ``logits [N,150,H/4,W/4]``, ``class_queries_logits
[N,Q,151]`` + ``masks_queries_logits [N,Q,H/4,W/4]``) whose output is known from its input: the depth graphs
undo the family's normalisation and return the red channel as disparity, the segmentation graphs classify
each pixel by its nearest reference colour. Everything between the photo and the artifact (resizing,
normalisation, channel order, upsampling, depth normalisation, class → segment → category) is therefore
checked against values computed by hand.
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import pytest
from onnx import TensorProto, helper, numpy_helper

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import Camera, DepthMap, Detections, Image, Panoptic
from psdr_room_plugins.onnx_models import ade20k
from psdr_room_plugins.onnx_models.depth import OnnxDepth, disparity_to_depth
from psdr_room_plugins.onnx_models.network import INPUTS, network_size, to_network
from psdr_room_plugins.onnx_models.segmentation import OnnxSegmentation, class_map, panoptic_from_classes

PHOTO = Path("photo.jpg")  # only named in external_files / errors; the implementations never read it
NO_PANOPTIC = Panoptic(ids=np.zeros((1, 1), np.int32), segments=[])  # the networks ignore these inputs
NO_CAMERA = Camera.from_vfov(1, 1, 50.0)
NO_DETECTIONS = Detections(items=[])


# ============================================================================ graph builders (onnx.helper)
def _image_input(static: tuple[int, int] | None = None, half: bool = False) -> onnx.ValueInfoProto:
    dims = [1, 3, *static] if static else ["N", 3, "H", "W"]
    return helper.make_tensor_value_info("pixel_values", TensorProto.FLOAT16 if half else TensorProto.FLOAT, dims)


def _const(name: str, array: np.ndarray) -> onnx.TensorProto:
    return numpy_helper.from_array(np.asarray(array, np.float32), name)


def _save(path: Path, nodes, inputs, outputs, initializers) -> Path:
    graph = helper.make_graph(nodes, path.stem, inputs, outputs, initializers)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


def _unnormalise(family: str, out: str = "rgb", half: bool = False) -> tuple[list, list]:
    """Nodes turning the normalised input back into sRGB in [0, 1] (x * std + mean)."""
    spec = INPUTS[family]
    inits = [_const("std", np.reshape(spec.std, (1, 3, 1, 1))), _const("mean", np.reshape(spec.mean, (1, 3, 1, 1)))]
    source = "pixel_values"
    nodes = []
    if half:
        nodes.append(helper.make_node("Cast", ["pixel_values"], ["pixel_values32"], to=TensorProto.FLOAT))
        source = "pixel_values32"
    nodes += [helper.make_node("Mul", [source, "std"], ["scaled"]), helper.make_node("Add", ["scaled", "mean"], [out])]
    return nodes, inits


def red_disparity_model(
    path: Path,
    family: str,
    static: tuple[int, int] | None = None,
    output_channels_dim: bool = False,
    half: bool = False,
) -> Path:
    """A depth graph whose disparity is the photo's red channel (after undoing the normalisation);
    ``half``: float16 input, like the ``model_fp16.onnx`` exports."""
    nodes, inits = _unnormalise(family, half=half)
    inits += [numpy_helper.from_array(np.array(v, np.int64), n) for n, v in (("s0", [0]), ("s1", [1]), ("ax", [1]))]
    nodes.append(helper.make_node("Slice", ["rgb", "s0", "s1", "ax"], ["red"]))
    if output_channels_dim:
        nodes.append(helper.make_node("Identity", ["red"], ["predicted_depth"]))
        out_dims = [1, 1, *static] if static else ["N", 1, "H", "W"]
    else:
        nodes.append(helper.make_node("Squeeze", ["red", "ax"], ["predicted_depth"]))
        out_dims = [1, *static] if static else ["N", "H", "W"]
    output = helper.make_tensor_value_info("predicted_depth", TensorProto.FLOAT, out_dims)
    return _save(path, nodes, [_image_input(static, half)], [output], inits)


def stats_model(path: Path) -> Path:
    """Per-channel mean and standard deviation of whatever image it is given."""
    nodes = [
        helper.make_node("ReduceMean", ["pixel_values"], ["mean4"], axes=[2, 3], keepdims=1),
        helper.make_node("Sub", ["pixel_values", "mean4"], ["centred"]),
        helper.make_node("Mul", ["centred", "centred"], ["squared"]),
        helper.make_node("ReduceMean", ["squared"], ["var"], axes=[2, 3], keepdims=0),
        helper.make_node("Sqrt", ["var"], ["std"]),
        helper.make_node("ReduceMean", ["pixel_values"], ["mean"], axes=[2, 3], keepdims=0),
    ]
    outputs = [helper.make_tensor_value_info(n, TensorProto.FLOAT, ["N", 3]) for n in ("mean", "std")]
    return _save(path, nodes, [_image_input()], outputs, [])


# Reference colours and the ADE20K class each one stands for (a nearest-colour classifier).
COLOURS = {
    (0.0, 0.0, 0.0): 0,  # black   -> wall
    (0.0, 0.0, 1.0): 5,  # blue    -> ceiling
    (0.0, 1.0, 0.0): 3,  # green   -> floor
    (1.0, 1.0, 1.0): 19,  # white   -> chair
    (1.0, 1.0, 0.0): 8,  # yellow  -> windowpane
    (1.0, 0.0, 1.0): 14,  # magenta -> door
    (0.0, 1.0, 1.0): 36,  # cyan    -> lamp
    (1.0, 0.0, 0.0): 134,  # red     -> sconce
}


def _nearest_colour_scores(weight_rows: int, targets: dict[int, tuple[float, ...]], out: str) -> tuple[list, list]:
    """A 1x1 conv giving 2 c·x - |c|² for class rows with a colour c (argmax = nearest colour), -100 elsewhere."""
    weight = np.zeros((weight_rows, 3, 1, 1), np.float32)
    bias = np.full(weight_rows, -100.0, np.float32)
    for row, colour in targets.items():
        weight[row, :, 0, 0] = 2.0 * np.asarray(colour)
        bias[row] = -float(np.dot(colour, colour))
    return [helper.make_node("Conv", ["rgb", "w", "b"], [out])], [_const("w", weight), _const("b", bias)]


def segformer_model(path: Path, n_classes: int = 150, static: tuple[int, int] | None = None) -> Path:
    nodes, inits = _unnormalise("segformer_ade20k")
    conv, conv_inits = _nearest_colour_scores(n_classes, {k: c for c, k in COLOURS.items() if k < n_classes}, "full")
    nodes += conv + [helper.make_node("AveragePool", ["full"], ["logits"], kernel_shape=[4, 4], strides=[4, 4])]
    out_dims = [1, n_classes, static[0] // 4, static[1] // 4] if static else ["N", n_classes, "h", "w"]
    output = helper.make_tensor_value_info("logits", TensorProto.FLOAT, out_dims)
    return _save(path, nodes, [_image_input(static)], [output], inits + conv_inits)


def mask_classification_model(path: Path, n_classes: int = 150, pixel_mask: bool = True) -> Path:
    """Mask2Former-style outputs: one query per reference colour, labelled with its class, whose mask is
    where the pixel has that colour."""
    queries = list(COLOURS.items())
    nodes, inits = _unnormalise("mask2former_ade20k")
    conv, conv_inits = _nearest_colour_scores(len(queries), dict(enumerate(c for c, _ in queries)), "dot")
    nodes += conv + [
        helper.make_node("ReduceSumSquare", ["rgb"], ["x2"], axes=[1], keepdims=1),
        helper.make_node("Sub", ["dot", "x2"], ["neg_dist2"]),  # -|x - c|²
        helper.make_node("Add", ["neg_dist2", "radius"], ["inside"]),  # > 0 within 0.3 of the colour
        helper.make_node("Mul", ["inside", "sharp"], ["mask_full"]),
        helper.make_node("AveragePool", ["mask_full"], ["masks_queries_logits"], kernel_shape=[4, 4], strides=[4, 4]),
    ]
    classes = np.zeros((1, len(queries), n_classes + 1), np.float32)
    for q, (_, k) in enumerate(queries):
        if k < n_classes:
            classes[0, q, k] = 12.0
    nodes.append(helper.make_node("Constant", [], ["class_queries_logits"], value=_const("cls", classes)))
    inits += conv_inits + [_const("radius", np.array(0.09)), _const("sharp", np.array(40.0))]
    inputs = [_image_input()]
    if pixel_mask:
        inputs.append(helper.make_tensor_value_info("pixel_mask", TensorProto.INT64, ["N", "H", "W"]))
    outputs = [
        helper.make_tensor_value_info("class_queries_logits", TensorProto.FLOAT, [1, len(queries), n_classes + 1]),
        helper.make_tensor_value_info("masks_queries_logits", TensorProto.FLOAT, ["N", len(queries), "h", "w"]),
    ]
    return _save(path, nodes, inputs, outputs, inits)


# ==================================================================================== photos
def ramp_photo(height: int = 23, width: int = 37, seed: int = 0) -> Image:
    """Red rises from 0.2 (left) to 1.0 (right); green and blue are noise; a red-free block at the top left."""
    rng = np.random.default_rng(seed)
    rgb = rng.uniform(0.0, 1.0, (height, width, 3)).astype(np.float32)
    rgb[..., 0] = np.linspace(0.2, 1.0, width, dtype=np.float32)[None, :]
    rgb[:8, :10, 0] = 0.0
    return Image(rgb=rgb, source="ramp", original_size=(width, height))


def colour_photo(height: int = 90, width: int = 121) -> Image:
    """Blue ceiling band, green floor band, black walls, two white chairs, a yellow window, a magenta door,
    a cyan lamp and a red sconce (the colours of :data:`COLOURS`)."""
    rgb = np.zeros((height, width, 3), np.float32)
    rgb[:14] = (0, 0, 1)
    rgb[76:] = (0, 1, 0)
    rgb[30:52, 8:30] = (1, 1, 1)
    rgb[30:52, 48:70] = (1, 1, 1)
    rgb[20:42, 84:110] = (1, 1, 0)
    rgb[48:72, 86:104] = (1, 0, 1)
    rgb[56:70, 34:44] = (0, 1, 1)
    rgb[18:26, 36:44] = (1, 0, 0)
    return Image(rgb=rgb, source="colours", original_size=(width, height))


def camera_for(image: Image) -> Camera:
    return Camera.from_vfov(image.width, image.height, 50.0)


def expected_ramp_depth(image: Image) -> tuple[np.ndarray, np.ndarray]:
    red = image.rgb[..., 0].astype(np.float64)
    valid = red > 0
    depth = np.where(valid, 1.0 / np.where(valid, red, 1.0), 0.0)
    return depth / depth[valid].max(), valid


def one_line(excinfo: pytest.ExceptionInfo, path: Path, *phrases: str) -> str:
    msg = str(excinfo.value)
    assert "\n" not in msg and str(path) in msg, msg
    for phrase in phrases:
        assert phrase in msg, msg
    return msg


# =================================================================================== input layout
@pytest.mark.parametrize(
    ("family", "hw", "expected"),
    [
        ("depth_anything_v2", (23, 37), (518, 840)),  # shorter side 518, both multiples of 14
        ("depth_anything_v2", (480, 640), (518, 686)),
        ("depth_anything_v2", (641, 479), (700, 518)),  # portrait
        ("dpt", (480, 640), (384, 512)),
        ("midas", (480, 640), (256, 256)),
        ("segformer_ade20k", (23, 37), (512, 512)),
        ("mask2former_ade20k", (480, 640), (512, 672)),
    ],
)
def test_network_size_per_family(family: str, hw: tuple[int, int], expected: tuple[int, int]) -> None:
    spec = INPUTS[family]
    got = network_size(*hw, spec)
    assert got == expected and got[0] % spec.multiple == 0 and got[1] % spec.multiple == 0
    if spec.keep_aspect:
        assert abs(got[1] / got[0] - hw[1] / hw[0]) < 0.05
    assert network_size(*hw, spec, size=140) != got
    assert network_size(*hw, spec, fixed=(256, 320)) == (256, 320)  # a fixed-size graph gets its own size


@pytest.mark.parametrize("family", sorted(INPUTS))
def test_normalisation_proved_by_a_statistics_model(tmp_path: Path, family: str) -> None:
    """A graph returning its input's per-channel mean/std sees exactly (colour - mean) / std, in RGB order."""
    session = ort.InferenceSession(str(stats_model(tmp_path / "stats.onnx")), providers=["CPUExecutionProvider"])
    spec = INPUTS[family]
    colour = np.array([0.3, 0.6, 0.9], np.float32)
    rgb = np.broadcast_to(colour, (31, 47, 3)).copy()
    pixel_values = to_network(rgb, spec, network_size(31, 47, spec, size=64))
    assert pixel_values.dtype == np.float32 and pixel_values.shape[:2] == (1, 3)
    mean, std = session.run(None, {"pixel_values": pixel_values})
    np.testing.assert_allclose(mean[0], (colour - spec.mean) / spec.std, atol=1e-5)
    np.testing.assert_allclose(std[0], 0.0, atol=1e-4)


# ========================================================================================= depth
def test_disparity_to_depth_is_unit_range_inverse() -> None:
    disparity = np.array([[4.0, 2.0], [1.0, 0.0]])
    depth, valid = disparity_to_depth(disparity, eps=1e-3)
    np.testing.assert_array_equal(valid, [[True, True], [True, False]])
    np.testing.assert_allclose(depth, [[0.25, 0.5], [1.0, 0.0]])  # 1/d, farthest = 1
    depth, valid = disparity_to_depth(np.array([[4.0, 0.003], [np.nan, -1.0]]), eps=1e-3)
    assert valid.tolist() == [[True, False], [False, False]] and depth[0, 0] == 1.0


@pytest.mark.parametrize(
    ("family", "static", "channel_dim", "half"),
    [
        ("depth_anything_v2", None, False, False),
        ("depth_anything_v2", None, False, True),  # a float16 export
        ("dpt", None, True, False),
        ("midas", (256, 256), False, False),  # a fixed-size export: the photo is squashed to it and back
    ],
)
def test_depth_end_to_end_on_a_non_square_odd_photo(
    tmp_path: Path, family: str, static, channel_dim: bool, half: bool
) -> None:
    path = red_disparity_model(tmp_path / f"{family}.onnx", family, static, channel_dim, half)
    image = ramp_photo()
    impl = OnnxDepth(model=None, path=str(path), family=family, intra_op_threads=1)
    assert impl.external_files(PHOTO) == [path]  # the weights are part of the cache key
    depth = impl.estimate(image, camera_for(image), NO_PANOPTIC, PHOTO)
    assert isinstance(depth, DepthMap) and not depth.metric and depth.source.startswith("onnx:")
    assert depth.depth.shape == (23, 37) and depth.depth.dtype == np.float32 and depth.valid.shape == (23, 37)
    expected, expected_valid = expected_ramp_depth(image)
    away = np.zeros_like(expected_valid)  # inside the photo and clear of the red-free block's blurred edge
    away[1:-1, 1:-1] = True
    away[:11, :13] = False
    assert not depth.valid[1:6, 1:7].any()  # the red-free block is invalid
    assert depth.valid[away].all()
    assert depth.depth[depth.valid].max() == pytest.approx(1.0)  # unit range
    # the same depth up to scale where the ramp is sharp (the block's blurred edge may hold the farthest pixel)
    np.testing.assert_allclose(
        depth.depth[away] / depth.depth[away].max(), expected[away] / expected[away].max(), rtol=0.06
    )
    # depth falls from left to right (red rises): the ramp's orientation survived the round trip
    row = depth.depth[15]
    assert row[12] > row[20] > row[30]


def test_depth_wrong_signature_is_one_line_naming_the_file(tmp_path: Path) -> None:
    image = ramp_photo()
    seg = segformer_model(tmp_path / "looks_like_segformer.onnx")
    with pytest.raises(PsdrRoomError) as excinfo:
        OnnxDepth(model=None, path=str(seg), family="depth_anything_v2").estimate(
            image, camera_for(image), NO_PANOPTIC, PHOTO
        )
    one_line(excinfo, seg, "signature", "depth_anything_v2", "logits[")
    two_inputs = tmp_path / "two_inputs.onnx"
    _save(
        two_inputs,
        [helper.make_node("Add", ["pixel_values", "other"], ["predicted_depth"])],
        [_image_input(), helper.make_tensor_value_info("other", TensorProto.FLOAT, ["N", 3, "H", "W"])],
        [helper.make_tensor_value_info("predicted_depth", TensorProto.FLOAT, ["N", 3, "H", "W"])],
        [],
    )
    with pytest.raises(PsdrRoomError) as excinfo:
        OnnxDepth(model=None, path=str(two_inputs), family="dpt").estimate(image, camera_for(image), NO_PANOPTIC, PHOTO)
    one_line(excinfo, two_inputs, "one float image input")


def test_missing_and_corrupt_registry_models(tmp_path: Path) -> None:
    image = ramp_photo()
    impl = OnnxDepth(model="depth_anything_v2_small", models_dir=str(tmp_path))
    path = tmp_path / "depth_anything_v2_small.onnx"
    assert impl.external_files(PHOTO) == [path]
    with pytest.raises(PsdrRoomError) as excinfo:
        impl.estimate(image, camera_for(image), NO_PANOPTIC, PHOTO)
    one_line(excinfo, path, "not found", "psdr-room-models download depth_anything_v2_small")
    path.write_bytes(b"\x08\x07<!DOCTYPE html> this is a captive portal, not a network" * 50)
    with pytest.raises(PsdrRoomError) as excinfo:
        OnnxDepth(model="depth_anything_v2_small", models_dir=str(tmp_path)).estimate(
            image, camera_for(image), NO_PANOPTIC, PHOTO
        )
    one_line(excinfo, path, "not a loadable ONNX model", "psdr-room-models download depth_anything_v2_small")
    real = red_disparity_model(tmp_path / "real.onnx", "depth_anything_v2").read_bytes()
    path.write_bytes(real[: len(real) // 2])  # an interrupted copy
    with pytest.raises(PsdrRoomError) as excinfo:
        OnnxDepth(model="depth_anything_v2_small", models_dir=str(tmp_path)).estimate(
            image, camera_for(image), NO_PANOPTIC, PHOTO
        )
    one_line(excinfo, path, "not a loadable ONNX model")


def test_configuration_errors() -> None:
    image = ramp_photo()
    with pytest.raises(PsdrRoomError, match="unknown depth model 'nope'.*depth_anything_v2_small"):
        OnnxDepth(model="nope").external_files(PHOTO)
    with pytest.raises(PsdrRoomError, match="'segformer_b0_ade20k' is a segmentation model"):
        OnnxDepth(model="segformer_b0_ade20k").external_files(PHOTO)
    with pytest.raises(PsdrRoomError, match="set depth.onnx.family"):
        OnnxDepth(model=None, path="/x/model.onnx").estimate(image, camera_for(image), NO_PANOPTIC, PHOTO)
    with pytest.raises(PsdrRoomError, match="family 'segformer_ade20k' is not a depth family"):
        OnnxDepth(model=None, path="/x/model.onnx", family="segformer_ade20k").external_files(PHOTO)


def test_threads_come_from_config(tmp_path: Path) -> None:
    path = red_disparity_model(tmp_path / "m.onnx", "depth_anything_v2")
    impl = OnnxDepth(
        model=None,
        path=str(path),
        family="depth_anything_v2",
        intra_op_threads=1,
        providers=["NoSuchExecutionProvider", "CPUExecutionProvider"],
    )
    session = impl.network.session
    assert session.get_session_options().intra_op_num_threads == 1
    assert session.get_providers() == ["CPUExecutionProvider"]


# ================================================================================== segmentation
def test_ade20k_table_and_categories() -> None:
    assert len(ade20k.LABELS) == 150 and ade20k.LABELS[0] == "wall" and ade20k.LABELS[149] == "flag"
    by_label = dict(zip(ade20k.LABELS, ade20k.CATEGORIES))
    assert {by_label[k] for k in ("wall", "floor", "ceiling")} == {"wall", "floor", "ceiling"}
    assert by_label["windowpane"] == "window" and by_label["blind"] == "window"
    assert by_label["door"] == "door" and by_label["screen door"] == "door"
    assert {by_label[k] for k in ("lamp", "light", "chandelier", "sconce")} == {"lamp"}
    assert by_label["rug"] == "floor"  # lies flat on it (category_of's rule)
    assert {
        by_label[k]
        for k in (
            "chair",
            "sofa",
            "bed",
            "cabinet",
            "chest of drawers",
            "painting",
            "curtain",
            "television receiver",
            "stairs",
            "fireplace",
        )
    } == {"object"}
    assert {ade20k.LABELS[k] for k in ade20k.STUFF} >= {"wall", "floor", "ceiling", "sky", "rug"}
    assert "chair" not in {ade20k.LABELS[k] for k in ade20k.STUFF}


def test_class_map_matches_full_resolution_argmax() -> None:
    rng = np.random.default_rng(1)
    scores = rng.normal(size=(150, 9, 13)).astype(np.float32) * 0.1
    scores[3, :, :7] += 2.0
    scores[19, :, 7:] += 2.0
    import cv2

    full = np.stack([cv2.resize(s, (51, 35), interpolation=cv2.INTER_LINEAR) for s in scores]).argmax(0)
    got = class_map(scores, (35, 51))
    assert got.shape == (35, 51) and (got == full).mean() > 0.999


def test_panoptic_from_classes_splits_objects_not_stuff() -> None:
    classes = np.zeros((40, 60), np.int32)  # wall
    classes[30:] = 3  # floor
    classes[5:15, 5:15] = 19  # chair 1
    classes[5:15, 30:40] = 19  # chair 2
    classes[0:2, 50:52] = 19  # a 4-pixel speck: left unlabelled
    classes[20:25, 0:5] = 0  # more wall, touching nothing else of class 0? still one segment
    panoptic = panoptic_from_classes(classes, min_fraction=0.002)
    labels = sorted((s.label, s.category) for s in panoptic.segments)
    assert labels == [("chair", "object"), ("chair", "object"), ("floor", "floor"), ("wall", "wall")]
    assert (panoptic.ids[0:2, 50:52] == 0).all()
    chairs = [s.id for s in panoptic.segments if s.label == "chair"]
    assert (
        panoptic.ids[10, 10] in chairs
        and panoptic.ids[10, 35] in chairs
        and panoptic.ids[10, 10] != panoptic.ids[10, 35]
    )


def _check_colour_segmentation(panoptic: Panoptic, image: Image, directory: Path) -> None:
    assert panoptic.ids.shape == (image.height, image.width) and panoptic.ids.dtype == np.int32
    got = sorted((s.label, s.category) for s in panoptic.segments)
    assert got == sorted(
        [
            ("wall", "wall"),
            ("ceiling", "ceiling"),
            ("floor", "floor"),
            ("chair", "object"),
            ("chair", "object"),
            ("windowpane", "window"),
            ("door", "door"),
            ("lamp", "lamp"),
            ("sconce", "lamp"),
        ]
    ), got
    label_at = {s.id: s.label for s in panoptic.segments}
    for (y, x), label in {
        (5, 60): "ceiling",
        (85, 60): "floor",
        (60, 5): "wall",
        (40, 18): "chair",
        (40, 58): "chair",
        (30, 96): "windowpane",
        (60, 94): "door",
        (62, 38): "lamp",
        (21, 40): "sconce",
    }.items():
        assert label_at.get(int(panoptic.ids[y, x])) == label, (y, x, label)
    assert panoptic.ids[40, 18] != panoptic.ids[40, 58]  # two chairs, two segments
    assert panoptic.mask("ceiling")[:12].mean() > 0.97 and panoptic.mask("floor")[78:].mean() > 0.97
    panoptic.save(directory)  # a valid artifact: every id has one segment and every segment pixels
    assert Panoptic.load(directory).segments == panoptic.segments


@pytest.mark.parametrize("static", [None, (128, 128)])
def test_segformer_end_to_end(tmp_path: Path, static) -> None:
    path = segformer_model(tmp_path / "segformer.onnx", static=static)
    image = colour_photo()
    impl = OnnxSegmentation(model=None, path=str(path), family="segformer_ade20k", input_size=256, intra_op_threads=1)
    assert impl.external_files(PHOTO) == [path]
    _check_colour_segmentation(impl.segment(image, NO_CAMERA, NO_DETECTIONS, PHOTO), image, tmp_path)


@pytest.mark.parametrize("pixel_mask", [True, False])
def test_mask2former_end_to_end(tmp_path: Path, pixel_mask: bool) -> None:
    path = mask_classification_model(tmp_path / "mask2former.onnx", pixel_mask=pixel_mask)
    image = colour_photo()
    impl = OnnxSegmentation(model=None, path=str(path), family="mask2former_ade20k", input_size=128)
    _check_colour_segmentation(impl.segment(image, NO_CAMERA, NO_DETECTIONS, PHOTO), image, tmp_path)


def test_segmentation_wrong_class_count_is_one_line(tmp_path: Path) -> None:
    image = colour_photo()
    coco = segformer_model(tmp_path / "segformer_cityscapes.onnx", n_classes=19)
    with pytest.raises(PsdrRoomError) as excinfo:
        OnnxSegmentation(model=None, path=str(coco), family="segformer_ade20k").segment(
            image, NO_CAMERA, NO_DETECTIONS, PHOTO
        )
    one_line(excinfo, coco, "150 ADE20K classes")
    panoptic133 = mask_classification_model(tmp_path / "mask2former_coco.onnx", n_classes=133)
    with pytest.raises(PsdrRoomError) as excinfo:
        OnnxSegmentation(model=None, path=str(panoptic133), family="mask2former_ade20k").segment(
            image, NO_CAMERA, NO_DETECTIONS, PHOTO
        )
    one_line(excinfo, panoptic133, "'no object'")
    depth = red_disparity_model(tmp_path / "depth.onnx", "dpt")
    with pytest.raises(PsdrRoomError) as excinfo:
        OnnxSegmentation(model=None, path=str(depth), family="mask2former_ade20k").segment(
            image, NO_CAMERA, NO_DETECTIONS, PHOTO
        )
    one_line(excinfo, depth, "class_queries_logits")


def test_segmentation_missing_registry_model(tmp_path: Path) -> None:
    impl = OnnxSegmentation(models_dir=str(tmp_path))  # the config's default model
    with pytest.raises(PsdrRoomError) as excinfo:
        impl.segment(colour_photo(), NO_CAMERA, NO_DETECTIONS, PHOTO)
    one_line(excinfo, tmp_path / "segformer_b0_ade20k.onnx", "psdr-room-models download segformer_b0_ade20k")


# ================================================================================ in the pipeline
def _plugins():
    import psdr_room_plugins.onnx_models as onnx_models
    from psdr_room_core.engine.plugins import load_plugins
    from psdr_room_core.engine.registry import Origin

    installed = any(ep.value == onnx_models.__name__ for ep in importlib.metadata.entry_points(group="psdr_room"))
    extra = [] if installed else [(onnx_models, Origin("onnx_models", "tests", "onnx_models (test)"))]
    return load_plugins(extra=extra)


def test_run_with_onnx_models_and_weights_in_the_cache_key(tmp_path: Path) -> None:
    """``depth=onnx segmentation=onnx`` through the real runner; new weights recompute only their stage."""
    import cv2

    from psdr_room_core.engine.cli import compose_config
    from psdr_room_core.engine.run import execute

    photo = tmp_path / "photo.png"
    image = colour_photo()
    cv2.imwrite(str(photo), (image.rgb[..., ::-1] * 255).astype(np.uint8))
    depth_model = red_disparity_model(tmp_path / "depth.onnx", "depth_anything_v2")
    seg_model = segformer_model(tmp_path / "seg.onnx")
    plugins = _plugins()
    overrides = [
        f"image={photo}",
        f"cache_dir={tmp_path / 'cache'}",
        "depth=onnx",
        "segmentation=onnx",
        f"depth.onnx.path={depth_model}",
        "depth.onnx.family=depth_anything_v2",
        "depth.onnx.intra_op_threads=1",
        f"segmentation.onnx.path={seg_model}",
        "segmentation.onnx.family=segformer_ade20k",
        "segmentation.onnx.input_size=128",
        "fov=fixed",
        "run.until=point_cloud",
        "report.enabled=false",
    ]
    record = execute(compose_config(overrides, plugins), tmp_path / "run1", plugins)
    assert record.implementations["depth"]["name"] == "onnx"
    assert record.implementations["segmentation"]["name"] == "onnx"
    labels = {s.label for s in record.artifacts["panoptic"].segments}
    assert {"wall", "ceiling", "floor", "chair", "door"} <= labels
    assert not record.artifacts["depth"].metric
    red_disparity_model(depth_model, "depth_anything_v2", output_channels_dim=True)  # same output, new bytes
    record = execute(compose_config(overrides, plugins), tmp_path / "run2", plugins)
    cached = {r.name: r.cached for r in record.stages}
    assert cached["load_image"] and cached["segment"] and not cached["estimate_depth"]
    assert cached["point_cloud"]  # the new weights give the same depth, so what follows is reused
