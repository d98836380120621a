"""The eyes network's 3D boxes on their own, against SUN RGB-D's 3D references: no retrieval, no fit.

For every shared photo with a 3D reference (``gt_3d_total3d.json``, :mod:`boxes3d`) the network runs once; each
instance it finds is read as a 3D box (:func:`psdr_room_plugins.eyes.box3d.read_box`) with the reference camera's
focal, put in the level frame with the reference pitch and roll (so only the network's own error counts), and
matched to the reference object whose 2D box its mask's box overlaps most (IoU ≥ ``--iou``, each used once, best
first). Per photo and in all: matched pairs, pairs at 3D IoU ≥ 0.25, mean 3D IoU, and the median centre error,
relative size error, yaw error (of the front; ``axis``: of the front's line, modulo 180°, as for a table) and
horizontal distance ratio (network / reference) of the pairs.

    python benchmarks/eyes3d.py [--network plugins/eyes/eyes.onnx] [--iou 0.3]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from boxes3d import (  # noqa: E402
    IOU_3D,
    TOTAL3D_TO_OPENCV,
    LevelBox,
    pair_scores,
    read_reference,
    total3d_rotation,
    yaw_error,
)

from psdr_room_core.method.artifacts import Image  # noqa: E402
from psdr_room_core.method.image_boxes import box_iou, mask_box  # noqa: E402
from psdr_room_plugins.eyes.box3d import BOX_OUTPUTS, read_box  # noqa: E402
from psdr_room_plugins.eyes.decode import instances  # noqa: E402
from psdr_room_plugins.eyes.perception import SHIPPED, Eyes  # noqa: E402

PHOTOS = Path(__file__).resolve().parents[2] / "shared" / "data" / "photos"


def network_boxes(
    eyes: Eyes, rgb: np.ndarray, K: np.ndarray, pitch: float, roll: float
) -> list[tuple[np.ndarray, LevelBox]]:
    """(photo-pixel box, level-frame box) of each instance the network finds in ``rgb``."""
    out = eyes.outputs(Image(rgb=rgb))
    if not all(name in out for name in BOX_OUTPUTS):
        raise SystemExit(f"{eyes.path}: a network without the 3D heads ({', '.join(BOX_OUTPUTS)})")
    height, width = rgb.shape[:2]
    fx, fy = K[0, 0] * 320 / width, K[1, 1] * 240 / height
    level = TOTAL3D_TO_OPENCV @ total3d_rotation(pitch, roll) @ TOTAL3D_TO_OPENCV.T  # camera → level frame
    found = []
    for item in instances(out["surface"], out["category"], out["center"], out["offset"], eyes.center_threshold):
        box = read_box(out, item.mask, fx, fy)
        mask = cv2.resize(item.mask.astype(np.uint8), (width, height), interpolation=cv2.INTER_NEAREST) > 0
        pixels = mask_box(mask)
        if pixels is None:
            continue
        found.append((np.asarray(pixels, float), LevelBox(center=level @ box.center, size=box.size, yaw=-box.yaw)))
    return found


def photo_row(eyes: Eyes, folder: Path, iou: float) -> dict | None:
    """One photo's pairs; None without a 3D reference."""
    reference = read_reference(folder)
    if reference is None:
        return None
    rgb = cv2.imread(str(folder / "img.jpg"))[..., ::-1].astype(np.float32) / 255.0
    found = network_boxes(eyes, rgb, reference.K, reference.pitch, reference.roll)
    boxes2d = np.array(reference.boxes2d).reshape(-1, 4)
    candidates = sorted(
        ((float(box_iou(f[0], boxes2d[[r]])[0]), k, r) for k, f in enumerate(found) for r in range(len(boxes2d))),
        reverse=True,
    )
    used_found: set[int] = set()
    used_reference: set[int] = set()
    pairs = []
    for overlap, k, r in candidates:
        if overlap < iou or k in used_found or r in used_reference:
            continue
        used_found.add(k)
        used_reference.add(r)
        truth, box = reference.boxes[r], found[k][1]
        distance = float(np.linalg.norm(truth.center[[0, 2]]))
        pairs.append(
            {
                **pair_scores(box, truth, 2 * np.pi),
                "yaw_axis": yaw_error(box, truth, np.pi),
                "depth_ratio": float(np.linalg.norm(box.center[[0, 2]])) / distance,
            }
        )
    return {"photo": folder.name, "references": len(reference.boxes), "found": len(found), "pairs": pairs}


def line(name: str, pairs: list[dict], references: int, found: int) -> str:
    def median(key: str, fmt: str) -> str:
        return format(float(np.median([p[key] for p in pairs])), fmt) if pairs else "-"

    hits = sum(p["iou"] >= IOU_3D for p in pairs)
    mean = format(float(np.mean([p["iou"] for p in pairs])), ".3f") if pairs else "-"
    return (
        f"{name:<26} {found:>5} {f'{len(pairs)}/{references}':>7} {f'{hits}/{references}':>7} {mean:>6} "
        f"{median('centre', '.2f'):>8} {median('size', '.2f'):>6} {median('yaw', '.0f'):>5} {median('yaw_axis', '.0f'):>6} "
        f"{median('depth_ratio', '.2f'):>7}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--network", type=Path, default=SHIPPED, help="an eyes.onnx with the 3D heads")
    parser.add_argument("--iou", type=float, default=0.3, help="2D box IoU that matches an instance to a reference")
    args = parser.parse_args()
    eyes = Eyes(str(args.network))
    rows = [r for r in (photo_row(eyes, f, args.iou) for f in sorted(PHOTOS.iterdir()) if f.is_dir()) if r]
    header = (
        f"{'photo':<26} {'found':>5} {'matched':>7} {'IoU≥.25':>7} {'IoU3D':>6} {'centre m':>8} {'size':>6} "
        f"{'yaw°':>5} {'axis°':>6} {'depth×':>7}"
    )
    print(f"the eyes network's 3D boxes alone ({args.network.name}), reference focal, pitch and roll")
    print(header)
    print("-" * len(header))
    for r in rows:
        print(line(r["photo"], r["pairs"], r["references"], r["found"]))
    print("-" * len(header))
    every = [p for r in rows for p in r["pairs"]]
    print(line("all", every, sum(r["references"] for r in rows), sum(r["found"] for r in rows)))


if __name__ == "__main__":
    main()
