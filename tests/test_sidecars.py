"""Sidecar readers: depth files (PNG16 / SUN / EXR / NPY) and segmentations (COCO panoptic / LabelMe)."""

from __future__ import annotations

import base64
import io
import json
from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest
from PIL import Image

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.libraries.sidecar_depth import (
    DEPTH_ENCODINGS,
    SidecarError,
    find_depth_sidecar,
    read_depth,
    read_depth_options,
)
from psdr_room_core.libraries.sidecar_segmentation import (
    category_of,
    find_segmentation_sidecar,
    panoptic_json_for,
    read_coco_panoptic,
    read_labelme,
)
from psdr_room_core.method.artifacts import CATEGORIES, Panoptic, SeenBox, Segment, write_coco_panoptic

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "nyu_basement"
PHOTOS = Path("/work/shared/data/photos")  # the team's shared real RGB-D samples (optional)
needs_photos = pytest.mark.skipif(not PHOTOS.is_dir(), reason="shared photo samples not available")


def one_line_error(excinfo: pytest.ExceptionInfo, path: Path, *phrases: str) -> str:
    """The error is one line, names the file, and contains the given phrases."""
    msg = str(excinfo.value)
    assert "\n" not in msg
    assert path.name in msg, msg
    for phrase in phrases:
        assert phrase in msg, msg
    return msg


# ============================================================================================= depth
def test_example_depth_png16_nyu():
    depth, valid = read_depth(EXAMPLE / "photo.depth.png", **read_depth_options(EXAMPLE / "photo.depth.png"))
    raw = np.array(Image.open(EXAMPLE / "photo.depth.png"))
    assert depth.dtype == np.float32 and valid.dtype == bool and depth.shape == (480, 640)
    np.testing.assert_array_equal(valid, raw > 0)
    np.testing.assert_allclose(depth[valid], raw[valid] / 1000.0, rtol=1e-6)
    assert np.all(depth[~valid] == 0)
    assert 0.70 < valid.mean() < 0.76  # the NYU frame's valid region (Kinect projection)
    d = depth[valid]
    assert d.min() > 0.5 and d.max() < 10.0 and 2.0 < np.median(d) < 5.0


def test_example_depth_options():
    assert read_depth_options(EXAMPLE / "photo.depth.png") == {"encoding": "png16", "scale": 1000.0}
    assert read_depth_options(EXAMPLE / "photo.jpg.nothing") == {}


@needs_photos
def test_sun_rgbd_encoding():
    path = PHOTOS / "sunrgbd_open3d_corridor" / "SUN_depth.png"
    depth, valid = read_depth(path, encoding="sun")
    raw = np.array(Image.open(path)).astype(np.uint32)
    rotated = ((raw >> 3) | (raw << 13)) & 0xFFFF
    np.testing.assert_allclose(depth[valid], rotated[valid] / 1000.0, rtol=1e-6)
    assert 0.78 < valid.mean() < 0.86
    d = depth[valid]
    assert d.min() > 0.5 and d.max() < 10.0 and 1.5 < np.median(d) < 4.0
    # read as plain png16 the same file gives implausible depths (up to ~64 m): SUN needs explicit encoding
    plain, _ = read_depth(path)
    assert plain.max() > 30.0


@needs_photos
def test_tum_scale_5000():
    path = PHOTOS / "tum_open3d_office" / "TUM_depth.png"
    depth, valid = read_depth(path, encoding="png16", scale=5000.0)
    assert 0.77 < valid.mean() < 0.85
    d = depth[valid]
    assert d.min() > 0.5 and d.max() < 10.0 and 1.5 < np.median(d) < 4.0


@needs_photos
def test_nyu_shared_file_matches_example():
    a, va = read_depth(PHOTOS / "nyu_metric3d_00000" / "sync_depth_00000.png")
    b, vb = read_depth(EXAMPLE / "photo.depth.png")
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(va, vb)


def test_npy_depth(tmp_path: Path):
    arr = np.full((4, 5), 2.5, dtype=np.float64)
    arr[0, 0], arr[1, 1], arr[2, 2] = np.nan, -1.0, 0.0
    np.save(tmp_path / "d.npy", arr)
    depth, valid = read_depth(tmp_path / "d.npy", scale=1234.0)  # scale is ignored for npy
    assert depth.dtype == np.float32 and valid.sum() == 17
    assert np.all(depth[valid] == 2.5) and np.all(depth[~valid] == 0)


# ------------------------------------------------------------------------------------------ OpenEXR
def write_exr(path: Path, channels: dict[str, np.ndarray]) -> None:
    """Write named float channels to an OpenEXR file (which stores them sorted by name)."""
    data = np.ascontiguousarray(np.stack(list(channels.values()), axis=-1))
    mi.Bitmap(data, mi.Bitmap.PixelFormat.MultiChannel, list(channels)).write(str(path))


def _depth_field(h: int = 37, w: int = 53) -> np.ndarray:
    yy, xx = np.mgrid[0:h, 0:w]
    d = (1.0 + 0.05 * xx + 0.02 * yy).astype(np.float32)
    d[5:9, 10:30] = 0.0  # flat runs (compress well), holes
    d[0, 0] = np.inf
    return d


@pytest.mark.parametrize("dtype", [np.float32, np.float16])
def test_exr_depth(tmp_path: Path, dtype):
    ref = _depth_field().astype(dtype)
    write_exr(tmp_path / "d.exr", {"Z": ref})
    depth, valid = read_depth(tmp_path / "d.exr")
    expect = ref.astype(np.float32)
    ok = np.isfinite(expect) & (expect > 0)
    np.testing.assert_array_equal(valid, ok)
    np.testing.assert_array_equal(depth[ok], expect[ok])


def test_exr_picks_depth_channel(tmp_path: Path):
    ref = _depth_field()
    other = np.full_like(ref, 7.0)
    write_exr(tmp_path / "d.exr", {"R": other, "G": other, "B": other, "ViewLayer.Depth.Z": ref})
    depth, valid = read_depth(tmp_path / "d.exr")
    np.testing.assert_array_equal(depth[valid], ref[valid])
    write_exr(tmp_path / "rgb.exr", {"R": ref, "G": other, "B": other})
    depth, valid = read_depth(tmp_path / "rgb.exr")
    np.testing.assert_array_equal(depth[valid], ref[valid])


# ----------------------------------------------------------------------------------- depth errors
def test_depth_error_missing(tmp_path: Path):
    with pytest.raises(SidecarError) as e:
        read_depth(tmp_path / "photo.depth.png")
    one_line_error(e, tmp_path / "photo.depth.png", "not found")


def test_depth_error_8bit_rgb(tmp_path: Path):
    path = tmp_path / "photo.depth.png"
    Image.fromarray(np.full((6, 8, 3), 100, np.uint8)).save(path)
    with pytest.raises(SidecarError) as e:
        read_depth(path)
    one_line_error(e, path, "expected a 16-bit single-channel PNG, got 8-bit RGB", "scale=1000")


def test_depth_error_all_invalid(tmp_path: Path):
    path = tmp_path / "photo.depth.png"
    Image.fromarray(np.zeros((6, 8), np.uint16)).save(path)
    with pytest.raises(SidecarError) as e:
        read_depth(path)
    one_line_error(e, path, "invalid")
    np.save(tmp_path / "nan.npy", np.full((3, 3), np.nan, np.float32))
    with pytest.raises(SidecarError) as e:
        read_depth(tmp_path / "nan.npy")
    one_line_error(e, tmp_path / "nan.npy", "invalid")


def test_depth_error_unreadable(tmp_path: Path):
    for name in ("photo.depth.png", "photo.depth.exr", "photo.depth.npy"):
        path = tmp_path / name
        path.write_bytes(b"this is not an image at all")
        with pytest.raises(SidecarError) as e:
            read_depth(path)
        one_line_error(e, path)


def test_depth_error_npy_dtype_and_shape(tmp_path: Path):
    np.save(tmp_path / "i.npy", np.ones((3, 3), np.uint16))
    with pytest.raises(SidecarError) as e:
        read_depth(tmp_path / "i.npy")
    one_line_error(e, tmp_path / "i.npy", "expected a float depth array, got uint16")
    np.save(tmp_path / "c.npy", np.ones((3, 3, 3), np.float32))
    with pytest.raises(SidecarError) as e:
        read_depth(tmp_path / "c.npy")
    one_line_error(e, tmp_path / "c.npy", "2-D")


def test_depth_error_bad_arguments(tmp_path: Path):
    path = tmp_path / "photo.depth.tif"
    path.write_bytes(b"x")
    with pytest.raises(SidecarError) as e:
        read_depth(path)
    one_line_error(e, path, "cannot tell the depth encoding")
    with pytest.raises(SidecarError) as e:
        read_depth(path, encoding="kinect")
    one_line_error(e, path, "unknown depth encoding", ", ".join(DEPTH_ENCODINGS))
    png = tmp_path / "ok.png"
    Image.fromarray(np.ones((2, 2), np.uint16)).save(png)
    with pytest.raises(SidecarError) as e:
        read_depth(png, scale=0)
    one_line_error(e, png, "scale must be a positive number")


def test_depth_error_exr_channels(tmp_path: Path):
    ref = _depth_field()
    path = tmp_path / "two.exr"
    write_exr(path, {"foo": ref, "bar": ref})
    with pytest.raises(SidecarError) as e:
        read_depth(path)
    one_line_error(e, path, "cannot tell which EXR channel", "bar, foo")


def test_depth_options_errors(tmp_path: Path):
    (tmp_path / "p.depth.json").write_text('{"encoding": "png16", "scale": -3}')
    with pytest.raises(SidecarError) as e:
        read_depth_options(tmp_path / "p.depth.png")
    one_line_error(e, tmp_path / "p.depth.json", "positive")
    (tmp_path / "p.depth.json").write_text('{"units": "mm"}')
    with pytest.raises(SidecarError) as e:
        read_depth_options(tmp_path / "p.depth.png")
    one_line_error(e, tmp_path / "p.depth.json", "unknown key")


def test_find_depth_sidecar(tmp_path: Path):
    photo = tmp_path / "room.jpg"
    photo.write_bytes(b"")
    assert find_depth_sidecar(photo) is None
    np.save(tmp_path / "room.depth.npy", np.ones((2, 2), np.float32))
    assert find_depth_sidecar(photo) == tmp_path / "room.depth.npy"
    Image.fromarray(np.ones((2, 2), np.uint16)).save(tmp_path / "room.depth.png")
    assert find_depth_sidecar(photo) == tmp_path / "room.depth.png"
    assert find_depth_sidecar(EXAMPLE / "photo.jpg") == EXAMPLE / "photo.depth.png"


# ====================================================================================== categories
CATEGORY_TABLE = {
    # COCO panoptic
    "wall-brick": "wall",
    "wall-stone": "wall",
    "wall-tile": "wall",
    "wall-wood": "wall",
    "wall-other-merged": "wall",
    "floor-wood": "floor",
    "floor-other-merged": "floor",
    "rug-merged": "floor",
    "ceiling-merged": "ceiling",
    "window-blind": "window",
    "window-other": "window",
    "door-stuff": "door",
    "light": "lamp",
    "mirror-stuff": "object",
    "table-merged": "object",
    "curtain": "object",
    # ADE20K
    "wall": "wall",
    "floor, flooring": "floor",
    "ceiling": "ceiling",
    "windowpane, window": "window",
    "windowpane;window": "window",
    "door, double door": "door",
    "screen door, screen": "door",
    "lamp": "lamp",
    "chandelier, pendant, pendent": "lamp",
    "light, light source": "lamp",
    "sconce": "lamp",
    "rug, carpet, carpeting": "floor",
    "blind, screen": "window",
    "column, pillar": "object",
    "wardrobe, closet, press": "object",
    # NYU-40
    "floor mat": "floor",
    "blinds": "window",
    "night stand": "object",
    "otherstructure": "object",
    "bookshelf": "object",
    "shower curtain": "object",
    # free text, case, plurals, instance numbers, head nouns
    "Walls": "wall",
    "FLOOR": "floor",
    "Ceiling_Light": "lamp",
    "floor lamp": "lamp",
    "floor_lamp": "lamp",
    "table lamp": "lamp",
    "wall clock": "object",
    "light switch": "object",
    "ceiling fan": "object",
    "wall2": "wall",
    "chair 3": "object",
    "doorway": "door",
    "door knob": "object",
    "tiled floor": "floor",
    "brick wall": "wall",
    "window frame": "window",
    "lamp shade": "lamp",
    "windows": "window",
    "skylight": "window",
    "": "object",
    "box": "object",
}


@pytest.mark.parametrize("name,category", sorted(CATEGORY_TABLE.items()))
def test_category_of(name: str, category: str):
    assert category_of(name) == category


def test_segment_validates():
    with pytest.raises(ValueError):
        Segment(0, "wall", "wall")
    with pytest.raises(ValueError):
        Segment(1, "sofa", "sofa")
    assert Segment(3, "object", "sofa").category in CATEGORIES


# =================================================================================== COCO panoptic
def _random_ids(h: int = 30, w: int = 40) -> tuple[np.ndarray, list[Segment]]:
    rng = np.random.default_rng(1)
    values = [1, 255, 256, 70000, 16777215]  # exercise R, G and B bytes
    ids = rng.choice([0] + values, size=(h, w)).astype(np.int32)
    labels = ["wall-brick", "floor", "wardrobe", "ceiling", "window-blind"]
    return ids, [Segment(v, category_of(lab), lab) for v, lab in zip(values, labels, strict=True)]


def test_panoptic_round_trip(tmp_path: Path):
    """A saved Panoptic artifact loads back, and read as <stem>.panoptic.png/.json by segmentation=file."""
    ids, segments = _random_ids()
    # an automatic object keeps its score, prompt box, second opinion and the network's 3D box
    seen = SeenBox((0.5, -0.2, 3.1), (1.2, 1.9, 0.6), -2.5, 0.35)
    segments[2] = Segment(segments[2].id, "object", "wardrobe", 0.4, (1.0, 2.0, 3.5, 4.0), "cabinet", seen)
    Panoptic(ids=ids, segments=segments).save(tmp_path)
    loaded = Panoptic.load(tmp_path)
    np.testing.assert_array_equal(loaded.ids, ids)
    assert loaded.segments == segments
    doc = json.loads((tmp_path / "panoptic.json").read_text())
    assert [c["name"] for c in doc["categories"]] == list(CATEGORIES)
    assert sum(s["area"] for s in doc["segments_info"]) == int((ids > 0).sum())
    for name in ("panoptic.png", "panoptic.json"):
        (tmp_path / name).rename(tmp_path / f"photo.{name}")
    kind, png = find_segmentation_sidecar(tmp_path / "photo.jpg")
    assert kind == "coco_panoptic"
    ids2, segments2 = read_coco_panoptic(png, panoptic_json_for(png))
    assert ids2.dtype == np.int32
    np.testing.assert_array_equal(ids2, ids)
    assert segments2 == segments


def test_panoptic_full_coco_file(tmp_path: Path):
    ids = np.zeros((4, 6), np.int32)
    ids[:2] = 5
    ids[2:, :3] = 300
    rgb = np.stack([ids & 255, (ids >> 8) & 255, (ids >> 16) & 255], -1).astype(np.uint8)
    Image.fromarray(rgb).save(tmp_path / "000139.png")
    doc = {
        "annotations": [
            {"file_name": "000001.png", "segments_info": [{"id": 9, "category_id": 1}]},
            {
                "file_name": "000139.png",
                "segments_info": [{"id": 5, "category_id": 199}, {"id": 300, "category_id": 190}],
            },
        ],
        "categories": [
            {"id": 199, "name": "wall-other-merged"},
            {"id": 190, "name": "floor-wood"},
            {"id": 1, "name": "person"},
        ],
    }
    (tmp_path / "coco.json").write_text(json.dumps(doc))
    ids2, segs = read_coco_panoptic(tmp_path / "000139.png", tmp_path / "coco.json")
    np.testing.assert_array_equal(ids2, ids)
    assert segs == [Segment(5, "wall", "wall-other-merged"), Segment(300, "floor", "floor-wood")]


def test_panoptic_errors(tmp_path: Path):
    ids, segments = _random_ids()
    png, js = tmp_path / "p.panoptic.png", tmp_path / "p.panoptic.json"
    write_coco_panoptic(png, js, ids, segments)
    good = json.loads(js.read_text())

    with pytest.raises(SidecarError) as e:
        read_coco_panoptic(png, tmp_path / "none.json")
    one_line_error(e, png, "none.json", "segments_info")

    js.write_text(json.dumps({"things": []}))
    with pytest.raises(SidecarError) as e:
        read_coco_panoptic(png, js)
    one_line_error(e, js, "unknown JSON structure")

    js.write_text("{not json")
    with pytest.raises(SidecarError) as e:
        read_coco_panoptic(png, js)
    one_line_error(e, js, "not valid JSON")

    bad = dict(good, segments_info=good["segments_info"] + [{"id": 4242, "category_id": 1}])
    js.write_text(json.dumps(bad))
    with pytest.raises(SidecarError) as e:
        read_coco_panoptic(png, js)
    one_line_error(e, js, "4242", "not present in p.panoptic.png")

    bad = dict(good, segments_info=good["segments_info"][1:])
    js.write_text(json.dumps(bad))
    with pytest.raises(SidecarError) as e:
        read_coco_panoptic(png, js)
    one_line_error(e, png, "not in p.panoptic.json")

    bad = dict(good, segments_info=[dict(good["segments_info"][0], category_id=77)] + good["segments_info"][1:])
    js.write_text(json.dumps(bad))
    with pytest.raises(SidecarError) as e:
        read_coco_panoptic(png, js)
    one_line_error(e, js, "category_id 77")

    bad = dict(good, segments_info=[dict(good["segments_info"][0], second_opinion=3)] + good["segments_info"][1:])
    js.write_text(json.dumps(bad))
    with pytest.raises(SidecarError) as e:
        read_coco_panoptic(png, js)
    one_line_error(e, js, "second_opinion 3", "a label")

    for seen_box in ({"center": [0, 0, -1], "size": [1, 1, 1], "yaw": 0, "confidence": 0.5}, [1, 2, 3]):
        bad = dict(good, segments_info=[dict(good["segments_info"][0], seen_box=seen_box)] + good["segments_info"][1:])
        js.write_text(json.dumps(bad))
        with pytest.raises(SidecarError) as e:
            read_coco_panoptic(png, js)
        one_line_error(e, js, "seen_box", "center, size, yaw and confidence")

    with pytest.raises(PsdrRoomError) as e:
        write_coco_panoptic(png, js, ids, segments[1:])
    one_line_error(e, png, "without a segment")


# ========================================================================================= LabelMe
def _labelme(tmp_path: Path, shapes: list[dict], h: int = 20, w: int = 20) -> Path:
    path = tmp_path / "photo.labelme.json"
    path.write_text(json.dumps({"version": "5.5.0", "flags": {}, "shapes": shapes, "imageHeight": h, "imageWidth": w}))
    return path


def _shape(label: str, points, kind: str = "polygon", group=None) -> dict:
    return {"label": label, "points": points, "group_id": group, "shape_type": kind, "flags": {}}


def test_labelme_order_groups_and_types(tmp_path: Path):
    path = _labelme(
        tmp_path,
        [
            _shape("wall", [[0, 0], [20, 0], [20, 10], [0, 10]]),  # 1: top half
            _shape("floor", [[0, 10], [20, 10], [20, 20], [0, 20]]),  # 2: bottom half
            _shape("wardrobe", [[5, 5], [15, 15]], "rectangle"),  # 3: drawn over wall and floor
            _shape("lamp", [[17, 3], [17, 5]], "circle"),  # 4: over the wall
            _shape("box", [[1, 12], [3, 12], [3, 14], [1, 14]], group=7),  # 5: two parts, one segment
            _shape("box", [[16, 16], [18, 16], [18, 18], [16, 18]], group=7),
            _shape("box", [[6, 17], [8, 17], [8, 19]]),  # 6: same label, no group: its own segment
            _shape("scribble", [[0, 0], [5, 5]], "line"),  # no area: skipped
            _shape("_background_", [[0, 0], [2, 0], [2, 2]]),  # background: skipped
        ],
    )
    ids, segs = read_labelme(path)
    assert ids.dtype == np.int32 and ids.shape == (20, 20)
    assert [(s.id, s.category, s.label) for s in segs] == [
        (1, "wall", "wall"),
        (2, "floor", "floor"),
        (3, "object", "wardrobe"),
        (4, "lamp", "lamp"),
        (5, "object", "box"),
        (6, "object", "box"),
    ]
    assert np.all(ids[5:15, 5:15] == 3)  # later shapes cover earlier ones
    assert (ids == 3).sum() == 100
    assert (ids == 1).sum() == 200 - 50 - (ids == 4).sum()
    assert ids[4, 17] == 4 and (ids == 4).sum() == 12  # radius-2 disc sampled at pixel centres
    assert (ids == 5).sum() == 8 and ids[12, 1] == 5 and ids[17, 17] == 5
    assert (ids == 6).sum() == 1 + 2  # triangle, pixel centres inside
    assert ids[0, 0] == 1  # the skipped background shape does not erase


def test_labelme_scaling(tmp_path: Path):
    shapes = [_shape("wall", [[0, 0], [10, 0], [10, 10], [0, 10]]), _shape("chair", [[12, 0], [20, 0], [12, 8]])]
    path = _labelme(tmp_path, shapes)
    ids, _ = read_labelme(path)
    assert (ids == 1).sum() == 100 and np.all(ids[:10, :10] == 1)
    ids2, _ = read_labelme(path, shape=(40, 40))
    assert ids2.shape == (40, 40) and (ids2 == 1).sum() == 400 and np.all(ids2[:20, :20] == 1)
    np.testing.assert_array_equal(ids2[::2, ::2][ids > 0] > 0, True)
    ids3, _ = read_labelme(path, shape=(10, 40))  # anisotropic
    assert (ids3 == 1).sum() == 5 * 20
    assert abs((ids3 == 2).sum() - 32 * 2 * 0.5) <= 4  # triangle area 32 scaled by 2 x 0.5


def test_labelme_mask_and_hidden_segment(tmp_path: Path):
    small = np.zeros((4, 5), np.uint8)
    small[1:3, 1:4] = 255
    buf = io.BytesIO()
    Image.fromarray(small).save(buf, format="PNG")
    mask_shape = _shape("sofa", [[10, 10], [14, 13]], "mask")
    mask_shape["mask"] = base64.b64encode(buf.getvalue()).decode()
    shapes = [_shape("rug", [[2, 2], [4, 2], [4, 4]]), mask_shape, _shape("wall", [[0, 0], [8, 0], [8, 8], [0, 8]])]
    ids, segs = read_labelme(_labelme(tmp_path, shapes))
    assert [s.label for s in segs] == ["sofa", "wall"]  # the rug is fully covered: dropped
    assert (ids == 2).sum() == 6 and np.all(ids[11:13, 11:14] == 2)


def test_labelme_errors(tmp_path: Path):
    cases = [
        ([_shape("wall", [[0, 0], [5, 5]])], "at least 3"),
        ([_shape("wall", [[0, 0], [5, 5], [5, 0]], "rectangle")], "2 opposite corners"),
        ([_shape("wall", [[0, 0], [5, 5]], "cuboid")], "unsupported shape_type 'cuboid'"),
        ([_shape("wall", [[0, "a"], [5, 5], [1, 1]])], "malformed points"),
        ([_shape("", [[0, 0], [5, 5], [5, 0]])], "no label"),
    ]
    for shapes, phrase in cases:
        path = _labelme(tmp_path, shapes)
        with pytest.raises(SidecarError) as e:
            read_labelme(path)
        one_line_error(e, path, phrase)
    path = tmp_path / "photo.labelme.json"
    path.write_text(json.dumps({"shapes": []}))
    with pytest.raises(SidecarError) as e:
        read_labelme(path)
    one_line_error(e, path, "imageHeight")
    assert read_labelme(path, shape=(3, 4))[0].shape == (3, 4)
    path.write_text(json.dumps({"annotations": []}))
    with pytest.raises(SidecarError) as e:
        read_labelme(path)
    one_line_error(e, path, "not a LabelMe file")
    with pytest.raises(SidecarError) as e:
        read_labelme(tmp_path / "missing.labelme.json")
    one_line_error(e, tmp_path / "missing.labelme.json", "not found")


def test_find_segmentation_sidecar(tmp_path: Path):
    photo = tmp_path / "room.jpg"
    assert find_segmentation_sidecar(photo) is None
    (tmp_path / "room.panoptic.png").write_bytes(b"")
    assert find_segmentation_sidecar(photo) == ("coco_panoptic", tmp_path / "room.panoptic.png")
    (tmp_path / "room.labelme.json").write_text("{}")
    assert find_segmentation_sidecar(photo) == ("labelme", tmp_path / "room.labelme.json")


# ================================================================================= bundled example
def test_example_files():
    assert find_segmentation_sidecar(EXAMPLE / "photo.jpg") == ("labelme", EXAMPLE / "photo.labelme.json")
    with Image.open(EXAMPLE / "photo.jpg") as im:
        assert im.size == (640, 480)
    gt = json.loads((EXAMPLE / "ground_truth.json").read_text())
    assert gt["intrinsics"]["fx"] == pytest.approx(518.8579)
    ids, segs = read_labelme(EXAMPLE / "photo.labelme.json", shape=(480, 640))
    cats = [s.category for s in segs]
    assert {"wall", "floor", "ceiling", "door", "window", "object"} <= set(cats)
    assert len([s for s in segs if s.category == "object"]) >= 8
    assert len({s.id for s in segs}) == len(segs) and all((ids == s.id).any() for s in segs)
    assert (ids > 0).mean() > 0.9 and (ids[6:474, 7:632] > 0).all()  # all but the white border
    # the floor is the bottom of the picture, the ceiling its top
    floor = np.isin(ids, [s.id for s in segs if s.category == "floor"])
    ceiling = np.isin(ids, [s.id for s in segs if s.category == "ceiling"])
    assert np.nonzero(floor)[0].mean() > 350 and np.nonzero(ceiling)[0].mean() < 100
    # read at half resolution, the labels scale with the photo
    half = read_labelme(EXAMPLE / "photo.labelme.json", shape=(240, 320))[0]
    assert half.shape == (240, 320) and (half[::1, ::1] == ids[::2, ::2]).mean() > 0.97
