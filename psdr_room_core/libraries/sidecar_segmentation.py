"""Readers for user-supplied segmentation files ("sidecars" next to a photo).

Two formats:

- COCO panoptic: an RGB PNG whose pixel id is ``R + 256*G + 256**2*B`` (0 = unlabelled) plus a JSON with
  ``segments_info`` and ``categories`` (one annotation, or a whole COCO file with ``annotations``). What
  :func:`psdr_room_core.method.artifacts.write_coco_panoptic` writes is one such annotation.
- LabelMe: a JSON of polygons / rectangles / circles / masks, rasterised in file order.

Class names are mapped to the room categories :data:`~psdr_room_core.method.artifacts.CATEGORIES` by
:func:`category_of`. The id map returned is int32 HxW; each core :class:`~psdr_room_core.method.artifacts.Segment`
names its id, category and original label. A file is parsed only within limits (its size, nesting, strings, the
pixels it declares); problems raise :class:`SidecarError` with a one-line message naming the file and the fix, which
shows at most :data:`~psdr_room_core.engine.bounded.ECHO` characters of a bad value.
"""

from __future__ import annotations

import base64
import binascii
import io
import json
import logging
import math
import re
import warnings
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from PIL import Image

from psdr_room_core.engine.bounded import JsonLimits, excerpt, load_json
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import SeenBox, Segment, box4, panoptic_ids

from .sidecar_depth import MAX_SIDECAR_PIXELS, SidecarError

log = logging.getLogger("psdr_room")

__all__ = [
    "BACKGROUND_LABELS",
    "SidecarError",
    "category_of",
    "find_segmentation_sidecar",
    "panoptic_json_for",
    "read_coco_panoptic",
    "read_labelme",
    "studio_segmentation_path",
]

BACKGROUND_LABELS = frozenset({"_background_", "background", "unlabeled", "unlabelled", "void", "ignore", "none"})
"""LabelMe labels that mean "no segment" (their pixels are set to 0)."""
LABELME_LIMITS = JsonLimits(max_bytes=256_000_000, max_string=256_000_000)
"""What a LabelMe file may hold (its ``imageData`` is the whole photo, base64-encoded)."""
PANOPTIC_LIMITS = JsonLimits(max_bytes=256_000_000)
"""What a COCO-panoptic JSON (one annotation, or a whole COCO file) may hold."""


# ------------------------------------------------------------------------------------- categories
# A class name is lower-cased, split into alternatives at "," ";" "/" (ADE20K: "windowpane, window"),
# each alternative into words at "-" "_" and spaces; COCO suffix words (other, merged, stuff) and
# instance numbers ("wall2", "chair 3") are dropped and plurals made singular. Then, in order:
# 1. the whole phrase is looked up in _PHRASES;
# 2. the last word (the head noun in English: "floor lamp", "ceiling light") in _HEAD_NOUNS;
# 3. COCO "surface-material" names: first word a surface, the rest materials ("wall-brick", "floor-wood").
# The first alternative that is not "object" wins; everything else is an object.
_HEAD_NOUNS = {
    "wall": "wall",
    "floor": "floor",
    "flooring": "floor",
    "rug": "floor",
    "carpet": "floor",
    "carpeting": "floor",
    "ceiling": "ceiling",
    "window": "window",
    "windowpane": "window",
    "skylight": "window",
    "blind": "window",
    "door": "door",
    "doorway": "door",
    "doorframe": "door",
    "lamp": "lamp",
    "light": "lamp",
    "lighting": "lamp",
    "chandelier": "lamp",
    "sconce": "lamp",
    "lampshade": "lamp",
    "spotlight": "lamp",
    "downlight": "lamp",
    "bulb": "lamp",
    "lantern": "lamp",
}
_PHRASES = {
    "mat": "floor",
    "floor mat": "floor",
    "door mat": "floor",
    "doormat": "floor",
    "bath mat": "floor",
    "window shade": "window",
    "window frame": "window",
    "window pane": "window",
    "door frame": "door",
    "lamp shade": "lamp",
    "light source": "lamp",
    "light fixture": "lamp",
    "pendant lamp": "lamp",
    "light switch": "object",
    "switch": "object",
}
_SURFACES = ("wall", "floor", "ceiling", "window", "door")
_MATERIALS = frozenset(
    {
        "brick",
        "stone",
        "tile",
        "tiled",
        "wood",
        "wooden",
        "panel",
        "paneling",
        "panelling",
        "concrete",
        "marble",
        "plaster",
        "painted",
        "paint",
        "glass",
        "metal",
        "laminate",
        "vinyl",
        "parquet",
        "granite",
        "cement",
        "ceramic",
        "mosaic",
        "board",
        "drywall",
    }
)
_DROP_WORDS = frozenset({"other", "merged", "stuff", "the", "a"})


def _singular(word: str) -> str:
    if len(word) > 3 and word.endswith("s") and not word.endswith("ss"):
        return word[:-1]
    return word


def _words(name: str) -> list[str]:
    words = []
    for word in re.split(r"[\s_\-]+", name):
        word = re.sub(r"\d+$", "", word.strip("()[]{}.:#'\""))
        if word and word not in _DROP_WORDS:
            words.append(_singular(word))
    return words


def _category_one(name: str) -> str:
    words = _words(name)
    if not words:
        return "object"
    phrase = " ".join(words)
    if phrase in _PHRASES:
        return _PHRASES[phrase]
    if words[-1] in _HEAD_NOUNS:
        return _HEAD_NOUNS[words[-1]]
    if words[0] in _SURFACES and all(w in _MATERIALS for w in words[1:]):
        return words[0]
    return "object"


def category_of(label: str) -> str:
    """Map a class name (COCO-panoptic, ADE20K, NYU-40, free text) to one of the core ``CATEGORIES``.

    Case-insensitive; tolerant of ``-other-merged``/``-stuff`` suffixes, ``_`` and plurals. Rugs and
    carpets count as floor (they lie flat on it), blinds as window, light fixtures as lamp.
    """
    for alternative in re.split(r"[,;/|]", str(label).lower()):
        category = _category_one(alternative)
        if category != "object":
            return category
    return "object"


# ------------------------------------------------------------------------------------ sidecar lookup
def studio_segmentation_path(photo: Path) -> Path:
    """Where psdr-room-studio keeps its own copy of a photo's segmentation: ``<stem>.studio.panoptic.png`` (and
    its ``.json``), the user's segmentation (or the automatic one) with the studio's boxes and marks applied."""
    return Path(photo).with_name(Path(photo).stem + ".studio.panoptic.png")


def find_segmentation_sidecar(photo: Path) -> tuple[str, Path] | None:
    """Return the segmentation file beside ``photo``: the studio's copy (:func:`studio_segmentation_path`), else
    ``("labelme", <stem>.labelme.json)``, else ``("coco_panoptic", <stem>.panoptic.png)``; None when there is none.
    A panoptic PNG's JSON is expected beside it (:func:`panoptic_json_for`)."""
    photo = Path(photo)
    studio = studio_segmentation_path(photo)
    if studio.is_file():
        return ("coco_panoptic", studio)
    labelme = photo.with_name(photo.stem + ".labelme.json")
    if labelme.is_file():
        return ("labelme", labelme)
    panoptic = photo.with_name(photo.stem + ".panoptic.png")
    if panoptic.is_file():
        return ("coco_panoptic", panoptic)
    return None


def panoptic_json_for(png: Path) -> Path:
    """The JSON expected beside a panoptic PNG: ``x.panoptic.png`` -> ``x.panoptic.json``."""
    return Path(png).with_suffix(".json")


# ---------------------------------------------------------------------------------- COCO panoptic
def _load_json(path: Path, what: str, limits: JsonLimits) -> Any:
    try:
        return load_json(path, limits, f"check this is the {what}")
    except PsdrRoomError as exc:
        raise SidecarError(str(exc)) from None
    except FileNotFoundError:
        raise SidecarError(f"{path}: {what} not found; create it or fix the path") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SidecarError(f"{path}: cannot read the {what} ({exc}); check the file and its permissions") from None
    except json.JSONDecodeError as exc:
        raise SidecarError(
            f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg}); fix the syntax"
        ) from None


def _as_int(value: Any, path: Path, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != int(value):
        raise SidecarError(f"{path}: {what} must be an integer, got {excerpt(repr(value))}; fix the JSON")
    return int(value)


def _open_image(source: Path | io.BytesIO) -> Image.Image:
    """The image at ``source``, its header read only; over :data:`MAX_SIDECAR_PIXELS` (or PIL's decompression-bomb
    limit) raises ValueError before any pixel is decoded."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", Image.DecompressionBombWarning)
        try:
            im = Image.open(source)
        except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
            raise ValueError(str(exc)) from None
    if im.width * im.height > MAX_SIDECAR_PIXELS:
        im.close()
        raise ValueError(f"{im.width}x{im.height} pixels, over the {MAX_SIDECAR_PIXELS:,} of the largest photo")
    return im


def _read_panoptic_png(png: Path) -> np.ndarray:
    if not png.is_file():
        raise SidecarError(f"{png}: panoptic PNG not found; put the COCO-panoptic PNG there or fix the path")
    try:
        with _open_image(png) as im:
            im.load()
            mode = im.mode
            arr = np.array(im)
    except (OSError, ValueError) as exc:
        raise SidecarError(
            f"{png}: not a readable image ({exc}); save the id map as an RGB PNG (id = R + 256*G + 256^2*B)"
        ) from None
    if mode in ("RGB", "RGBA"):
        return panoptic_ids(arr)
    if mode in ("L", "P", "I;16", "I;16B", "I;16L", "I"):  # ids stored directly (e.g. LabelMe's label.png)
        ids = arr.astype(np.int64)
        if ids.min() < 0 or ids.max() > np.iinfo(np.int32).max:
            raise SidecarError(f"{png}: ids out of range; store ids 0..2^31-1 (or use an RGB PNG)")
        return ids.astype(np.int32)
    raise SidecarError(f"{png}: unsupported PNG mode {mode}; save the id map as an RGB PNG (id = R + 256*G + 256^2*B)")


def _pick_annotation(doc: dict, png: Path, json_path: Path) -> dict:
    if "segments_info" in doc:
        return doc
    anns = doc.get("annotations")
    if not isinstance(anns, list) or not anns:
        raise SidecarError(
            f"{json_path}: unknown JSON structure (no 'segments_info' and no 'annotations' list); "
            f'write COCO panoptic: {{"segments_info": [{{"id", "category_id"}}], "categories": [{{"id", "name"}}]}}'
        )
    if not all(isinstance(a, dict) for a in anns):
        raise SidecarError(f"{json_path}: 'annotations' must be a list of objects; fix the JSON")
    for match in (
        lambda a: str(a.get("file_name", "")) == png.name,
        lambda a: Path(str(a.get("file_name", ""))).stem == png.stem,
    ):
        found = [a for a in anns if match(a)]
        if found:
            return found[0]
    if len(anns) == 1:  # a renamed single-image file (e.g. photo.panoptic.png)
        return anns[0]
    names = ", ".join(excerpt(str(a.get("file_name"))) for a in anns[:3]) + (", ..." if len(anns) > 3 else "")
    raise SidecarError(
        f"{json_path}: no annotation has file_name {png.name!r} (found {names}); rename the PNG or fix file_name"
    )


def read_coco_panoptic(png: Path, json_path: Path) -> tuple[np.ndarray, list[Segment]]:
    """Read a COCO-panoptic PNG + JSON. Returns (int32 HxW id map, 0 = unlabelled; segments).

    The JSON is a single annotation (``segments_info`` + ``categories``) or a full COCO panoptic file
    (``annotations`` + ``categories``; the annotation whose ``file_name`` matches the PNG is used). A
    segment's label is its ``label`` field if present, else its category name; the ``score``, ``prompt_box``,
    ``second_opinion`` and ``seen_box`` :func:`~psdr_room_core.method.artifacts.write_coco_panoptic` writes for an
    automatic object are read back.
    """
    png, json_path = Path(png), Path(json_path)
    if not json_path.is_file():
        raise SidecarError(
            f"{png}: no segment JSON beside it (expected {json_path.name}); "
            f"write the COCO panoptic segments_info and categories there"
        )
    ids = _read_panoptic_png(png)
    doc = _load_json(json_path, "panoptic JSON", PANOPTIC_LIMITS)
    if not isinstance(doc, dict):
        raise SidecarError(
            f"{json_path}: unknown JSON structure (top level is not an object); write a COCO panoptic annotation object"
        )
    ann = _pick_annotation(doc, png, json_path)
    infos = ann.get("segments_info")
    if not isinstance(infos, list):
        raise SidecarError(
            f'{json_path}: \'segments_info\' must be a list of {{"id", "category_id"}} objects; fix the JSON'
        )

    cats = doc.get("categories", ann.get("categories"))
    names: dict[int, str] = {}
    if cats is not None:
        if not isinstance(cats, list) or not all(isinstance(c, dict) and "id" in c and "name" in c for c in cats):
            raise SidecarError(f'{json_path}: \'categories\' must be a list of {{"id", "name"}} objects; fix the JSON')
        names = {_as_int(c["id"], json_path, "category id"): str(c["name"]) for c in cats}

    segments: list[Segment] = []
    seen: set[int] = set()
    for k, info in enumerate(infos):
        if not isinstance(info, dict) or "id" not in info:
            raise SidecarError(f"{json_path}: segments_info[{k}] has no 'id'; give every segment its PNG id")
        sid = _as_int(info["id"], json_path, f"segments_info[{k}].id")
        if sid <= 0:
            raise SidecarError(f"{json_path}: segments_info[{k}] has id {sid}; ids must be > 0 (0 is unlabelled)")
        if sid in seen:
            raise SidecarError(f"{json_path}: segment id {sid} is listed twice; give each segment one entry")
        seen.add(sid)
        label = info.get("label")
        if "category_id" in info:
            cid = _as_int(info["category_id"], json_path, f"segments_info[{k}].category_id")
            if cid not in names:
                fix = "add it to 'categories'" if names else 'add a \'categories\' list of {"id", "name"}'
                raise SidecarError(f"{json_path}: segment {sid} has category_id {cid}, which has no name; {fix}")
            cat_name = names[cid]
        elif isinstance(label, str):
            cat_name = label
        else:
            raise SidecarError(
                f"{json_path}: segment {sid} has no category_id; add one (and its name under 'categories')"
            )
        if not isinstance(label, str) or not label:
            label = cat_name
        score, box = info.get("score"), info.get("prompt_box")
        if score is not None and not isinstance(score, (int, float)):
            raise SidecarError(
                f"{json_path}: segment {sid} has score {excerpt(repr(score))}; give a number or leave it out"
            )
        if box is not None and not (
            isinstance(box, list) and len(box) == 4 and all(isinstance(v, (int, float)) for v in box)
        ):
            raise SidecarError(
                f"{json_path}: segment {sid} has prompt_box {excerpt(repr(box))}; give [x0, y0, x1, y1] or leave it out"
            )
        opinion = info.get("second_opinion")
        if opinion is not None and not isinstance(opinion, str):
            raise SidecarError(
                f"{json_path}: segment {sid} has second_opinion {excerpt(repr(opinion))}; "
                "give a label (text) or leave it out"
            )
        seen_box = info.get("seen_box")
        try:
            seen_3d = None if seen_box is None else SeenBox.from_json(seen_box)
        except (ValueError, TypeError) as exc:
            raise SidecarError(
                f"{json_path}: segment {sid} has seen_box {excerpt(repr(seen_box))} ({exc}); "
                "give center, size, yaw and confidence as psdr-room writes them, or leave it out"
            ) from None
        segments.append(
            Segment(
                sid,
                category_of(cat_name),
                label,
                None if score is None else float(score),
                None if box is None else box4(box),
                opinion,
                seen_3d,
            )
        )

    present = np.unique(ids)
    present = present[present != 0]
    missing = sorted(seen - set(present.tolist()))
    if missing:
        listed = ", ".join(map(str, missing[:5])) + (", ..." if len(missing) > 5 else "")
        raise SidecarError(
            f"{json_path}: segment id(s) {listed} not present in {png.name}; remove them from segments_info "
            f"or check the PNG is the one the JSON describes (id = R + 256*G + 256^2*B)"
        )
    extra = sorted(set(present.tolist()) - seen)
    if extra:
        listed = ", ".join(map(str, extra[:5])) + (", ..." if len(extra) > 5 else "")
        raise SidecarError(
            f"{png}: pixel id(s) {listed} are not in {json_path.name}; list them in segments_info or paint them black (id 0)"
        )
    return ids.astype(np.int32, copy=False), segments


# ------------------------------------------------------------------------------------------ LabelMe
def _fill_polygon(mask: np.ndarray, xy: np.ndarray) -> None:
    """Set ``mask`` to 1 at pixels whose centre ``(i + 0.5, j + 0.5)`` lies inside polygon ``xy`` (even-odd)."""
    h, w = mask.shape
    x0, y0 = xy[:, 0], xy[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    r0 = max(math.floor(y0.min() - 0.5), 0)
    r1 = min(math.ceil(y0.max() + 0.5), h)
    if r1 <= r0:
        return
    yc = np.arange(r0, r1, dtype=np.float64)[:, None] + 0.5
    crosses = (y0 <= yc) != (y1 <= yc)  # half-open: a vertex on the scanline counts once
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = np.where(crosses, x0 + (yc - y0) / (y1 - y0) * (x1 - x0), np.inf)
    xs.sort(axis=1)
    n_pairs = int(crosses.sum(axis=1).max()) // 2
    if n_pairs == 0:
        return
    left, right = xs[:, 0 : 2 * n_pairs : 2], xs[:, 1 : 2 * n_pairs : 2]
    ok = np.isfinite(right)
    start = np.clip(np.ceil(left - 0.5), 0, w).astype(np.int64)
    end = np.clip(np.ceil(right - 0.5), 0, w).astype(np.int64)
    rows = np.broadcast_to(np.arange(r1 - r0)[:, None], left.shape)
    diff = np.zeros((r1 - r0, w + 1), dtype=np.int32)
    np.add.at(diff, (rows[ok], start[ok]), 1)
    np.add.at(diff, (rows[ok], end[ok]), -1)
    mask[r0:r1] |= (np.cumsum(diff[:, :w], axis=1) > 0).astype(mask.dtype)


def _points(shape: dict, k: int, json_path: Path) -> np.ndarray:
    pts = shape.get("points")
    try:
        arr = np.asarray(pts, dtype=np.float64) if pts != [] else np.zeros((0, 2))
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.ndim != 2 or arr.shape[1] != 2 or not np.all(np.isfinite(arr)):
        raise SidecarError(
            f"{json_path}: shape {k} ({excerpt(repr(shape.get('label')))}) has malformed points; "
            "give a list of [x, y] pairs"
        )
    return arr.reshape(-1, 2)


def _decode_mask(shape: dict, k: int, json_path: Path) -> np.ndarray:
    data = shape.get("mask")
    if not isinstance(data, str):
        raise SidecarError(
            f"{json_path}: mask shape {k} ({excerpt(repr(shape.get('label')))}) has no base64 'mask'; "
            "redraw it or use a polygon"
        )
    try:
        with _open_image(io.BytesIO(base64.b64decode(data))) as im:
            return np.array(im.convert("L")) > 0
    except (binascii.Error, OSError, ValueError):
        raise SidecarError(
            f"{json_path}: mask shape {k} ({excerpt(repr(shape.get('label')))}) has an unreadable or oversized "
            "'mask' image; redraw it or use a polygon"
        ) from None


def read_labelme(json_path: Path, shape: tuple[int, int] | None = None) -> tuple[np.ndarray, list[Segment]]:
    """Rasterise a LabelMe JSON into (int32 HxW id map, 0 = unlabelled; segments).

    Shapes are drawn in file order, later over earlier. Shapes with the same label and a non-null
    ``group_id`` form one segment; every other shape is its own segment (ids 1, 2, ... by first
    appearance). Points are continuous image coordinates (pixel ``i`` spans ``[i, i+1)``); a pixel is
    filled when its centre is inside. When ``shape`` (H, W) differs from the file's imageHeight/Width the
    points are scaled. polygon, rectangle, circle and mask shapes have area; line/linestrip/point shapes
    and background labels (``_background_``...) are skipped. Segments left without pixels are dropped; a shape
    that covers no pixel of its own is logged as a warning.
    """
    json_path = Path(json_path)
    doc = _load_json(json_path, "LabelMe JSON", LABELME_LIMITS)
    if not isinstance(doc, dict) or not isinstance(doc.get("shapes"), list):
        raise SidecarError(
            f"{json_path}: not a LabelMe file (no 'shapes' list); save it from LabelMe or add \"shapes\": [...]"
        )
    try:
        file_h = int(doc["imageHeight"]) if doc.get("imageHeight") is not None else None
        file_w = int(doc["imageWidth"]) if doc.get("imageWidth") is not None else None
    except (TypeError, ValueError):
        raise SidecarError(
            f"{json_path}: imageHeight/imageWidth must be integers; fix them to the photo's size"
        ) from None
    if file_h is None or file_w is None:
        if shape is None:
            raise SidecarError(f"{json_path}: no imageHeight/imageWidth; add the photo's size to the JSON")
        file_h, file_w = int(shape[0]), int(shape[1])
    if file_h <= 0 or file_w <= 0:
        raise SidecarError(
            f"{json_path}: imageHeight/imageWidth must be positive, got {file_h}x{file_w}; fix them to the photo's size"
        )
    if file_h * file_w > MAX_SIDECAR_PIXELS:
        raise SidecarError(
            f"{json_path}: imageHeight/imageWidth {file_h}x{file_w} is over the {MAX_SIDECAR_PIXELS:,} pixels of the "
            "largest photo; fix them to the photo's size"
        )
    out_h, out_w = (int(shape[0]), int(shape[1])) if shape is not None else (file_h, file_w)
    sx, sy = out_w / file_w, out_h / file_h

    ids = np.zeros((out_h, out_w), dtype=np.int32)
    segments: list[Segment] = []
    groups: dict[tuple[str, Any], int] = {}
    for k, shp in enumerate(doc["shapes"]):
        if not isinstance(shp, dict):
            raise SidecarError(f"{json_path}: shape {k} is not an object; fix the 'shapes' list")
        label = shp.get("label")
        if not isinstance(label, str) or not label.strip():
            raise SidecarError(
                f"{json_path}: shape {k} has no label; give it a class name such as wall, floor or chair"
            )
        label = label.strip()
        kind = excerpt(str(shp.get("shape_type") or "polygon").lower())
        if kind in ("line", "linestrip", "point", "points") or label.lower() in BACKGROUND_LABELS:
            continue
        pts = _points(shp, k, json_path)
        where = f"{json_path}: shape {k} ({excerpt(repr(label))}, {kind})"
        mask: np.ndarray = np.zeros((out_h, out_w), dtype=np.uint8)
        if kind == "polygon":
            if len(pts) < 3:
                raise SidecarError(
                    f"{where} has {len(pts)} point(s); a polygon needs at least 3 — add points or delete it"
                )
            _fill_polygon(mask, pts * (sx, sy))
        elif kind == "rectangle":
            if len(pts) != 2:
                raise SidecarError(f"{where} has {len(pts)} points; a rectangle needs 2 opposite corners — redraw it")
            (x0, y0), (x1, y1) = pts * (sx, sy)
            _fill_polygon(mask, np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
        elif kind == "circle":
            if len(pts) != 2:
                raise SidecarError(
                    f"{where} has {len(pts)} points; a circle needs its centre and one point on it — redraw it"
                )
            (cx, cy), (px, py) = pts
            rx, ry = math.hypot(px - cx, py - cy) * sx, math.hypot(px - cx, py - cy) * sy
            yy, xx = np.mgrid[0:out_h, 0:out_w]
            inside = ((xx + 0.5 - cx * sx) / max(rx, 1e-9)) ** 2 + ((yy + 0.5 - cy * sy) / max(ry, 1e-9)) ** 2 <= 1.0
            mask[inside] = 1
        elif kind == "mask":
            if len(pts) != 2:
                raise SidecarError(f"{where} has {len(pts)} points; a mask needs its 2 box corners — redraw it")
            small = _decode_mask(shp, k, json_path).astype(np.uint8)
            x0, y0 = round(float(pts[:, 0].min())), round(float(pts[:, 1].min()))
            full = np.zeros((file_h, file_w), dtype=np.uint8)
            h, w = small.shape
            ya, xa = max(y0, 0), max(x0, 0)
            yb, xb = min(y0 + h, file_h), min(x0 + w, file_w)
            if yb > ya and xb > xa:
                full[ya:yb, xa:xb] = small[ya - y0 : yb - y0, xa - x0 : xb - x0]
            mask = (
                full
                if (out_h, out_w) == (file_h, file_w)
                else cv2.resize(full, (out_w, out_h), interpolation=cv2.INTER_NEAREST)
            )
        else:
            raise SidecarError(f"{where}: unsupported shape_type {kind!r}; use polygon, rectangle, circle or mask")

        if not mask.any():
            _warn_empty(json_path, k, label, pts, (file_w, file_h))
        group = shp.get("group_id")
        if isinstance(group, bool) or not isinstance(group, (int, str, type(None))):
            raise SidecarError(
                f"{where}: group_id must be an integer or null, got {excerpt(repr(group))}; fix it in the JSON"
            )
        key = (label, group)
        if group is not None and key in groups:
            sid = groups[key]
        else:
            sid = len(segments) + 1
            segments.append(Segment(sid, category_of(label), label))
            if group is not None:
                groups[key] = sid
        ids[mask.astype(bool)] = sid

    present = set(np.unique(ids).tolist())
    return ids, [s for s in segments if s.id in present]


def _warn_empty(json_path: Path, k: int, label: str, points: np.ndarray, size: tuple[int, int]) -> None:
    """One warning line for a shape that covers no pixel (``points`` and ``size``: in the file's pixels)."""
    width, height = size
    (x0, y0), (x1, y1) = points.min(axis=0), points.max(axis=0)
    outside = x1 <= 0 or y1 <= 0 or x0 >= width or y0 >= height
    why = f"lies outside the {width}x{height} photo" if outside else "covers no pixel centre"
    log.warning("%s: shape %d (%s) %s; dropped (fix its points or delete it)", json_path, k, excerpt(repr(label)), why)
