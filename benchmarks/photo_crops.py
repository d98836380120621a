"""Crops of the shared real photos that show little of a room: the lower half of a photo (floor and the bottom
of the furniture, no ceiling, often no wall's top) and close-ups of one piece of furniture (its reference box,
widened by 15%). They are photos a phone or a listing gives; ``real_photos.py --photos DIR`` runs them bare.

The crops are fixed here, chosen from the photos' reference boxes before any was run; a crop keeps the photo's
focal length in pixels, so ``index.csv`` carries ``fy`` and the FoV error is measured on the crops as well.

    python benchmarks/photo_crops.py [--photos DIR] --out DIR
    python benchmarks/real_photos.py --photos DIR
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import cv2

PHOTOS = Path(__file__).resolve().parents[2] / "shared" / "data" / "photos"

LOWER_HALVES = (
    "sunrgbd_total3d_01/img.jpg",
    "sunrgbd_total3d_03/img.jpg",
    "sunrgbd_total3d_05/img.jpg",
    "nyu_metric3d_00000/rgb_00000.jpg",
    "nyu_vainf_office/image.png",
    "nyu_densedepth/267_image.png",
)
"""Photos whose lower half is a crop."""
CLOSE_UPS = {
    "sunrgbd_total3d_05/img.jpg": ("bed", (143, 186, 631, 529)),
    "sunrgbd_total3d_03/img.jpg": ("chair", (345, 218, 626, 529)),
    "sunrgbd_total3d_02/img.jpg": ("chair", (526, 218, 726, 502)),
    "sunrgbd_total3d_04/img.jpg": ("desk", (367, 214, 519, 441)),
}
"""Photo → (what, reference box x0 y0 x1 y1 in its pixels) of the close-ups."""
MARGIN = 0.15
"""A close-up's box is widened by this fraction of its size on every side (within the photo)."""


def crops(photos: Path) -> list[tuple[str, Path, tuple[int, int, int, int]]]:
    """(name, photo, window x0 y0 x1 y1) of every crop."""
    out = []
    for image in LOWER_HALVES:
        height, width = cv2.imread(str(photos / image)).shape[:2]
        out.append((f"{Path(image).parent.name}_lower_half", photos / image, (0, height // 2, width, height)))
    for image, (what, (x0, y0, x1, y1)) in CLOSE_UPS.items():
        height, width = cv2.imread(str(photos / image)).shape[:2]
        dx, dy = round(MARGIN * (x1 - x0)), round(MARGIN * (y1 - y0))
        window = (max(x0 - dx, 0), max(y0 - dy, 0), min(x1 + dx, width), min(y1 + dy, height))
        out.append((f"{Path(image).parent.name}_{what}_close_up", photos / image, window))
    return out


def focal_lengths(photos: Path) -> dict[str, tuple[str, str]]:
    """Image path (as index.csv names it) → (fx, fy) of the shared photos that have them."""
    with (photos / "index.csv").open(newline="") as fh:
        return {row["image"]: (row.get("fx", ""), row.get("fy", "")) for row in csv.DictReader(fh)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--photos", type=Path, default=PHOTOS, help="the shared photos (default: %(default)s)")
    parser.add_argument("--out", type=Path, required=True, help="the crops' folder, with its index.csv")
    args = parser.parse_args()
    focal = focal_lengths(args.photos)
    args.out.mkdir(parents=True, exist_ok=True)
    with (args.out / "index.csv").open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["image", "width", "height", "fx", "fy", "source"])
        for name, photo, (x0, y0, x1, y1) in crops(args.photos):
            image = cv2.imread(str(photo))[y0:y1, x0:x1]
            target = args.out / name / "photo.png"
            target.parent.mkdir(exist_ok=True)
            cv2.imwrite(str(target), image)
            fx, fy = focal.get(str(photo.relative_to(args.photos)), ("", ""))
            writer.writerow([f"{name}/photo.png", x1 - x0, y1 - y0, fx, fy, f"{photo.name} [{x0}:{x1}, {y0}:{y1}]"])
    print(f"{len(crops(args.photos))} crops in {args.out}")


if __name__ == "__main__":
    main()
