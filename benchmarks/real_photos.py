"""Photo → scene on real photos with nothing beside them: what a new user gets from a bare photo.

Every photo named by the folder's ``index.csv`` (the layout of ``../shared/data/photos/index.csv``: columns
``image``, ``width``, ``height``, ``fx``, ``fy``, ``gt_depth``, ``gt_depth_format``, ``gt_boxes``, ...) is
copied alone into a temporary folder and run through the ``psdr-room`` command with default settings (plus
``--set`` overrides) and one cache shared by all photos. Per photo it prints:

* ``FoV err``: estimated minus true vertical field of view, where ``fy`` is known;
* ``segs`` / ``fit``: object segments of the segmentation, objects in the fitted scene;
* reference furniture recall, where the folder has reference 2D boxes (a ``detections.json`` list of
  ``{"bbox": [x0, y0, x1, y1], "class": NAME}``, or an mmdetection3d SUN RGB-D ``*infos.pkl``): the
  references whose class :data:`REFERENCE_CLASSES` maps to database categories (the others are ignored),
  matched one-to-one (greedy, best IoU first) at box IoU >= 0.5 by an object segment's box (``seg``), by a
  placed object before the joint fit (``placed``: ``place_objects``' poses) and by a fitted object (``obj``:
  the box of its mesh projected with the fitted camera, its database category among the reference's), so
  that a piece lost between perception and the scene shows in which stage it was lost;
* what the object stage did with what perception found (:mod:`psdr_room_core.method.physical`'s measures):
  ``lost``: references matched by an object segment but by no fitted object; ``dup``: pairs of fitted objects
  of one category that are one thing twice (sharing half the smaller one's volume, or half their silhouettes);
  ``size``: fitted
  objects outside their category's real sizes (:mod:`psdr_room_core.method.sizes`); ``pen``: pairs passing
  through each other by more than 5 cm; ``out``: objects reaching more than 5 cm beyond the final room box;
  ``hid``: fitted objects the others hide (in the scene's render from the photo's camera they explain less than
  half of the pixels of their segment they explain alone);
* in 3D, where the photo's folder has Total3D's SUN RGB-D ground truth (``gt_3d_total3d.json``, read by
  :mod:`boxes3d`): for the references the fitted objects recall, 3D box IoU, centre, size and yaw errors; the
  3D IoU of the final room box and the reference layout; the fitted camera's pitch and roll errors (a second
  table);
* ``si-log`` / ``AbsRel`` / ``δ1`` (share of pixels within 1.25× after a median scale) of the estimated depth
  against sensor depth (a ``*depth*`` image in the photo's folder, decoded as ``gt_depth_format`` says), on
  the pixels both have;
* ``w/f/c``: wall/floor/ceiling pixel accuracy of the segmentation against the polygons drawn by hand in
  ``benchmarks/layout_labels/`` (LabelMe files whose ``imagePath`` names the photo as ``index.csv`` does; only
  the pixels they label count);
* RMSE (1/8-size images) and SSIM of the render against the photo at initialisation and after the fit;
* the wall time of the run; a second table gives every stage's compute time;
* what the run guessed (:mod:`psdr_room_core.method.guesses`: a weak FoV, a floor the photo does not show),
  below the table, and the runs that failed, each with its error line (the other photos still run).

Totals per column close the table. A contact sheet per photo (photo with reference boxes | segmentation |
fitted objects' outlines | final render) is written to ``OUT/sheets/<photo>.png``; the rows to
``OUT/rows.json`` (``--save FILE`` elsewhere), and ``--compare FILE`` prints an earlier run's recall and
fit columns beside this one's.

    python benchmarks/real_photos.py [--photos DIR] [--only NAME ...] [--set KEY=VALUE ...]
                                     [--until STAGE] [--out DIR] [--compare rows.json]
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import math
import os
import pickle
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine import shipped
from psdr_room_core.libraries.object_db import ObjectDatabase, builtin_database
from psdr_room_core.libraries.sidecar_depth import read_depth
from psdr_room_core.method.artifacts import Camera, DepthMap, Image, Panoptic, Placement, Placements, RoomBox
from psdr_room_core.method.guesses import guesses
from psdr_room_core.method.image_boxes import box_iou, mask_box
from psdr_room_core.method.objects import OBJECT_CATEGORIES
from psdr_room_core.method.physical import hidden_by, interpenetrations, room_excess
from psdr_room_core.method.silhouette import depth_map, silhouette
from psdr_room_core.method.sizes import scale_range
from psdr_room_core.method.solids import overlap
from psdr_room_core.method.visualize import segment_overlay

sys.path.insert(0, str(Path(__file__).resolve().parent))
import boxes3d  # noqa: E402  (sibling benchmark module)
from objects import EXACT, symmetry_period  # noqa: E402  (sibling benchmark)
from preprocess import depth_errors  # noqa: E402  (sibling benchmark)

REPO = Path(__file__).resolve().parents[1]
LAYOUT_LABELS = REPO / "benchmarks" / "layout_labels"
PHOTOS = REPO.parent / "shared" / "data" / "photos"
OUT = REPO / "outputs" / "benchmarks" / "real_photos"
IOU = 0.5
PENETRATION = 0.05
"""Interpenetration (and reach beyond the room box) counted, metres."""

REFERENCE_CLASSES: dict[str, tuple[str, ...] | None] = {
    # furniture: the database categories a fitted model may have to count
    "chair": ("chair",),
    "sofa_chair": ("chair", "sofa"),
    "stool": ("chair", "ottoman"),
    "sofa": ("sofa",),
    "ottoman": ("ottoman", "sofa"),
    "table": ("table", "desk"),
    "desk": ("desk", "table"),
    "coffee_table": ("table",),
    "end_table": ("table", "cabinet"),
    "bed": ("bed",),
    "dresser": ("cabinet",),
    "night_stand": ("cabinet", "table"),
    "cabinet": ("cabinet", "shelf"),
    "counter": ("cabinet",),
    "kitchen_cabinet": ("cabinet",),
    "bookshelf": ("shelf", "cabinet"),
    "shelf": ("shelf", "cabinet"),
    "refridgerator": ("refrigerator",),
    "refrigerator": ("refrigerator",),
    "microwave": ("appliance",),
    "oven": ("appliance",),
    "stove": ("appliance",),
    "tv": ("tv",),
    "monitor": ("tv",),
    "computer": ("tv",),
    "lamp": ("lamp",),
    "floor_lamp": ("lamp",),
    "picture": ("frame",),
    "mirror": ("frame",),
    "whiteboard": ("frame",),
    "box": ("box",),
    "basket": ("box",),
    "bin": ("box",),
    "rug": ("rug",),
    "plant": ("plant",),
    # not furniture, or not something the database models: ignored
    "pillow": None,
    "books": None,
    "book": None,
    "paper": None,
    "void": None,
    "bag": None,
    "clothes": None,
    "towel": None,
    "person": None,
    "curtain": None,
    "blinds": None,
    "window": None,
    "door": None,
    "wall": None,
    "floor": None,
    "ceiling": None,
    "floor_mat": None,
    "shower_curtain": None,
    "toilet": None,
    "sink": None,
    "bathtub": None,
    "counter_top": None,
}
"""Reference class (SUN RGB-D / NYU-37 spelling, lower case, spaces as ``_``) → the object database categories
that count as agreeing with it; ``None``: not furniture the scene should hold, ignored. A class missing here is
ignored and named under the table, so a new folder's classes are noticed."""

MMDET3D_SUNRGBD = ("bed", "table", "sofa", "chair", "toilet", "desk", "dresser", "night_stand", "bookshelf", "bathtub")
"""Class order of mmdetection3d's SUN RGB-D infos (``bbox_label``)."""


# --------------------------------------------------------------------------------------------- the photos
@dataclass(frozen=True)
class Entry:
    """One row of ``index.csv`` and the files it names."""

    name: str
    image: Path
    size: tuple[int, int]
    """(width, height) of the photo file."""
    fy: float | None
    depth: tuple[Path, str, float] | None
    """Sensor depth: file, encoding (``png16`` or ``sun``), units per metre."""
    boxes: Path | None


def _depth_format(text: str) -> tuple[str, float]:
    """(encoding, units per metre) from ``gt_depth_format`` ("uint16 PNG mm (scale 1000)", "uint16 PNG (/5000 = m)",
    "uint16 SUN encoding (...)")."""
    if "sun" in text.lower():
        return "sun", 1000.0
    number = re.search(r"(?:scale\s*|/\s*)(\d+(?:\.\d+)?)", text)
    return "png16", float(number.group(1)) if number else 1000.0


def _beside(image: Path, pattern: str) -> Path | None:
    found = sorted(p for p in image.parent.glob(pattern) if p != image and p.is_file())
    return found[0] if len(found) == 1 else None


def read_index(folder: Path) -> list[Entry]:
    """The photos of ``folder/index.csv`` with the ground truth each one has."""
    index = folder / "index.csv"
    if not index.is_file():
        sys.exit(
            f"real_photos: {index} is missing; --photos must name a folder with an index.csv "
            f"laid out as {PHOTOS / 'index.csv'}"
        )
    entries = []
    with index.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    folders = [Path(row["image"]).parent for row in rows]
    for row in rows:
        image = folder / row["image"]
        if not image.is_file():
            sys.exit(f"real_photos: {image} (named in {index}) is missing")
        depth = None
        if row.get("gt_depth", "").strip().lower() == "yes":
            file = _beside(image, "*depth*.png") or _beside(image, "*depth*.npy") or _beside(image, "*depth*.exr")
            if file is not None:
                depth = (file, *_depth_format(row.get("gt_depth_format", "")))
        boxes = None
        note = row.get("gt_boxes", "")
        if note.strip().lower() not in ("", "no"):
            boxes = next(
                (image.parent / w for w in re.findall(r"[\w.\-]+\.(?:json|pkl)", note) if (image.parent / w).is_file()),
                None,
            ) or _beside(image, "*infos.pkl")
        fy = row.get("fy", "").strip()
        shared = folders.count(Path(row["image"]).parent) > 1 or image.parent == folder
        name = f"{image.parent.name}_{image.stem}" if shared else image.parent.name
        entries.append(
            Entry(
                name=name,
                image=image,
                size=(int(row["width"]), int(row["height"])),
                fy=float(fy) if fy else None,
                depth=depth,
                boxes=boxes,
            )
        )
    return entries


class _NumpyOnly(pickle.Unpickler):
    """Unpickles plain containers and numpy scalars/arrays only: a benchmark folder is data, not code."""

    def find_class(self, module: str, name: str) -> type:
        if module.split(".")[0] == "numpy" or (module, name) == ("_codecs", "encode"):  # numpy scalars' bytes
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"{module}.{name} is not allowed in a reference-box file")


def read_references(file: Path) -> list[tuple[str, np.ndarray]]:
    """(class, box x0 y0 x1 y1 in photo pixels) of a ``detections.json`` or an mmdetection3d ``*infos.pkl``."""
    if file.suffix == ".json":
        items = json.loads(file.read_text())
        return [(str(i["class"]).lower().replace(" ", "_"), np.asarray(i["bbox"], np.float64)) for i in items]
    with file.open("rb") as fh:
        data = _NumpyOnly(fh).load()
    return [
        (MMDET3D_SUNRGBD[int(i["bbox_label"])], np.asarray(i["bbox"], np.float64))
        for item in data["data_list"]
        for i in item["instances"]
    ]


# ---------------------------------------------------------------------------------------------- matching
def seen_objects(
    placements: Placements, art: Path, db: ObjectDatabase
) -> tuple[list[np.ndarray], list[tuple[np.ndarray, Placement]], list[str]]:
    """Each posed object's silhouette box and (silhouette, placement) seen with the run's fitted camera and room
    (``art``: its artifacts folder), and its database category ("other" for a model the database lacks); objects
    out of view are left out."""
    boxes, masks, categories = [], [], []
    if placements.objects:
        camera = Camera.load(art / "camera_fit")
        c2w = np.asarray(RoomBox.load(art / "room_box_fit").camera_to_world)
        for p in placements.objects:
            mask = silhouette(camera, c2w, p.world_vertices(), p.mesh.faces)
            box = mask_box(mask)
            if box is not None:
                boxes.append(box)
                masks.append((mask, p))
                categories.append(db.record(p.model_id).category if p.model_id in db else "other")
    return boxes, masks, categories


def match(
    references: Sequence[np.ndarray],
    boxes: Sequence[np.ndarray],
    eligible: np.ndarray | None = None,
    threshold: float = IOU,
) -> list[tuple[int, int]]:
    """One-to-one pairs (reference, box), greedy by IoU, of IoU >= ``threshold`` where ``eligible[r, b]``."""
    if not len(references) or not len(boxes):
        return []
    ious = np.stack([box_iou(r, np.stack(boxes)) for r in references])
    if eligible is not None:
        ious = np.where(eligible, ious, -1.0)
    pairs = []
    while ious.max() >= threshold:
        r, b = np.unravel_index(int(np.argmax(ious)), ious.shape)
        pairs.append((int(r), int(b)))
        ious[r, :], ious[:, b] = -1.0, -1.0
    return pairs


# ---------------------------------------------------------------------------------------------- one photo
def run_pipeline(
    entry: Entry, run_dir: Path, cache: Path, overrides: list[str], until: str | None
) -> tuple[float, str | None]:
    """The photo alone in a temporary folder through the ``psdr-room`` command: wall seconds, and the error's
    last line when the run failed (the other photos still run: a photo that ends in an error is a result)."""
    if run_dir.exists():
        shutil.rmtree(run_dir)
    with tempfile.TemporaryDirectory() as bare:
        photo = Path(bare) / entry.image.name
        shutil.copyfile(entry.image, photo)
        command = [
            shutil.which("psdr-room") or "psdr-room",
            f"image={photo}",
            f"hydra.run.dir={run_dir}",
            f"cache_dir={cache}",
            *([f"run.until={until}"] if until else []),
            *overrides,
        ]
        start = time.perf_counter()
        result = subprocess.run(command, capture_output=True, text=True)
        seconds = time.perf_counter() - start
    if result.returncode != 0:
        lines = [line for line in result.stderr.splitlines() if line.strip()]
        return seconds, lines[-1] if lines else f"exit status {result.returncode}"
    return seconds, None


def evaluate(entry: Entry, run_dir: Path, db: ObjectDatabase, seconds: float, sheets: Path) -> dict:
    """One photo's row from its run folder, and its contact sheet."""
    art = run_dir / "artifacts"
    metrics = json.loads((run_dir / "metrics.json").read_text())
    image = Image.load(art / "image")
    panoptic = Panoptic.load(art / "panoptic")
    objects = [s for s in panoptic.segments if s.category in OBJECT_CATEGORIES]
    row: dict = {
        "photo": entry.name,
        "seconds": seconds,
        "segments": len(objects),
        "stages": {k: v["compute_seconds"] for k, v in metrics["stages"].items()},
        "guessed": guesses(
            Camera.load(art / "camera"), RoomBox.load(art / "room_box") if (art / "room_box").is_dir() else None
        ),
        "implementations": {k: v["name"] for k, v in metrics.get("implementations", {}).items()},
    }
    if entry.fy is not None:
        camera = Camera.load(art / "camera")
        true_vfov = math.degrees(2 * math.atan(entry.size[1] / (2 * entry.fy)))
        row["fov_error"] = camera.vfov_deg - true_vfov
    fitted = art / ("placements_fit" if (art / "placements_fit").is_dir() else "placements")
    placements = Placements.load(fitted) if fitted.is_dir() else Placements(objects=[])
    row["fitted"] = len(placements.objects)
    room_dir = next((art / n for n in ("room_box_objects", "room_box_fit") if (art / n).is_dir()), None)
    grouped = art / ("panoptic_grouped" if (art / "panoptic_grouped").is_dir() else "panoptic")
    row.update(
        physical_rows(
            placements,
            RoomBox.load(room_dir) if room_dir else None,
            db,
            Camera.load(art / ("camera_fit" if (art / "camera_fit").is_dir() else "camera")),
            Panoptic.load(grouped),
        )
    )
    fitted_boxes, fitted_masks, categories = seen_objects(placements, art, db)
    scale = np.array([image.width / entry.size[0], image.height / entry.size[1]] * 2)
    references, ignored = [], []
    if entry.boxes is not None:
        for name, box in read_references(entry.boxes):
            if REFERENCE_CLASSES.get(name):
                references.append((name, box * scale))
            else:
                ignored.append(name)
        segment_boxes = [b for b in (mask_box(panoptic.ids == s.id) for s in objects) if b is not None]
        ref_boxes = [b for _, b in references]
        eligible = np.array([[c in REFERENCE_CLASSES[n] for c in categories] for n, _ in references], bool)
        found = match(ref_boxes, fitted_boxes, eligible.reshape(len(references), len(fitted_boxes)))
        by_segment = {r for r, _ in match(ref_boxes, segment_boxes)}
        matched_refs = {r for r, _ in found}
        placed = Placements.load(art / "placements") if (art / "placements").is_dir() else Placements(objects=[])
        placed_boxes, _, placed_categories = seen_objects(placed, art, db)
        allowed = np.array([[c in REFERENCE_CLASSES[n] for c in placed_categories] for n, _ in references], bool)
        row.update(
            references=len(references),
            seg_recall=len(by_segment),
            place_recall=len(match(ref_boxes, placed_boxes, allowed.reshape(len(references), len(placed_boxes)))),
            obj_recall=len(found),
            lost=sorted(references[r][0] for r in by_segment - matched_refs),
            ignored=sorted(set(ignored)),
        )
        row["unmapped"] = sorted({n for n in ignored if n not in REFERENCE_CLASSES})
        reference_3d = boxes3d.read_reference(entry.image.parent)
        if reference_3d is not None and room_dir is not None:
            row["boxes3d"] = boxes3d.scene_scores(
                reference_3d,
                references=[(n, b) for n, b in read_references(entry.boxes) if REFERENCE_CLASSES.get(n)],
                pairs=found,
                fitted=[p for _, p in fitted_masks],
                symmetry=functools.partial(symmetry_period, tolerance=EXACT),
                room=RoomBox.load(room_dir),
            )
    else:
        matched_refs = set()
    if entry.depth is not None and (art / "depth").is_dir():
        depth = DepthMap.load(art / "depth")
        row.update(depth_scores(entry, depth.depth, depth.valid))
    accuracy = room_accuracy(entry, panoptic)
    if accuracy is not None:
        row["room_accuracy"] = accuracy
    fit = metrics.get("fit_appearance_log", {})
    for key in ("rmse_init", "rmse", "ssim_init", "ssim", "flip_init", "flip", "denoiser"):
        if key in fit:
            row[key] = fit[key]
    render = art / "appearance" / "render.png"
    write_sheet(
        sheets / f"{entry.name}.png",
        image,
        panoptic,
        fitted_masks,
        references,
        matched_refs,
        cv2.imread(str(render))[..., ::-1] if render.is_file() else None,
    )
    return row


def depth_scores(entry: Entry, depth: np.ndarray, valid: np.ndarray) -> dict[str, float]:
    """si-log, AbsRel and δ1 (after a median scale) of ``depth`` (working resolution) against the photo's sensor
    depth, on the pixels both have."""
    file, encoding, units = entry.depth  # type: ignore[misc]
    truth, known = read_depth(file, encoding=encoding, scale=units)
    size = (depth.shape[1], depth.shape[0])
    truth = cv2.resize(truth, size, interpolation=cv2.INTER_NEAREST)
    known = cv2.resize(known.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
    both = known & valid & (depth > 0)
    silog, absrel = depth_errors(depth, truth, both)
    scaled = depth[both] * np.median(truth[both] / depth[both])
    return {
        "silog": silog,
        "absrel": absrel,
        "delta1": float(np.mean(np.maximum(scaled / truth[both], truth[both] / scaled) < 1.25)),
    }


def room_accuracy(entry: Entry, panoptic: Panoptic) -> float | None:
    """Share of the hand-labelled wall/floor/ceiling pixels (:func:`room_labels`) whose segment has that
    category; None when the photo has no labels."""
    labels = room_labels(entry, (panoptic.ids.shape[1], panoptic.ids.shape[0]))
    if labels is None:
        return None
    category = np.array([""] + [s.category for s in panoptic.segments], dtype=object)
    index = np.zeros(panoptic.ids.shape, np.int64)
    for k, segment in enumerate(panoptic.segments):
        index[panoptic.ids == segment.id] = k + 1
    labelled = labels != ""
    return float(np.mean(category[index][labelled] == labels[labelled]))


def room_labels(entry: Entry, size: tuple[int, int]) -> np.ndarray | None:
    """The hand-drawn wall/floor/ceiling label of each pixel ('' where none) at ``size`` (width, height), from
    the LabelMe file of ``LAYOUT_LABELS`` that names the photo; None when there is none."""
    name = f"{entry.image.parent.name}/{entry.image.name}"
    for file in sorted(LAYOUT_LABELS.glob("*.json")):
        data = json.loads(file.read_text())
        if data.get("imagePath") != name:
            continue
        label = np.zeros((entry.size[1], entry.size[0]), np.uint8)
        classes = ("", "wall", "floor", "ceiling")
        for shape in data["shapes"]:
            if shape["label"] in classes[1:]:
                points = np.round(np.asarray(shape["points"], np.float64)).astype(np.int32)
                cv2.fillPoly(label, [points], classes.index(shape["label"]))
        small = cv2.resize(label, size, interpolation=cv2.INTER_NEAREST)
        return np.array(classes, dtype=object)[small]
    return None


def physical_rows(
    placements: Placements, room: RoomBox | None, db: ObjectDatabase, camera: Camera, panoptic: Panoptic
) -> dict:
    """The fitted scene's duplicates, implausible sizes, interpenetrations, reach beyond the room box and objects
    the others hide (``panoptic``: the segmentation the placements' segment ids name)."""
    objects = placements.objects
    small = camera.resized(min(160, camera.width))
    c2w = np.asarray(room.camera_to_world) if room is not None else None
    depths = [depth_map(small, c2w, p.world_vertices(), p.mesh.faces) for p in objects] if c2w is not None else []
    looks = [d > 0 for d in depths]
    kinds = [db.record(p.model_id).category if p.model_id in db else p.category for p in objects]
    duplicates = []
    for i, a in enumerate(objects):
        for j in range(i + 1, len(objects)):
            b = objects[j]
            union = (looks[i] | looks[j]).sum() if looks else 0
            seen = (looks[i] & looks[j]).sum() / union if union else 0.0
            if kinds[i] == kinds[j] and (overlap(a, b).shared >= 0.5 or seen >= 0.5):
                duplicates.append((a.segment_id, b.segment_id))
    sizes = []
    for p, category in zip(objects, kinds):
        low, high = scale_range(category, np.ptp(p.mesh.vertices, axis=0))
        if not low * 0.99 <= p.scale <= high * 1.01:
            sizes.append(f"{p.segment_id}:{p.model_id.split('/')[-1]} x{p.scale:.2f}")
    out = [
        p.segment_id
        for p in objects
        if room is not None and np.any(np.nan_to_num(room_excess(p, room, PENETRATION), nan=1.0))
    ]
    return {
        "duplicates": duplicates,
        "implausible": sizes,
        "through": interpenetrations(objects, PENETRATION),
        "outside": out,
        "hidden": hidden_objects(objects, depths, panoptic, small),
    }


def hidden_objects(objects: list, depths: list[np.ndarray], panoptic: Panoptic, camera: Camera) -> list[int]:
    """Segment ids of the objects the others hide (:func:`~psdr_room_core.method.physical.hidden_by` with the
    shipped ``priors.physical.hidden_share``; ``depths``: each object's depth map from ``camera``, 0 where it is not seen)."""
    by_id = {p.segment_id: np.where(d > 0, d, np.inf) for p, d in zip(objects, depths)}
    ids = panoptic.ids_at(camera.width, camera.height)
    share = shipped.node("priors.physical.hidden_share")
    return [k for k in by_id if hidden_by(k, by_id, ids, share) is not None]


def write_sheet(
    path: Path,
    image: Image,
    panoptic: Panoptic,
    fitted: list,
    references: list,
    matched: set[int],
    render: np.ndarray | None,
) -> None:
    """photo with reference boxes (green: recalled by a fitted object, red: missed) | segmentation |
    fitted objects' outlines with their model names | final render."""
    rgb8 = image.to_uint8()
    photo = np.ascontiguousarray(rgb8.copy())
    for k, (name, box) in enumerate(references):
        x0, y0, x1, y1 = np.rint(box).astype(int)
        colour = (40, 220, 40) if k in matched else (230, 40, 40)
        cv2.rectangle(photo, (x0, y0), (x1, y1), colour, 2)
        cv2.putText(photo, name, (x0 + 3, y0 + 13), cv2.FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv2.LINE_AA)
    outlines = np.ascontiguousarray((0.6 * rgb8).astype(np.uint8))
    for k, (mask, placement) in enumerate(fitted):
        contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        colour = tuple(int(c) for c in cv2.applyColorMap(np.uint8([[37 * k % 255]]), cv2.COLORMAP_HSV)[0, 0][::-1])
        cv2.drawContours(outlines, contours, -1, colour, 2)
        ys, xs = np.nonzero(mask)
        cv2.putText(
            outlines,
            placement.model_id.split("/")[-1],
            (int(xs.min()), max(12, int(ys.min()) + 12)),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.4,
            colour,
            1,
            cv2.LINE_AA,
        )
    tiles = [photo, segment_overlay(rgb8, panoptic), outlines]
    if render is not None:
        tiles.append(cv2.resize(render, (rgb8.shape[1], rgb8.shape[0]), interpolation=cv2.INTER_LINEAR))
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.hstack(tiles)[..., ::-1])


# ---------------------------------------------------------------------------------------------- tables
def _cell(value: object, fmt: str, width: int) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-".rjust(width)
    return format(value, fmt).rjust(width)


def _ratio(row: dict, key: str) -> str:
    return f"{row[key]}/{row['references']}" if "references" in row else "-"


def _count(row: dict, key: str) -> int:
    return len(row.get(key, []))


PHYSICAL = (
    ("lost", "lost"),
    ("dup", "duplicates"),
    ("size", "implausible"),
    ("pen", "through"),
    ("out", "outside"),
    ("hid", "hidden"),
)
"""Column → row key of the object stage's counts."""


def format_table(rows: list[dict]) -> str:
    header = (
        f"{'photo':<24} {'FoV err':>7} {'segs':>4} {'fit':>4} {'seg rec':>7} {'placed':>7} {'obj rec':>7} "
        + " ".join(f"{c:>4}" for c, _ in PHYSICAL)
        + f" {'si-log':>6} {'AbsRel':>6} {'δ1':>5} {'w/f/c':>5} {'RMSE init→fit':>15} {'SSIM init→fit':>13} {'FLIP init→fit':>13} {'s':>5}"
    )
    lines = [header, "-" * len(header)]
    for r in rows:
        rmse = f"{r['rmse_init']:.3f}→{r['rmse']:.3f}" if "rmse" in r else "-"
        ssim = f"{r['ssim_init']:.3f}→{r['ssim']:.3f}" if "ssim" in r else "-"
        flip = f"{r['flip_init']:.3f}→{r['flip']:.3f}" if "flip" in r else "-"
        counts = " ".join(f"{_count(r, key) if key in r else '-':>4}" for _, key in PHYSICAL)
        lines.append(
            f"{r['photo']:<24} {_cell(r.get('fov_error'), '+.2f', 7)} {r['segments']:>4} {r['fitted']:>4} "
            f"{_ratio(r, 'seg_recall'):>7} {_ratio(r, 'place_recall'):>7} {_ratio(r, 'obj_recall'):>7} {counts} "
            f"{_cell(r.get('silog'), '.3f', 6)} "
            f"{_cell(r.get('absrel'), '.3f', 6)} {_cell(r.get('delta1'), '.2f', 5)} "
            f"{_cell(r.get('room_accuracy'), '.2f', 5)} {rmse:>15} {ssim:>13} {flip:>13} {r['seconds']:5.0f}"
        )
    boxed = [r for r in rows if "references" in r]
    fov = [abs(r["fov_error"]) for r in rows if "fov_error" in r]
    refs = sum(r["references"] for r in boxed)
    improved = [r for r in rows if "rmse" in r]
    lines.append("-" * len(header))
    lines.append(
        f"{'total (' + str(len(rows)) + ' photos)':<24} {_cell(float(np.median(fov)) if fov else None, '.2f', 7)} "
        f"{sum(r['segments'] for r in rows):>4} {sum(r['fitted'] for r in rows):>4} "
        f"{(str(sum(r['seg_recall'] for r in boxed)) + '/' + str(refs)) if boxed else '-':>7} "
        f"{(str(sum(r['place_recall'] for r in boxed)) + '/' + str(refs)) if boxed else '-':>7} "
        f"{(str(sum(r['obj_recall'] for r in boxed)) + '/' + str(refs)) if boxed else '-':>7} "
        + " ".join(f"{sum(_count(r, key) for r in rows):>4}" for _, key in PHYSICAL)
        + f" {_cell(_median(rows, 'silog'), '.3f', 6)} {_cell(_median(rows, 'absrel'), '.3f', 6)} "
        f"{_cell(_median(rows, 'delta1'), '.2f', 5)} {_cell(_mean(rows, 'room_accuracy'), '.2f', 5)} "
        f"{_better(improved, 'rmse', lower=True):>15} {_better(improved, 'ssim', lower=False):>13} "
        f"{_better([r for r in improved if 'flip' in r], 'flip', lower=True):>13} {sum(r['seconds'] for r in rows):5.0f}"
    )
    lines.append(
        "(FoV err: median |error| in the total row; si-log, AbsRel, δ1: medians; w/f/c: mean wall/floor/ceiling "
        "pixel accuracy; RMSE/SSIM/FLIP: photos improved by "
        "the fit (renders denoised unless denoiser=none); recall at box IoU >= 0.5; lost: references a segment "
        "matches and no fitted object does; dup, size, pen, out: duplicate pairs, implausible sizes, pairs "
        f"through each other and objects beyond the room by > {PENETRATION * 100:g} cm; hid: objects the others hide)"
    )
    for r in rows:
        details = [f"{c} {r[key]}" for c, key in PHYSICAL if r.get(key)]
        if details:
            lines.append(f"  {r['photo']}: " + "; ".join(details))
    for r in rows:
        for guess in r.get("guessed", []):
            lines.append(f"  {r['photo']} guessed: {guess}")
    unmapped = sorted({n for r in boxed for n in r.get("unmapped", [])})
    if unmapped:
        lines.append(f"reference classes not in REFERENCE_CLASSES (ignored): {', '.join(unmapped)}")
    return "\n".join(lines)


def _median(rows: list[dict], key: str) -> float | None:
    values = [r[key] for r in rows if key in r]
    return float(np.median(values)) if values else None


def _mean(rows: list[dict], key: str) -> float | None:
    values = [r[key] for r in rows if key in r]
    return float(np.mean(values)) if values else None


def _better(rows: list[dict], key: str, lower: bool) -> str:
    if not rows:
        return "-"
    better = sum((r[key] < r[f"{key}_init"]) if lower else (r[key] > r[f"{key}_init"]) for r in rows)
    return f"{better}/{len(rows)} better"


def stage_table(rows: list[dict]) -> str:
    names = list(dict.fromkeys(n for r in rows for n in r["stages"]))
    short = [n.replace("estimate_", "").replace("_objects", "_obj").replace("appearance", "app") for n in names]
    lines = [f"{'photo':<24} " + " ".join(f"{s[:9]:>9}" for s in short)]
    for r in rows:
        lines.append(f"{r['photo']:<24} " + " ".join(_cell(r["stages"].get(n), ".1f", 9) for n in names))
    return "\n".join(lines)


def compare_table(before: list[dict], after: list[dict]) -> str:
    """Recall and fit columns of an earlier run (``before``) beside this one's, per photo."""
    old = {r["photo"]: r for r in before}
    header = (
        f"{'photo':<24} {'segs':>9} {'fit':>9} {'seg rec':>13} {'placed':>13} {'obj rec':>13} {'lost':>7} {'AbsRel':>13} "
        f"{'δ1':>11} {'w/f/c':>11} {'RMSE fit':>13} {'SSIM fit':>13} {'FLIP fit':>13}"
    )
    lines = [header, "-" * len(header)]

    def pair(a: dict | None, b: dict, key: str, fmt: str = "") -> str:
        def one(r: dict | None) -> str:
            if r is None or key not in r:
                return "-"
            return f"{r[key]}/{r['references']}" if key.endswith("recall") else format(r[key], fmt)

        return f"{one(a)}→{one(b)}"

    for r in after:
        o = old.get(r["photo"])
        lost = f"{_count(o, 'lost') if o and 'lost' in o else '-'}→{_count(r, 'lost') if 'lost' in r else '-'}"
        lines.append(
            f"{r['photo']:<24} {pair(o, r, 'segments'):>9} {pair(o, r, 'fitted'):>9} "
            f"{pair(o, r, 'seg_recall'):>13} {pair(o, r, 'place_recall'):>13} {pair(o, r, 'obj_recall'):>13} {lost:>7} "
            f"{pair(o, r, 'absrel', '.3f'):>13} {pair(o, r, 'delta1', '.2f'):>11} "
            f"{pair(o, r, 'room_accuracy', '.2f'):>11} {pair(o, r, 'rmse', '.3f'):>13} "
            f"{pair(o, r, 'ssim', '.3f'):>13} {pair(o, r, 'flip', '.3f'):>13}"
        )

    def total(rows: list[dict], key: str) -> str:
        boxed = [r for r in rows if "references" in r]
        if not boxed or any(key not in r for r in boxed):  # an earlier run without the column
            return "-"
        return f"{sum(r[key] for r in boxed)}/{sum(r['references'] for r in boxed)}"

    def summary(rows: list[dict], key: str, how: Callable[[list[float]], float], fmt: str) -> str:
        values = [r[key] for r in rows if key in r]
        return format(how(values), fmt) if values else "-"

    shown = {r["photo"] for r in after}
    earlier = [o for o in before if o["photo"] in shown]
    lines.append("-" * len(header))
    lines.append(
        f"{'total (' + str(len(after)) + ' photos)':<24} "
        f"{str(sum(r['segments'] for r in earlier)) + '→' + str(sum(r['segments'] for r in after)):>9} "
        f"{str(sum(r['fitted'] for r in earlier)) + '→' + str(sum(r['fitted'] for r in after)):>9} "
        f"{total(earlier, 'seg_recall') + '→' + total(after, 'seg_recall'):>13} "
        f"{total(earlier, 'place_recall') + '→' + total(after, 'place_recall'):>13} "
        f"{total(earlier, 'obj_recall') + '→' + total(after, 'obj_recall'):>13} "
        f"{str(sum(_count(r, 'lost') for r in earlier)) + '→' + str(sum(_count(r, 'lost') for r in after)):>7} "
        f"{summary(earlier, 'absrel', np.median, '.3f') + '→' + summary(after, 'absrel', np.median, '.3f'):>13} "
        f"{summary(earlier, 'delta1', np.median, '.2f') + '→' + summary(after, 'delta1', np.median, '.2f'):>11} "
        f"{summary(earlier, 'room_accuracy', np.mean, '.2f') + '→' + summary(after, 'room_accuracy', np.mean, '.2f'):>11}"
    )
    lines.append("(total: recall sums, median AbsRel and δ1, mean w/f/c)")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--photos", type=Path, default=PHOTOS, help="a folder with index.csv (default: %(default)s)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="run these photos only (folder names)")
    parser.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="a config override for every run"
    )
    parser.add_argument("--until", metavar="STAGE", help="stop every run after this stage (run.until)")
    parser.add_argument("--out", type=Path, default=OUT, help="runs, sheets, rows.json (default: %(default)s)")
    parser.add_argument("--cache", type=Path, help="the shared cache (default: OUT/cache)")
    parser.add_argument("--save", type=Path, help="write the rows here (default: OUT/rows.json)")
    parser.add_argument("--compare", type=Path, help="rows.json of an earlier run to print beside this one")
    parser.add_argument(
        "--no-run",
        action="store_true",
        help="evaluate the run folders already in OUT/runs again (after changing this script)",
    )
    args = parser.parse_args()
    entries = read_index(args.photos.resolve())
    if args.only:
        unknown = set(args.only) - {e.name for e in entries}
        if unknown:
            sys.exit(
                f"real_photos: --only {', '.join(sorted(unknown))}: not in {args.photos / 'index.csv'}; "
                f"names: {', '.join(e.name for e in entries)}"
            )
        entries = [e for e in entries if e.name in args.only]
    if args.compare and not args.compare.is_file():
        sys.exit(f"real_photos: --compare {args.compare}: no such file; give the rows.json an earlier run wrote")
    cache = (args.cache or args.out / "cache").resolve()
    os.environ.setdefault("PSDR_ROOM_CACHE_DIR", str(cache))  # the object database's own records and thumbnails
    db = builtin_database()
    rows, failed = [], {}
    for entry in entries:
        run_dir = args.out / "runs" / entry.name
        if args.no_run:
            if not (run_dir / "metrics.json").is_file():
                failed[entry.name] = "no finished run in " + str(run_dir)
                continue
            metrics = json.loads((run_dir / "metrics.json").read_text())
            seconds = sum(v["compute_seconds"] for v in metrics["stages"].values())
        else:
            seconds, error = run_pipeline(entry, run_dir, cache, args.set, args.until)
            if error is not None:
                failed[entry.name] = error
                print(f"{entry.name}: failed after {seconds:.0f} s: {error}", file=sys.stderr, flush=True)
                continue
        rows.append(evaluate(entry, run_dir, db, seconds, args.out / "sheets"))
        print(f"{entry.name}: {rows[-1]['fitted']} objects, {seconds:.0f} s", file=sys.stderr, flush=True)
    save = args.save or args.out / "rows.json"
    save.parent.mkdir(parents=True, exist_ok=True)
    save.write_text(json.dumps(rows, indent=1) + "\n")
    print(
        f"Real photos run bare ({args.photos}; overrides: {' '.join(args.set) or 'none'}"
        f"{'; until ' + args.until if args.until else ''})\n"
    )
    print(format_table(rows))
    if any("boxes3d" in r for r in rows):
        print("\nin 3D, against SUN RGB-D's 3D boxes (Total3D's ground truth):")
        print(boxes3d.format_table(rows))
    print(f"\nfinished: {len(rows)}/{len(rows) + len(failed)}")
    for name, error in failed.items():
        print(f"  {name} failed: {error}")
    print("\nseconds per stage (compute):")
    print(stage_table(rows))
    if args.compare:
        print(f"\nbefore ({args.compare}) → now:")
        print(compare_table(json.loads(args.compare.read_text()), rows))
    print(f"\ncontact sheets: {args.out / 'sheets'}/<photo>.png; rows: {save}")


if __name__ == "__main__":
    main()
