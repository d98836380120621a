"""The eyes network alone on the real photos: what a trained ``eyes.onnx`` sees, in seconds, without the pipeline.

For each network given (default: the shipped one) and each photo of ``--photos`` (an ``index.csv`` folder, as
``real_photos.py`` reads it), the photo at the pipeline's working size goes through ``segmentation=eyes`` and
``depth=eyes``; per network it prints

* ``segs`` and ``seg rec``: furniture segments, and reference pieces (SUN RGB-D boxes) matched by a segment's box
  at IoU >= 0.5 (one-to-one, best first), the same count as ``real_photos.py``'s;
* ``AbsRel`` / ``δ1`` against sensor depth after a median scale (medians over the photos that have it);
* ``w/f/c``: wall/floor/ceiling pixel accuracy against ``benchmarks/layout_labels`` (mean over the photos).

``--compare rows.json`` adds the same columns from a ``real_photos.py`` run (e.g. the classical perception:
``--set segmentation=layout --set depth=layout --until estimate_depth``). The real-photo check of
``psdr-room-train``: run it on the ``eyes.onnx`` a training run wrote.

    python benchmarks/eyes.py [NETWORK.onnx ...] [--photos DIR] [--compare rows.json]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from real_photos import (  # noqa: E402
    PHOTOS,
    REFERENCE_CLASSES,
    Entry,
    depth_scores,
    match,
    read_index,
    read_references,
    room_accuracy,
)

from psdr_room_core.method.artifacts import Camera, Detections, Image  # noqa: E402
from psdr_room_core.method.image_boxes import mask_box  # noqa: E402
from psdr_room_plugins.eyes.perception import SHIPPED, EyesDepth, EyesSegmentation  # noqa: E402

MAX_SIDE = 800
"""The long side of the pipeline's working image (``load_image.max_side``)."""


def evaluate(entry: Entry, network: Path) -> dict:
    """One photo's row for one network."""
    bgr = cv2.imread(str(entry.image), cv2.IMREAD_COLOR)
    scale = min(1.0, MAX_SIDE / max(bgr.shape[:2]))
    bgr = cv2.resize(bgr, (round(bgr.shape[1] * scale), round(bgr.shape[0] * scale)), interpolation=cv2.INTER_AREA)
    image = Image(rgb=bgr[..., ::-1].astype(np.float32) / 255.0)
    f = (entry.fy or 525.0) * image.height / entry.size[1]
    camera = Camera(image.width, image.height, f, f, image.width / 2, image.height / 2)
    panoptic = EyesSegmentation(path=str(network)).segment(image, camera, Detections([]), entry.image)
    objects = [s for s in panoptic.segments if s.category in ("object", "lamp")]
    row: dict = {"photo": entry.name, "segments": len(objects)}
    if entry.boxes is not None:
        size = np.array([image.width / entry.size[0], image.height / entry.size[1]] * 2)
        references = [box * size for name, box in read_references(entry.boxes) if REFERENCE_CLASSES.get(name)]
        boxes = [b for b in (mask_box(panoptic.ids == s.id) for s in objects) if b is not None]
        row.update(references=len(references), seg_recall=len(match(references, boxes)))
    if entry.depth is not None:
        depth = EyesDepth(path=str(network)).estimate(image, camera, panoptic, entry.image)
        row.update(depth_scores(entry, depth.depth, depth.valid))
    accuracy = room_accuracy(entry, panoptic)
    if accuracy is not None:
        row["room_accuracy"] = accuracy
    return row


def summary(rows: list[dict]) -> str:
    """segs, seg rec, AbsRel, δ1, w/f/c over the photos."""
    boxed = [r for r in rows if "references" in r]
    depth = [r for r in rows if "absrel" in r]
    room = [r["room_accuracy"] for r in rows if "room_accuracy" in r]
    recall = f"{sum(r['seg_recall'] for r in boxed)}/{sum(r['references'] for r in boxed)}" if boxed else "-"
    return (
        f"{sum(r['segments'] for r in rows):>5} {recall:>8} "
        f"{np.median([r['absrel'] for r in depth]) if depth else float('nan'):>7.3f} "
        f"{np.median([r['delta1'] for r in depth]) if depth else float('nan'):>6.2f} "
        f"{np.mean(room) if room else float('nan'):>6.2f}"
    )


def main() -> None:
    import json

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("networks", nargs="*", type=Path, default=[SHIPPED], help="eyes.onnx files (default: shipped)")
    parser.add_argument("--photos", type=Path, default=PHOTOS, help="a folder with index.csv (default: %(default)s)")
    parser.add_argument("--compare", type=Path, help="rows.json of a real_photos.py run to print beside them")
    args = parser.parse_args()
    for network in args.networks:
        if not network.is_file():
            sys.exit(f"eyes: {network}: no such network; train one with psdr-room-train (its RUN/eyes.onnx)")
    entries = read_index(args.photos.resolve())
    header = f"{'':<34} {'segs':>5} {'seg rec':>8} {'AbsRel':>7} {'δ1':>6} {'w/f/c':>6}"
    lines = [header, "-" * len(header)]
    if args.compare:
        lines.append(f"{'real_photos ' + args.compare.parent.name:<34} {summary(json.loads(args.compare.read_text()))}")
    per_photo = {}
    for network in args.networks:
        rows = [evaluate(entry, network) for entry in entries]
        per_photo[network] = rows
        lines.append(f"{str(network)[-34:]:<34} {summary(rows)}")
    print("\n".join(lines))
    print(
        "(segs: furniture segments; seg rec: reference pieces matched at box IoU >= 0.5; AbsRel, δ1: medians over "
        "the photos with sensor depth; w/f/c: mean wall/floor/ceiling pixel accuracy on the hand-drawn labels)"
    )
    for network, rows in per_photo.items():
        print(f"\n{network}:")
        for r in rows:
            print(
                f"  {r['photo']:<26} segs {r['segments']:>3}  "
                + "  ".join(
                    f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}"
                    for k, v in r.items()
                    if k not in ("photo", "segments")
                )
            )


if __name__ == "__main__":
    main()
