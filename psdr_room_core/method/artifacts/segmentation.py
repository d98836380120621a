"""What the estimators say about the photo: depth, object boxes, panoptic segments (§4.1)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError

from .io import read_json, read_npy, read_png, write_json, write_png

CATEGORIES = ("wall", "floor", "ceiling", "window", "door", "lamp", "object")
"""Room categories a segmentation is mapped to; the room stage uses wall/floor/ceiling."""

ROOM_CATEGORIES = ("wall", "floor", "ceiling")


@dataclass
class DepthMap:
    """Per-pixel z-depth (distance along the optical axis) at working resolution.

    ``metric`` says whether the unit is metres (sensor depth) or an unknown scale (monocular estimates,
    which the paper normalises to a unit range).
    """

    kind: ClassVar[str] = "depth"
    marker: ClassVar[str] = "depth.json"
    depth: np.ndarray
    valid: np.ndarray
    metric: bool = True
    source: str = ""
    unplaced: tuple[int, ...] = ()
    """Segments whose depth gives their direction only: ``depth=layout`` found no floor contact for them inside
    the room and put them just in front of its surface."""

    def save(self, directory: Path) -> None:
        np.save(directory / "depth.npy", self.depth.astype(np.float32))
        write_png(directory / "valid.png", self.valid.astype(np.uint8) * 255)
        write_json(
            directory / "depth.json", {"metric": self.metric, "source": self.source, "unplaced": list(self.unplaced)}
        )

    @classmethod
    def load(cls, directory: Path) -> DepthMap:
        meta = read_json(directory / "depth.json")
        depth = read_npy(directory / "depth.npy").astype(np.float32)
        valid = read_png(directory / "valid.png") > 0
        meta["unplaced"] = tuple(meta.get("unplaced", ()))
        return cls(depth=depth, valid=valid & np.isfinite(depth) & (depth > 0), **meta)


def box4(values: Iterable[Any]) -> tuple[float, float, float, float]:
    """``(x0, y0, x1, y1)`` as a typed tuple of floats."""
    x0, y0, x1, y1 = (float(v) for v in values)
    return x0, y0, x1, y1


@dataclass(frozen=True)
class Detection:
    """One object box: a prompt for the segmenter (from a detector, or from the user's boxes file)."""

    label: str
    """The detector's or user's class name (e.g. COCO ``couch``); a weak prior only."""
    category: str
    """One of :data:`CATEGORIES` (usually ``object``; ``lamp``, ``window``, ``door`` where known)."""
    box: tuple[float, float, float, float]
    """``(x0, y0, x1, y1)`` in working-image pixels (see the module's conventions)."""
    score: float = 1.0
    """Detector confidence in [0, 1]; 1 for user boxes."""

    def __post_init__(self) -> None:
        if self.category not in CATEGORIES:
            raise ValueError(f"Detection category must be one of {', '.join(CATEGORIES)}, got {self.category!r}")
        x0, y0, x1, y1 = self.box
        if not (x1 > x0 and y1 > y0):
            raise ValueError(f"Detection box must have x1 > x0 and y1 > y0, got {self.box!r}")


@dataclass
class Detections:
    """Object boxes in the working image, highest score first."""

    kind: ClassVar[str] = "detections"
    marker: ClassVar[str] = "detections.json"
    items: list[Detection]
    source: str = ""
    """What produced them (``nanodet_onnx``, a boxes file's path, ...)."""

    def save(self, directory: Path) -> None:
        write_json(
            directory / "detections.json",
            {
                "source": self.source,
                "items": [
                    {
                        "label": d.label,
                        "category": d.category,
                        "box": [float(v) for v in d.box],
                        "score": float(d.score),
                    }
                    for d in self.items
                ],
            },
        )

    @classmethod
    def load(cls, directory: Path) -> Detections:
        data = read_json(directory / "detections.json")
        try:
            items = [
                Detection(
                    label=str(d["label"]),
                    category=str(d["category"]),
                    box=box4(d["box"]),
                    score=float(d["score"]),
                )
                for d in data["items"]
            ]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(
                f"{directory / 'detections.json'}: not as psdr-room writes it ({exc}); fix the entry or regenerate it"
            ) from None
        return cls(items=items, source=str(data.get("source", "")))


@dataclass(frozen=True)
class SeenBox:
    """An object's 3D box as a network sees it in the photo's camera frame (OpenCV: x right, y down, z forward;
    metres at the network's own scale)."""

    center: tuple[float, float, float]
    """The box's centre (z > 0: in front of the camera)."""
    size: tuple[float, float, float]
    """Its size along the object's own axes: width, height, depth (each > 0)."""
    yaw: float
    """Radians about world up from the camera's heading to the object's front (0: it faces away from the camera)."""
    confidence: float
    """How sure the network is of the yaw, in [0, 1] (the probability of its yaw bin)."""

    def __post_init__(self) -> None:
        center = tuple(float(v) for v in self.center)
        size = tuple(float(v) for v in self.size)
        numbers = (*center, *size, float(self.yaw), float(self.confidence))
        if len(center) != 3 or len(size) != 3 or not all(math.isfinite(v) for v in numbers):
            raise ValueError(f"SeenBox needs 3 finite centre and size values, got {self.center!r}, {self.size!r}")
        if center[2] <= 0 or min(size) <= 0 or not 0.0 <= self.confidence <= 1.0:
            raise ValueError(
                f"SeenBox needs a centre in front of the camera (z > 0), a positive size and a confidence in [0, 1], "
                f"got z={center[2]!r}, size={size!r}, confidence={self.confidence!r}"
            )
        object.__setattr__(self, "center", center)
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "yaw", float(self.yaw))
        object.__setattr__(self, "confidence", float(self.confidence))

    def to_json(self) -> dict[str, Any]:
        return {"center": list(self.center), "size": list(self.size), "yaw": self.yaw, "confidence": self.confidence}

    @classmethod
    def from_json(cls, data: Any) -> SeenBox:
        """The box :meth:`to_json` wrote (ValueError or TypeError: it is not one)."""
        if not isinstance(data, dict) or set(data) != {"center", "size", "yaw", "confidence"}:
            raise ValueError("a seen_box is an object with center, size, yaw and confidence")
        center, size = data["center"], data["size"]
        if not all(isinstance(v, list) and len(v) == 3 for v in (center, size)):
            raise ValueError("a seen_box's center and size are lists of 3 numbers")
        values = [*center, *size, data["yaw"], data["confidence"]]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            raise ValueError("a seen_box holds numbers only")
        return cls(tuple(center), tuple(size), data["yaw"], data["confidence"])


@dataclass(frozen=True)
class Segment:
    """One segment of a panoptic segmentation."""

    id: int
    """Its value in the id map (> 0)."""
    category: str
    """One of :data:`CATEGORIES`."""
    label: str
    """The class name the segmenter or annotator gave (e.g. ``wardrobe``)."""
    score: float | None = None
    """How sure an automatic guess is (the prompt's score, for objects ``segmentation=layout`` discovered):
    such objects are dropped when no model explains them (``place_objects.prune``). None: a segment a person
    drew or a dense segmenter labelled, kept whatever the fit."""
    box: tuple[float, float, float, float] | None = None
    """The box that prompted an automatic object segment (working-image pixels): the object may reach anywhere
    in it (a box-prompted cut leaves out thin legs), so a model covering it where the mask does not is not
    wrong. None: the mask is the whole object."""
    second_opinion: str | None = None
    """What a second judge calls an automatic object: the label of a network's instance filling its prompt's box
    (``segmentation=layout_eyes``), or a person's name for it (the studio). Where it names one of the label's own
    categories the label is confirmed: its alternates are not searched
    (:func:`~psdr_room_core.method.labels.alternates`). None: nobody else judged."""
    seen: SeenBox | None = None
    """The object's 3D box as the network that found it sees it (``segmentation=eyes``, ``layout_eyes`` where one of
    its instances fills the prompt's box). None: no network's box."""

    def __post_init__(self) -> None:
        if self.box is not None:
            object.__setattr__(self, "box", tuple(float(v) for v in self.box))
        if isinstance(self.id, bool) or not isinstance(self.id, (int, np.integer)) or self.id <= 0:
            raise ValueError(f"Segment id must be a positive integer, got {self.id!r}")
        if self.category not in CATEGORIES:
            raise ValueError(f"Segment category must be one of {', '.join(CATEGORIES)}, got {self.category!r}")


def panoptic_ids(rgb: np.ndarray) -> np.ndarray:
    """The int32 id map of a COCO-panoptic RGB image (HxWx3): ``id = R + 256 G + 256² B``, 0 = unlabelled."""
    rgb = rgb.astype(np.int32)
    return rgb[..., 0] + 256 * rgb[..., 1] + 65536 * rgb[..., 2]


def write_coco_panoptic(png: Path, json_path: Path, ids: np.ndarray, segments: list[Segment]) -> None:
    """Write an id map and its segments as COCO panoptic: an RGB PNG (see :func:`panoptic_ids`) and a
    single-annotation JSON (``file_name``, ``segments_info``, ``categories``).

    The categories are :data:`CATEGORIES` with ids 1..7; each segment keeps its label as ``label``. Every
    id in the map must have exactly one segment and every segment pixels, so that :meth:`Panoptic.load`
    and the ``segmentation=file`` reader read the files back unchanged.
    """
    ids = np.asarray(ids)
    if ids.ndim != 2 or not np.issubdtype(ids.dtype, np.integer):
        raise PsdrRoomError(
            f"{png}: the id map must be a 2-D integer array, got {ids.dtype} {ids.shape}; pass an int32 HxW array"
        )
    if ids.size and (ids.min() < 0 or ids.max() >= 1 << 24):
        raise PsdrRoomError(f"{png}: ids must lie in 0..16777215 to fit an RGB PNG; renumber the segments")
    listed: set[int] = set()
    for s in segments:
        if s.id in listed:
            raise PsdrRoomError(f"{json_path}: segment id {s.id} appears twice; give each segment a unique id")
        listed.add(int(s.id))
    present = set(np.unique(ids).tolist()) - {0}
    if present - listed:
        raise PsdrRoomError(
            f"{png}: id map holds ids without a segment ({sorted(present - listed)[:5]}); add segments or zero those pixels"
        )
    if listed - present:
        raise PsdrRoomError(
            f"{json_path}: segment(s) {sorted(listed - present)[:5]} have no pixels; drop them before writing"
        )

    u = ids.astype(np.uint32)
    write_png(png, np.stack([u & 255, (u >> 8) & 255, (u >> 16) & 255], axis=-1).astype(np.uint8))
    cat_id = {name: i + 1 for i, name in enumerate(CATEGORIES)}
    infos = []
    for s in segments:
        ys, xs = np.nonzero(ids == s.id)
        x0, y0 = int(xs.min()), int(ys.min())
        bbox = [x0, y0, int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1]
        infos.append(
            {
                "id": int(s.id),
                "category_id": cat_id[s.category],
                "label": s.label,
                "iscrowd": 0,
                "area": int(xs.size),
                "bbox": bbox,
                **({} if s.score is None else {"score": float(s.score)}),
                **({} if s.box is None else {"prompt_box": [float(v) for v in s.box]}),
                **({} if s.second_opinion is None else {"second_opinion": s.second_opinion}),
                **({} if s.seen is None else {"seen_box": s.seen.to_json()}),
            }
        )
    write_json(
        json_path,
        {
            "file_name": png.name,
            "image_id": png.stem,
            "height": int(ids.shape[0]),
            "width": int(ids.shape[1]),
            "segments_info": infos,
            "categories": [{"id": i, "name": n, "isthing": int(n in ("object", "lamp"))} for n, i in cat_id.items()],
        },
    )


@dataclass
class Panoptic:
    """Panoptic segmentation at working resolution: an int32 id map (0 = unlabelled) and its segments.

    Saved with :func:`write_coco_panoptic` as ``panoptic.png`` + ``panoptic.json``, the format the ``file``
    segmentation implementation reads, so a corrected segmentation can be fed back in (as
    ``<photo stem>.panoptic.png`` + ``.panoptic.json``).
    """

    kind: ClassVar[str] = "panoptic"
    marker: ClassVar[str] = "panoptic.json"
    ids: np.ndarray
    segments: list[Segment]

    def mask(self, category: str) -> np.ndarray:
        wanted = [s.id for s in self.segments if s.category == category]
        return np.isin(self.ids, wanted)

    def ids_at(self, width: int, height: int) -> np.ndarray:
        """The id map resampled to ``width`` × ``height`` (each pixel the id at its centre)."""
        return cv2.resize(self.ids, (width, height), interpolation=cv2.INTER_NEAREST_EXACT)

    def save(self, directory: Path) -> None:
        write_coco_panoptic(directory / "panoptic.png", directory / "panoptic.json", self.ids, self.segments)

    @classmethod
    def load(cls, directory: Path) -> Panoptic:
        """Read what :meth:`save` wrote; (edited) files from elsewhere go through ``segmentation=file``."""
        rgb = read_png(directory / "panoptic.png")
        if rgb.ndim != 3:
            raise PsdrRoomError(
                f"{directory / 'panoptic.png'}: not an RGB PNG (id = R + 256 G + 256² B); regenerate it"
            )
        meta = read_json(directory / "panoptic.json")
        try:
            names = {c["id"]: c["name"] for c in meta["categories"]}
            segments = [
                Segment(
                    int(s["id"]),
                    names[s["category_id"]],
                    s.get("label") or names[s["category_id"]],
                    None if s.get("score") is None else float(s["score"]),
                    s.get("prompt_box"),
                    s.get("second_opinion"),
                    None if s.get("seen_box") is None else SeenBox.from_json(s["seen_box"]),
                )
                for s in meta["segments_info"]
            ]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(
                f"{directory / 'panoptic.json'}: not as psdr-room writes it ({type(exc).__name__}: {exc}); "
                "regenerate it, or feed an edited segmentation in with segmentation=file"
            ) from None
        return cls(ids=panoptic_ids(rgb), segments=segments)
