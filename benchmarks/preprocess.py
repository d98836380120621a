"""The offline preprocess on real photos: FoV, layout segmentation, layout depth and the detector.

Runs the pipeline up to ``estimate_depth`` with ``segmentation=layout depth=layout detector=nanodet_onnx``
(what ``auto`` picks for a bare photo) on the real photos of ``../shared/data/photos`` and the bundled
example, and prints per photo:

* the vertical FoV error where the intrinsics are known;
* the wall/floor/ceiling IoU of the layout segmentation where reference labels exist (the example's
  LabelMe file; the NYU office frame's 13-class map, which shows walls only);
* the scale-invariant log error (si-log RMSE, Eigen et al. 2014) and the median-scaled AbsRel of the
  layout depth against sensor depth, on the pixels the segmentation calls wall/floor/ceiling;
* the number of detector boxes and of GrabCut object segments.

Then the FoV summary over all photos with intrinsics (``benchmarks/fov_accuracy.py``) and the detector's
recall on the SUN RGB-D photos with reference boxes (``benchmarks/detector.py``). Overlays (segments,
layout depth) are written to ``--overlays`` (default ``outputs/benchmarks/preprocess``).

    python benchmarks/preprocess.py [--overlays DIR] [--photos NAME ...]
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine.cli import compose_config
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.engine.run import execute
from psdr_room_core.libraries.sidecar_depth import read_depth
from psdr_room_core.libraries.sidecar_segmentation import read_labelme
from psdr_room_core.method.artifacts import ROOM_CATEGORIES, Panoptic
from psdr_room_core.method.visualize import depth_colormap, segment_overlay

sys.path.insert(0, str(Path(__file__).resolve().parent))
import detector as detector_benchmark  # noqa: E402  (sibling benchmark)
import fov_accuracy  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PHOTOS = REPO.parent / "shared" / "data" / "photos"
NYU13 = {"wall": (64, 0, 128), "floor": (128, 0, 128), "ceiling": (128, 128, 0)}
"""RGB colours of the NYU 13-class palette (PASCAL VOC colour map, classes 12, 5, 3) in semantic13.png."""


@dataclass(frozen=True)
class Photo:
    """A benchmark photo and what is known about it."""

    name: str
    path: Path
    fy: float | None = None
    depth: tuple[Path, str, float] | None = None
    """Sensor depth: file, encoding, units per metre."""
    labels: str | None = None
    """``labelme`` (a LabelMe JSON beside the photo) or ``nyu13`` (semantic13.png beside it)."""


def photos() -> list[Photo]:
    nyu = 519.46961
    return [
        Photo(
            "example_nyu_basement",
            REPO / "examples/nyu_basement/photo.jpg",
            nyu,
            (REPO / "examples/nyu_basement/photo.depth.png", "png16", 1000.0),
            "labelme",
        ),
        Photo(
            "nyu_metric3d_00050",
            PHOTOS / "nyu_metric3d_00050/rgb_00050.jpg",
            nyu,
            (PHOTOS / "nyu_metric3d_00050/sync_depth_00050.png", "png16", 1000.0),
        ),
        Photo(
            "sunrgbd_corridor",
            PHOTOS / "sunrgbd_open3d_corridor/SUN_color.jpg",
            525.0,
            (PHOTOS / "sunrgbd_open3d_corridor/SUN_depth.png", "sun", 1000.0),
        ),
        Photo(
            "tum_office",
            PHOTOS / "tum_open3d_office/TUM_color.png",
            None,
            (PHOTOS / "tum_open3d_office/TUM_depth.png", "png16", 5000.0),
        ),
        Photo("nyu_office_labelled", PHOTOS / "nyu_vainf_office/image.png", None, None, "nyu13"),
        *[Photo(f"sunrgbd_total3d_0{i}", PHOTOS / f"sunrgbd_total3d_0{i}/img.jpg", 529.5) for i in range(1, 6)],
        *[Photo(f"nyu_{n}", PHOTOS / f"nyu_densedepth/{n}_image.png", nyu) for n in (119, 267, 308, 312)],
    ]


def reference_labels(photo: Photo, shape: tuple[int, int]) -> dict[str, np.ndarray] | None:
    """Category → boolean mask at ``shape`` from the photo's reference labels."""
    if photo.labels == "labelme":
        ids, segments = read_labelme(photo.path.with_suffix(".labelme.json"), shape)
        return {c: np.isin(ids, [s.id for s in segments if s.category == c]) for c in ROOM_CATEGORIES}
    if photo.labels == "nyu13":
        rgb = cv2.imread(str(photo.path.parent / "semantic13.png"))[..., ::-1]
        rgb = cv2.resize(rgb, (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST)
        return {c: np.all(rgb == colour, axis=-1) for c, colour in NYU13.items()}
    return None


def iou(a: np.ndarray, b: np.ndarray) -> float:
    union = (a | b).sum()
    return float((a & b).sum() / union) if union else float("nan")


def depth_errors(pred: np.ndarray, truth: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """(si-log RMSE, AbsRel after median scaling) on ``mask``."""
    p, t = pred[mask].astype(np.float64), truth[mask].astype(np.float64)
    d = np.log(p) - np.log(t)
    silog = float(np.sqrt(max(np.mean(d**2) - np.mean(d) ** 2, 0.0)))
    scaled = p * np.median(t / p)
    return silog, float(np.mean(np.abs(scaled - t) / t))


def evaluate(photo: Photo, cache: Path, overlays: Path) -> dict:
    plugins = plugin_system()
    overrides = [
        f"image={photo.path}",
        f"cache_dir={cache}",
        "run.until=estimate_depth",
        "report.enabled=false",
        "segmentation=layout",
        "depth=layout",
        "detector=nanodet_onnx",
    ]
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as run_dir:
        record = execute(compose_config(overrides, plugins), Path(run_dir), plugins)
    seconds = {r.name: r.seconds for r in record.stages}
    image, camera = record.artifacts["image"], record.artifacts["camera"]
    panoptic: Panoptic = record.artifacts["panoptic"]
    depth = record.artifacts["depth"]
    row: dict = {
        "photo": photo.name,
        "seconds": time.perf_counter() - start,
        "segment_s": seconds["segment"],
        "depth_s": seconds["estimate_depth"],
        "boxes": len(record.artifacts["detections"].items),
        "objects": sum(s.category not in ROOM_CATEGORIES for s in panoptic.segments),
    }
    if photo.fy is not None:
        true_vfov = math.degrees(2 * math.atan(image.original_size[1] / (2 * photo.fy)))
        row["fov_error"] = camera.vfov_deg - true_vfov
    labels = reference_labels(photo, (image.height, image.width))
    if labels is not None:
        ious = {c: iou(panoptic.mask(c), m) for c, m in labels.items() if m.any()}
        row.update({f"iou_{c}": v for c, v in ious.items()})
        row["miou"] = float(np.mean(list(ious.values())))
    if photo.depth is not None:
        file, encoding, scale = photo.depth
        truth, valid = read_depth(file, encoding=encoding, scale=scale)
        size = (image.width, image.height)
        truth = cv2.resize(truth, size, interpolation=cv2.INTER_NEAREST)
        valid = cv2.resize(valid.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
        room = np.isin(panoptic.ids, [s.id for s in panoptic.segments if s.category in ROOM_CATEGORIES])
        row["silog"], row["absrel"] = depth_errors(depth.depth, truth, room & valid & depth.valid)
    overlays.mkdir(parents=True, exist_ok=True)
    picture = np.hstack([segment_overlay(image.to_uint8(), panoptic), depth_colormap(depth.depth, depth.valid)])
    cv2.imwrite(str(overlays / f"{photo.name}.png"), picture[..., ::-1])
    return row


def _cell(row: dict, key: str, fmt: str) -> str:
    """``row[key]`` formatted with ``fmt`` (whose leading digits are the width), or a right-aligned dash."""
    value = row.get(key)
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-".rjust(int("".join(ch for ch in fmt.split(".")[0] if ch.isdigit()) or 1))
    return format(value, fmt)


def format_table(rows: list[dict]) -> str:
    header = (
        f"{'photo':<22} {'FoV err°':>8} {'wall':>5} {'floor':>5} {'ceil':>5} {'mIoU':>5} {'si-log':>6} "
        f"{'AbsRel':>6} {'boxes':>5} {'objs':>4} {'seg s':>6} {'depth s':>7}"
    )
    lines = [header]
    for r in rows:
        lines.append(
            f"{r['photo']:<22} {_cell(r, 'fov_error', '+8.2f')} {_cell(r, 'iou_wall', '5.2f')} "
            f"{_cell(r, 'iou_floor', '5.2f')} {_cell(r, 'iou_ceiling', '5.2f')} {_cell(r, 'miou', '5.2f')} "
            f"{_cell(r, 'silog', '6.3f')} {_cell(r, 'absrel', '6.3f')} {r['boxes']:>5} {r['objects']:>4} "
            f"{r['segment_s']:6.2f} {r['depth_s']:7.2f}"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--overlays", type=Path, default=REPO / "outputs" / "benchmarks" / "preprocess")
    parser.add_argument("--photos", nargs="*", help="names of the photos to run (default: all)")
    args = parser.parse_args()
    logging.getLogger("psdr_room").setLevel(logging.WARNING)
    chosen = [p for p in photos() if not args.photos or p.name in args.photos]
    with tempfile.TemporaryDirectory() as cache:
        rows = [evaluate(p, Path(cache), args.overlays) for p in chosen]
    print("Offline preprocess (segmentation=layout, depth=layout, detector=nanodet_onnx) on real photos\n")
    print(format_table(rows))
    print(f"\noverlays (segments | layout depth): {args.overlays}")
    fov = fov_accuracy.summarize(fov_accuracy.evaluate(PHOTOS))
    print(
        f"\nFoV (vanishing points, all photos with intrinsics): median |error| {fov['median_abs_error_deg']:.2f}°, "
        f"worst {fov['worst_abs_error_deg']:.2f}°, {fov['n_estimated']}/{fov['n_photos']} estimated"
    )
    print("\nDetector recall on SUN RGB-D reference boxes (recalled/references; any = class-agnostic)\n")
    print(detector_benchmark.format_table(detector_benchmark.detector_recall(overlays=args.overlays / "detector")))


if __name__ == "__main__":
    main()
