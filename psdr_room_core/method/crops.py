"""Crop pairs (§4.4): rectangular windows inside a part's rendered mask ∩ its target mask, compared in the
photo and in a render of the scene; and the user's crops file that takes their place.

A crop file sits beside the photo as ``<photo stem>.crops.yaml``::

    crops:
      - image: [x0, y0, x1, y1]      # photo pixels (x1, y1 exclusive)
        part: floor                  # the scene part it shows: floor, ceiling, wall_x_neg, object_12_seat ...
      - image: [410, 300, 470, 350]
        render: [400, 290, 460, 340] # or: the part is the one seen most in this window of the render

Rectangles are in the photo's pixels and scaled to the working resolution here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole

from .artifacts import Rect

CROPS_SUFFIX = ".crops.yaml"


def largest_rectangle(mask: np.ndarray, min_side: int = 1) -> tuple[Rect, int]:
    """The axis-aligned rectangle of largest area inside a boolean mask with both sides at least
    ``min_side``, ``((x0, y0, x1, y1), area)`` (area 0 when there is none): row by row, the largest rectangle
    under the histogram of run heights (every maximal rectangle is met, and a constrained optimum grows
    into one, so filtering them by side is exact)."""
    ys, xs = np.nonzero(mask)
    if not len(ys):
        return (0, 0, 0, 0), 0
    oy, ox = int(ys.min()), int(xs.min())
    box = mask[oy : ys.max() + 1, ox : xs.max() + 1]
    h, w = box.shape
    heights = np.zeros(w + 1, np.int64)  # a zero sentinel closes every run at the right
    best: tuple[Rect, int] = ((0, 0, 0, 0), 0)
    for y in range(h):
        heights[:w] = np.where(box[y], heights[:w] + 1, 0)
        row = heights.tolist()
        stack: list[int] = []
        for x in range(w + 1):
            while stack and row[stack[-1]] >= row[x]:
                height = row[stack.pop()]
                left = stack[-1] + 1 if stack else 0
                if height * (x - left) > best[1] and min(height, x - left) >= min_side:
                    best = ((ox + left, oy + y + 1 - height, ox + x, oy + y + 1), height * (x - left))
            stack.append(x)
    return best


def crop_windows(region: np.ndarray, max_crops: int, min_side: int, min_area: int) -> list[Rect]:
    """Up to ``max_crops`` disjoint rectangles inside ``region``, largest first: each is the largest rectangle
    with both sides at least ``min_side`` pixels in what the previous ones left, kept while its area is at
    least ``min_area``."""
    left = region.copy()
    windows: list[Rect] = []
    while len(windows) < max_crops:
        (x0, y0, x1, y1), area = largest_rectangle(left, min_side)
        if area < min_area or area == 0:
            break
        windows.append((x0, y0, x1, y1))
        left[y0:y1, x0:x1] = False
    return windows


@dataclass(frozen=True)
class UserCrop:
    """One crop of the user's file at the working resolution: a photo window and the part it shows, or the
    render window that names the part."""

    image: Rect
    part: str | None
    render: Rect | None


def crops_file(photo: Path) -> Path:
    """Where the user's crop pairs for ``photo`` are read from."""
    return photo.with_name(photo.stem + CROPS_SUFFIX)


def read_crops(path: Path, photo_size: tuple[int, int], working_size: tuple[int, int]) -> list[UserCrop]:
    """The crops of ``path`` scaled from the photo's (width, height) to the working one; a one-line error
    naming the file and the entry for anything malformed."""
    return check_crops(path, load_crops(path), photo_size, working_size)


def load_crops(path: Path) -> object:
    """The crops file's parsed YAML, unchecked (:func:`check_crops` checks it); one line when it is unreadable."""
    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise PsdrRoomError(
            f"{path}: unreadable crops file ({str(exc).splitlines()[0]}); fix the YAML or remove it"
        ) from None


def check_crops(path: Path, data: object, photo_size: tuple[int, int], working_size: tuple[int, int]) -> list[UserCrop]:
    """The crops of a crops file's parsed YAML ``data``, checked against the photo's (width, height) and scaled
    to the working size; errors name ``path`` and the entry."""
    if not isinstance(data, dict) or not isinstance(data.get("crops"), list):
        raise PsdrRoomError(
            f"{path}: expected a mapping with a 'crops:' list; see the format in psdr_room_core/method/crops.py"
        )
    sx, sy = working_size[0] / photo_size[0], working_size[1] / photo_size[1]

    def rect(value: object, where: str) -> Rect:
        if (
            not isinstance(value, list)
            or len(value) != 4
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
        ):
            raise PsdrRoomError(f"{path}: {where} must be [x0, y0, x1, y1] in photo pixels")
        x0, y0, x1, y1 = (float(v) for v in value)
        if not (0 <= x0 < x1 <= photo_size[0] and 0 <= y0 < y1 <= photo_size[1]):
            raise PsdrRoomError(
                f"{path}: {where} = {value} is not a non-empty window inside the {photo_size[0]}x{photo_size[1]} photo"
            )
        return (
            int(round(x0 * sx)),
            int(round(y0 * sy)),
            max(int(round(x1 * sx)), int(round(x0 * sx)) + 1),
            max(int(round(y1 * sy)), int(round(y0 * sy)) + 1),
        )

    crops = []
    for i, entry in enumerate(data["crops"]):
        where = f"crops[{i}]"
        if not isinstance(entry, dict) or "image" not in entry or ("part" in entry) == ("render" in entry):
            raise PsdrRoomError(f"{path}: {where} needs 'image' and exactly one of 'part' or 'render'")
        part = entry.get("part")
        if part is not None and not isinstance(part, str):
            raise PsdrRoomError(f"{path}: {where}.part must be a part name such as floor or object_12_seat")
        crops.append(
            UserCrop(
                image=rect(entry["image"], f"{where}.image"),
                part=part,
                render=rect(entry["render"], f"{where}.render") if "render" in entry else None,
            )
        )
    return crops


def write_crops(path: Path, entries: list[dict[str, object]], photo_size: tuple[int, int]) -> None:
    """Write ``entries`` (``{image: [x0, y0, x1, y1], part: name}`` or ``{image, render}``, photo pixels) as the
    crops file ``path`` after checking them as :func:`read_crops` will (a wrong one raises and writes nothing);
    the file appears whole or not at all."""
    data = {"crops": entries}
    check_crops(path, data, photo_size, photo_size)
    write_whole(path, yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
