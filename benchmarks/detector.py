"""Recall of the bundled NanoDet detector on SUN RGB-D photos with reference 2D boxes.

Each photo folder holds ``img.jpg`` and ``detections.json`` (a list of ``{"bbox": [x0, y0, x1, y1],
"class": NAME}`` in photo pixels, the Total3DUnderstanding demo inputs). The photo goes through
``load_image``'s reader and resizing (long side 800) and ``detector=nanodet_onnx`` with its defaults. A
reference box is recalled at IoU >= t when a detection, each used once (greedy by IoU), overlaps it that
much; "class" recall counts only detections of the COCO class the reference's class maps to
(:data:`TO_COCO`) and is over the mappable references, "any" ignores classes (COCO labels are a weak
prior) over the same references, "any/all" over every reference box. Time is per ``detect`` call after
a warm-up (resize, inference, decoding).

    python benchmarks/detector.py [--photos DIR ...] [--overlays DIR]
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine import shipped
from psdr_room_core.method.artifacts import Detections, Image
from psdr_room_core.method.capabilities import Detector
from psdr_room_core.method.image_boxes import box_iou
from psdr_room_core.method.photo import read_photo, resize_to_working
from psdr_room_plugins.detectors.nanodet import NanodetOnnx

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_PHOTOS = [REPO_ROOT.parent / f"shared/data/photos/sunrgbd_total3d_0{i}" for i in range(1, 6)]
THRESHOLDS = (0.5, 0.3)
MAX_SIDE = shipped.node("load_image.max_side")

TO_COCO = {
    "chair": "chair",
    "sofa_chair": "chair",
    "sofa": "couch",
    "bed": "bed",
    "table": "dining table",
    "desk": "dining table",
    "refridgerator": "refrigerator",
    "refrigerator": "refrigerator",
    "tv": "tv",
    "toilet": "toilet",
    "sink": "sink",
}
"""SUN RGB-D reference classes with a COCO counterpart (SUN RGB-D spells ``refridgerator``); cabinets,
dressers, night stands and shelves have none."""


def load(folder: Path) -> tuple[Image, list[dict]]:
    """The working image of ``folder/img.jpg`` and its reference boxes scaled to it."""
    rgb = read_photo(folder / "img.jpg", 10**8)
    image = Image(
        rgb=resize_to_working(rgb, MAX_SIDE), source=str(folder / "img.jpg"), original_size=(rgb.shape[1], rgb.shape[0])
    )
    scale = np.array([image.width / rgb.shape[1], image.height / rgb.shape[0]] * 2)
    references = [
        {"class": r["class"], "box": np.asarray(r["bbox"], np.float64) * scale}
        for r in json.loads((folder / "detections.json").read_text())
    ]
    return image, references


def matched(references: list[np.ndarray], detections: list[np.ndarray], threshold: float) -> int:
    """How many references a one-to-one greedy matching (best IoU first) pairs at IoU >= ``threshold``."""
    if not references or not detections:
        return 0
    ious = np.stack([box_iou(r, np.stack(detections)) for r in references])
    count = 0
    while ious.size and ious.max() >= threshold:
        r, d = np.unravel_index(np.argmax(ious), ious.shape)
        ious[r, :], ious[:, d] = -1.0, -1.0
        count += 1
    return count


def recall_row(folder: Path, references: list[dict], detections: Detections, ms: float) -> dict:
    """One photo's row: reference and detection counts, recalled counts per threshold, time."""
    mappable = [r for r in references if r["class"] in TO_COCO]
    boxes = [np.asarray(d.box) for d in detections.items]
    row = {
        "photo": folder.name,
        "references": len(mappable),
        "references_all": len(references),
        "detections": len(detections.items),
        "ms": ms,
    }
    for t in THRESHOLDS:
        row[f"class@{t}"] = sum(
            matched(
                [r["box"] for r in mappable if TO_COCO[r["class"]] == label],
                [np.asarray(d.box) for d in detections.items if d.label == label],
                t,
            )
            for label in {TO_COCO[r["class"]] for r in mappable}
        )
        row[f"any@{t}"] = matched([r["box"] for r in mappable], boxes, t)
        row[f"any_all@{t}"] = matched([r["box"] for r in references], boxes, t)
    return row


def draw(image: Image, references: list[dict], detections: Detections, path: Path) -> None:
    """Save the working image with reference boxes (thin, white) and detections (green, labelled)."""
    canvas = np.ascontiguousarray(image.to_uint8()[..., ::-1])
    for r in references:
        x0, y0, x1, y1 = np.rint(r["box"]).astype(int)
        cv2.rectangle(canvas, (x0, y0), (x1, y1), (255, 255, 255), 1)
    for d in detections.items:
        x0, y0, x1, y1 = np.rint(d.box).astype(int)
        cv2.rectangle(canvas, (x0, y0), (x1, y1), (0, 200, 0), 2)
        cv2.putText(
            canvas,
            f"{d.label} {d.score:.2f}",
            (x0 + 2, max(y0 - 4, 10)),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.4,
            (0, 255, 0),
            1,
            cv2.LINE_AA,
        )
    cv2.imwrite(str(path), canvas)


def detector_recall(
    photos: Sequence[Path] = DEFAULT_PHOTOS, detector: Detector | None = None, overlays: Path | None = None
) -> list[dict]:
    """Per-photo rows (see the module docstring) for ``detector`` (default: ``nanodet_onnx`` with one
    thread); ``overlays``: a directory for ``<photo>.png`` drawings of the boxes."""
    detector = detector or NanodetOnnx(intra_op_threads=1)
    rows = []
    for folder in map(Path, photos):
        image, references = load(folder)
        if not rows:
            detector.detect(image, folder / "img.jpg")  # warm-up: session creation, first-run allocations
        start = time.perf_counter()
        detections = detector.detect(image, folder / "img.jpg")
        rows.append(recall_row(folder, references, detections, 1000.0 * (time.perf_counter() - start)))
        if overlays is not None:
            overlays.mkdir(parents=True, exist_ok=True)
            draw(image, references, detections, overlays / f"{folder.name}.png")
    return rows


def format_table(rows: list[dict]) -> str:
    """Plain-text table: recalled/references per photo and in total, then the mean time."""
    columns = [f"{kind}@{t}" for kind in ("class", "any", "any_all") for t in THRESHOLDS]
    lines = [f"{'photo':<20} {'dets':>5} " + " ".join(f"{c:>12}" for c in columns) + f" {'ms':>6}"]
    total = {k: sum(r[k] for r in rows) for k in ("detections", "references", "references_all", *columns)}
    for r in [*rows, {"photo": "total", **total, "ms": float(np.mean([r["ms"] for r in rows]))}]:
        cells = [f"{r[c]:>3}/{r['references_all' if c.startswith('any_all') else 'references']:<3}" for c in columns]
        lines.append(
            f"{r['photo']:<20} {r['detections']:>5} " + " ".join(f"{c:>12}" for c in cells) + f" {r['ms']:6.1f}"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--photos", type=Path, nargs="+", default=DEFAULT_PHOTOS, help="folders holding img.jpg and detections.json"
    )
    parser.add_argument("--overlays", type=Path, help="also draw the boxes into DIR/<photo>.png")
    args = parser.parse_args()
    print(format_table(detector_recall(args.photos, overlays=args.overlays)))


if __name__ == "__main__":
    main()
