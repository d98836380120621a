"""``detector=boxes_file``: object boxes a user wrote in a YAML file beside the photo.

``<photo stem>.boxes.yaml`` (or ``detector.boxes_file.path``)::

    boxes:
      - {label: sofa, category: object, box: [120, 340, 610, 590]}
      - {label: floor lamp, category: lamp, box: [650, 80, 730, 560]}

``box`` is ``[x0, y0, x1, y1]`` in pixels of the original photo as it is displayed (after its EXIF
orientation), e.g. as read in an image viewer; the boxes are scaled to the working image. ``category`` is
one of the room categories (default ``object``); ``label`` is free text kept with the box. Every box has
score 1.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from psdr_room_core.engine.bounded import size_text
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole
from psdr_room_core.method.artifacts import CATEGORIES, Detection, Detections, Image

KEYS = ("label", "category", "box")
MAX_BYTES = 4 << 20
"""The largest boxes file read (a thousand boxes take about 60 kB)."""
EXAMPLE = "boxes: [{label: sofa, category: object, box: [x0, y0, x1, y1]}]"


def sidecar_path(photo: Path) -> Path:
    """Where the boxes of ``photo`` are looked for by default."""
    return photo.with_name(f"{photo.stem}.boxes.yaml")


def _entry(path: Path, index: int, entry: Any, size: tuple[int, int]) -> Detection:
    """One validated entry, its box still in photo pixels."""
    where = f"{path}: boxes[{index}]"
    if not isinstance(entry, dict):
        raise PsdrRoomError(
            f"{where} is not a mapping; write it as {{label: NAME, category: object, box: [x0, y0, x1, y1]}}"
        )
    unknown = sorted(set(map(str, entry)) - set(KEYS))
    if unknown:
        raise PsdrRoomError(f"{where} has unknown key(s) {', '.join(unknown)}; use only {', '.join(KEYS)}")
    label, category, box = entry.get("label"), entry.get("category", "object"), entry.get("box")
    if not isinstance(label, str) or not label.strip():
        raise PsdrRoomError(f"{where}.label is missing or not text; give the object's name (e.g. label: sofa)")
    if category not in CATEGORIES:
        raise PsdrRoomError(f"{where}.category {category!r} is unknown; use one of {', '.join(CATEGORIES)}")
    if (
        not isinstance(box, list)
        or len(box) != 4
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in box)
    ):
        raise PsdrRoomError(f"{where}.box {box!r} is not four numbers; write it as [x0, y0, x1, y1] in photo pixels")
    x0, y0, x1, y1 = map(float, box)
    if not (x1 > x0 and y1 > y0):
        raise PsdrRoomError(
            f"{where}.box {box} is inverted or empty; write it as [x0, y0, x1, y1] with x1 > x0 and y1 > y0"
        )
    width, height = size
    if x0 < 0 or y0 < 0 or x1 > width or y1 > height:
        raise PsdrRoomError(
            f"{where}.box {box} is outside the {width}x{height} photo; give it in pixels "
            "of the photo as displayed (after EXIF rotation), within 0..width and 0..height"
        )
    return Detection(label=label.strip(), category=category, box=(x0, y0, x1, y1))


def read_boxes(path: Path, size: tuple[int, int]) -> list[Detection]:
    """The boxes of a boxes file, validated against the photo's ``size`` (width, height), in photo pixels."""
    try:
        with open(path, "rb") as file:
            text = file.read(MAX_BYTES + 1)
        if len(text) > MAX_BYTES:
            raise PsdrRoomError(
                f"{path}: {size_text(path.stat().st_size)}, larger than a boxes file ever is (at most "
                f"{size_text(MAX_BYTES)}); write one box a line ({EXAMPLE})"
            )
        data = yaml.safe_load(text)
    except FileNotFoundError:
        raise PsdrRoomError(
            f"{path}: no such boxes file; write one ({EXAMPLE}) or fix detector.boxes_file.path"
        ) from None
    except RecursionError:
        raise PsdrRoomError(f"{path}: nested too deep to read; write one box a line ({EXAMPLE})") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise PsdrRoomError(f"{path}: not valid YAML ({problem}{where}); fix the syntax ({EXAMPLE})") from None
    return check_boxes(path, data, size)


def check_boxes(path: Path, data: Any, size: tuple[int, int]) -> list[Detection]:
    """The boxes of a boxes file's parsed YAML ``data``, validated against the photo's ``size``; errors name
    ``path``."""
    if not isinstance(data, dict) or not isinstance(data.get("boxes"), list) or set(data) != {"boxes"}:
        raise PsdrRoomError(f"{path}: expected a single key 'boxes' holding a list; write it as {EXAMPLE}")
    return [_entry(path, i, entry, size) for i, entry in enumerate(data["boxes"])]


def write_boxes(path: Path, boxes: list[Detection], size: tuple[int, int]) -> None:
    """Write ``boxes`` (in photo pixels) as the boxes file ``path`` after checking them as :func:`read_boxes` will
    (a wrong box raises and writes nothing); the file appears whole or not at all."""
    data = {
        "boxes": [{"label": d.label, "category": d.category, "box": [round(float(v), 1) for v in d.box]} for d in boxes]
    }
    check_boxes(path, data, size)
    write_whole(path, yaml.safe_dump(data, sort_keys=False, default_flow_style=None))


def photo_scale(image: Image) -> tuple[float, float]:
    """Working-image pixels per photo pixel, along x and y (boxes files are in photo pixels)."""
    width, height = image.photo_size
    return image.width / width, image.height / height


def scaled(box: tuple[float, float, float, float], sx: float, sy: float) -> tuple[float, float, float, float]:
    """``box`` (x0, y0, x1, y1) with its x coordinates times ``sx`` and its y coordinates times ``sy``."""
    return box[0] * sx, box[1] * sy, box[2] * sx, box[3] * sy


class BoxesFile:
    """Object boxes from ``<photo stem>.boxes.yaml`` beside the photo (or ``path``), in photo pixels."""

    def __init__(self, path: str | None = None) -> None:
        self.path = Path(path).expanduser() if path else None

    def _file(self, photo: Path) -> Path:
        return self.path if self.path is not None else sidecar_path(photo)

    def external_files(self, photo: Path) -> list[Path]:
        return [self._file(photo)]

    def unavailable(self, photo: Path) -> str | None:
        file = self._file(photo)
        return None if file.is_file() else f"no boxes file {file}"

    def detect(self, image: Image, photo: Path) -> Detections:
        file = self._file(photo)
        sx, sy = photo_scale(image)
        items = [
            Detection(label=d.label, category=d.category, score=d.score, box=scaled(d.box, sx, sy))
            for d in read_boxes(file, image.photo_size)
        ]
        return Detections(items=items, source=str(file))


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import Detector

    _BoxesFile_is_a_detector: type[Detector] = BoxesFile
