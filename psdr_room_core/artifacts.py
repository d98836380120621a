"""Typed artifacts: what stages pass to each other, each saved as ordinary files a user can open and edit.

Every artifact is a dataclass with a ``kind`` (its name in cache manifests), ``save(directory)`` writing
standard formats (PNG, NPY, JSON, PLY, XML) and ``load(directory)`` reading them back. An artifact's
identity in the cache is the digest of the files it saves, so two equal artifacts have equal digests.

Coordinate conventions used throughout:

* image pixels: x right, y down, origin at the top-left corner of the top-left pixel;
* camera frame: OpenCV (x right, y down, z forward), in the units of the depth;
* world frame: Y up, the floor is ``y = 0``, the camera centre is at ``(0, h, 0)``, and world +Z is the
  optical axis projected on the floor.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Protocol, runtime_checkable

import cv2
import numpy as np

from .errors import PsdrRoomError
from .geometry import TriangleMesh

CATEGORIES = ("wall", "floor", "ceiling", "window", "door", "lamp", "object")
"""Room categories a segmentation is mapped to; the room stage uses wall/floor/ceiling."""

ROOM_CATEGORIES = ("wall", "floor", "ceiling")


@runtime_checkable
class Artifact(Protocol):
    """What every artifact type provides."""

    kind: ClassVar[str]
    marker: ClassVar[str]
    """A file every saved artifact of this kind has: how a directory's kind is recognised."""

    def save(self, directory: Path) -> None:
        """Write the artifact's files into ``directory`` (which exists and is empty)."""

    @classmethod
    def load(cls, directory: Path) -> "Artifact":
        """Read an artifact written by :meth:`save` (possibly edited by a user)."""


def _write_json(path: Path, data: Any) -> None:
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise PsdrRoomError(f"{path}: missing; the artifact directory is incomplete") from None
    except json.JSONDecodeError as exc:
        raise PsdrRoomError(f"{path}: invalid JSON ({exc.msg} at line {exc.lineno}); fix or regenerate it") from None


def _read_npy(path: Path) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise PsdrRoomError(f"{path}: missing; the artifact directory is incomplete") from None
    except ValueError as exc:
        raise PsdrRoomError(f"{path}: not a readable .npy array ({exc}); regenerate it") from None


def write_png(path: Path, array: np.ndarray) -> None:
    """Write an RGB (HxWx3) or gray array as PNG (uint8/uint16 as is), making its folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if array.ndim == 3:
        array = array[..., ::-1]
    if not cv2.imwrite(str(path), np.ascontiguousarray(array)):
        raise PsdrRoomError(f"{path}: could not be written; check the directory is writable")


def _read_png(path: Path) -> np.ndarray:
    data = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if data is None:
        raise PsdrRoomError(f"{path}: missing or not a readable PNG; regenerate it")
    return data[..., ::-1].copy() if data.ndim == 3 else data


# --------------------------------------------------------------------------------------------- image
@dataclass
class Image:
    """The input photo at working resolution: float32 HxWx3 sRGB in [0, 1]."""

    kind: ClassVar[str] = "image"
    marker: ClassVar[str] = "image.json"
    rgb: np.ndarray
    source: str = ""
    """The photo's path as given by the user (a record, not an input)."""
    original_size: tuple[int, int] = (0, 0)
    """(width, height) of the photo before resizing, after EXIF orientation."""

    @property
    def height(self) -> int:
        return int(self.rgb.shape[0])

    @property
    def width(self) -> int:
        return int(self.rgb.shape[1])

    def to_uint8(self) -> np.ndarray:
        return np.clip(np.rint(self.rgb * 255.0), 0, 255).astype(np.uint8)

    def save(self, directory: Path) -> None:
        write_png(directory / "image.png", np.clip(np.rint(self.rgb * 65535.0), 0, 65535).astype(np.uint16))
        _write_json(directory / "image.json", {"source": self.source, "original_size": list(self.original_size)})

    @classmethod
    def load(cls, directory: Path) -> "Image":
        data = _read_png(directory / "image.png")
        scale = 65535.0 if data.dtype == np.uint16 else 255.0
        meta = _read_json(directory / "image.json")
        rgb = (data.astype(np.float32) / scale)[..., :3]
        return cls(rgb=rgb, source=meta["source"], original_size=tuple(meta["original_size"]))


# -------------------------------------------------------------------------------------------- camera
@dataclass
class Camera:
    """Pinhole intrinsics in pixels of the working image, with the estimate's provenance."""

    kind: ClassVar[str] = "camera"
    marker: ClassVar[str] = "camera.json"
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    method: str = ""
    """How the intrinsics were obtained (e.g. ``vanishing_points/orthogonal_triplet``, ``fixed``)."""
    confidence: float = 1.0
    extra: dict[str, Any] = field(default_factory=dict)
    """Estimator details kept for inspection (vanishing points, segment counts, ...)."""

    @classmethod
    def from_vfov(cls, width: int, height: int, vfov_deg: float, **kwargs: Any) -> "Camera":
        fy = 0.5 * height / math.tan(math.radians(vfov_deg) / 2.0)
        return cls(width=width, height=height, fx=fy, fy=fy, cx=width / 2.0, cy=height / 2.0, **kwargs)

    @property
    def vfov_deg(self) -> float:
        return math.degrees(2.0 * math.atan(0.5 * self.height / self.fy))

    def resized(self, width: int) -> "Camera":
        """The camera for an image ``width`` pixels wide: the intrinsics scaled uniformly (square pixels stay
        square; the rounded height changes the vertical field of view by under half a pixel)."""
        s = width / self.width
        return Camera(width=width, height=max(1, round(self.height * s)), fx=self.fx * s, fy=self.fy * s,
                      cx=self.cx * s, cy=self.cy * s, method=self.method)

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def pixel_rays(self) -> np.ndarray:
        """(H, W, 3) camera-frame directions with unit z through the pixel centres (``u + 0.5``, ``v + 0.5``):
        a z-depth map times these is its back-projection."""
        u, v = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        return np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones_like(u)], axis=-1)

    def save(self, directory: Path) -> None:
        data = {k: v for k, v in asdict(self).items()}
        data["vfov_deg"] = self.vfov_deg
        _write_json(directory / "camera.json", data)

    @classmethod
    def load(cls, directory: Path) -> "Camera":
        data = _read_json(directory / "camera.json")
        data.pop("vfov_deg", None)
        return cls(**data)


# --------------------------------------------------------------------------------------------- depth
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

    def save(self, directory: Path) -> None:
        np.save(directory / "depth.npy", self.depth.astype(np.float32))
        write_png(directory / "valid.png", self.valid.astype(np.uint8) * 255)
        _write_json(directory / "depth.json", {"metric": self.metric, "source": self.source})

    @classmethod
    def load(cls, directory: Path) -> "DepthMap":
        meta = _read_json(directory / "depth.json")
        depth = _read_npy(directory / "depth.npy").astype(np.float32)
        valid = _read_png(directory / "valid.png") > 0
        return cls(depth=depth, valid=valid & np.isfinite(depth) & (depth > 0), **meta)


# -------------------------------------------------------------------------------------------- detections
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
        _write_json(directory / "detections.json", {"source": self.source, "items": [
            {"label": d.label, "category": d.category, "box": [float(v) for v in d.box], "score": float(d.score)}
            for d in self.items]})

    @classmethod
    def load(cls, directory: Path) -> "Detections":
        data = _read_json(directory / "detections.json")
        try:
            items = [Detection(label=str(d["label"]), category=str(d["category"]), box=tuple(map(float, d["box"])),
                               score=float(d["score"])) for d in data["items"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(f"{directory / 'detections.json'}: not as psdr-room writes it ({exc}); "
                                "fix the entry or regenerate it") from None
        return cls(items=items, source=str(data.get("source", "")))


# ------------------------------------------------------------------------------------------ panoptic
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
        raise PsdrRoomError(f"{png}: the id map must be a 2-D integer array, got {ids.dtype} {ids.shape}; pass an int32 HxW array")
    if ids.size and (ids.min() < 0 or ids.max() >= 1 << 24):
        raise PsdrRoomError(f"{png}: ids must lie in 0..16777215 to fit an RGB PNG; renumber the segments")
    listed: set[int] = set()
    for s in segments:
        if s.id in listed:
            raise PsdrRoomError(f"{json_path}: segment id {s.id} appears twice; give each segment a unique id")
        listed.add(int(s.id))
    present = set(np.unique(ids).tolist()) - {0}
    if present - listed:
        raise PsdrRoomError(f"{png}: id map holds ids without a segment ({sorted(present - listed)[:5]}); add segments or zero those pixels")
    if listed - present:
        raise PsdrRoomError(f"{json_path}: segment(s) {sorted(listed - present)[:5]} have no pixels; drop them before writing")

    u = ids.astype(np.uint32)
    write_png(png, np.stack([u & 255, (u >> 8) & 255, (u >> 16) & 255], axis=-1).astype(np.uint8))
    cat_id = {name: i + 1 for i, name in enumerate(CATEGORIES)}
    infos = []
    for s in segments:
        ys, xs = np.nonzero(ids == s.id)
        x0, y0 = int(xs.min()), int(ys.min())
        bbox = [x0, y0, int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1]
        infos.append({"id": int(s.id), "category_id": cat_id[s.category], "label": s.label, "iscrowd": 0,
                      "area": int(xs.size), "bbox": bbox, **({} if s.score is None else {"score": float(s.score)}),
                      **({} if s.box is None else {"prompt_box": [float(v) for v in s.box]})})
    _write_json(json_path, {
        "file_name": png.name,
        "image_id": png.stem,
        "height": int(ids.shape[0]),
        "width": int(ids.shape[1]),
        "segments_info": infos,
        "categories": [{"id": i, "name": n, "isthing": int(n in ("object", "lamp"))} for n, i in cat_id.items()],
    })


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

    def save(self, directory: Path) -> None:
        write_coco_panoptic(directory / "panoptic.png", directory / "panoptic.json", self.ids, self.segments)

    @classmethod
    def load(cls, directory: Path) -> "Panoptic":
        """Read what :meth:`save` wrote; (edited) files from elsewhere go through ``segmentation=file``."""
        rgb = _read_png(directory / "panoptic.png")
        if rgb.ndim != 3:
            raise PsdrRoomError(f"{directory / 'panoptic.png'}: not an RGB PNG (id = R + 256 G + 256² B); regenerate it")
        meta = _read_json(directory / "panoptic.json")
        try:
            names = {c["id"]: c["name"] for c in meta["categories"]}
            segments = [Segment(int(s["id"]), names[s["category_id"]], s.get("label") or names[s["category_id"]],
                                None if s.get("score") is None else float(s["score"]), s.get("prompt_box"))
                        for s in meta["segments_info"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(
                f"{directory / 'panoptic.json'}: not as psdr-room writes it ({type(exc).__name__}: {exc}); "
                "regenerate it, or feed an edited segmentation in with segmentation=file"
            ) from None
        return cls(ids=panoptic_ids(rgb), segments=segments)


# --------------------------------------------------------------------------------------- point cloud
PLY_FIELDS = [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1"),
              ("segment", "<i4")]
PLY_TYPES = {"<f4": "float", "u1": "uchar", "<i4": "int"}


def ply_bytes(points: np.ndarray, colors: np.ndarray, segment: np.ndarray) -> bytes:
    """Binary little-endian PLY with per-vertex colour and an integer ``segment`` property."""
    data = np.empty(len(points), dtype=PLY_FIELDS)
    data["x"], data["y"], data["z"] = points[:, 0], points[:, 1], points[:, 2]
    data["red"], data["green"], data["blue"] = colors[:, 0], colors[:, 1], colors[:, 2]
    data["segment"] = segment
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(points)}"]
    header += [f"property {PLY_TYPES[t]} {name}" for name, t in PLY_FIELDS] + ["end_header"]
    return ("\n".join(header) + "\n").encode("ascii") + data.tobytes()


def read_ply(path: Path) -> np.ndarray:
    """Read a PLY written by :func:`ply_bytes` (structured array with :data:`PLY_FIELDS`)."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise PsdrRoomError(f"{path}: missing; the artifact directory is incomplete") from None
    end = raw.find(b"end_header\n")
    header = raw[:end].decode("ascii", "replace").splitlines()
    expected = [f"property {PLY_TYPES[t]} {name}" for name, t in PLY_FIELDS]
    if end < 0 or header[1:2] != ["format binary_little_endian 1.0"] or header[3:] != expected:
        raise PsdrRoomError(f"{path}: not a psdr-room point cloud PLY (binary, x y z red green blue segment)")
    count = int(header[2].split()[-1])
    return np.frombuffer(raw[end + len(b"end_header\n"):], dtype=PLY_FIELDS, count=count)


@dataclass
class PointCloud:
    """The segmented point cloud in the camera frame, with a segment id per point (see ``segments``)."""

    kind: ClassVar[str] = "point_cloud"
    marker: ClassVar[str] = "points.ply"
    points: np.ndarray
    colors: np.ndarray
    segment: np.ndarray
    segments: list[Segment]

    def category_points(self, category: str) -> np.ndarray:
        wanted = [s.id for s in self.segments if s.category == category]
        return self.points[np.isin(self.segment, wanted)]

    def save(self, directory: Path) -> None:
        (directory / "points.ply").write_bytes(ply_bytes(self.points, self.colors, self.segment))
        _write_json(directory / "segments.json", [asdict(s) for s in self.segments])

    @classmethod
    def load(cls, directory: Path) -> "PointCloud":
        data = read_ply(directory / "points.ply")
        segments = [Segment(**s) for s in _read_json(directory / "segments.json")]
        points = np.stack([data["x"], data["y"], data["z"]], axis=1).astype(np.float32)
        colors = np.stack([data["red"], data["green"], data["blue"]], axis=1)
        return cls(points=points, colors=colors, segment=data["segment"].astype(np.int32), segments=segments)


# -------------------------------------------------------------------------------------------- room box
def rotation_y(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about +Y."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass
class RoomBox:
    """The room as a box in the world frame, and the camera's pose in that frame.

    World corner = ``center + R_y(yaw) @ (±hx, ±hy, ±hz)``; the floor is ``y = 0`` so ``center[1] ==
    half_size[1]`` for a box standing on the floor.
    """

    kind: ClassVar[str] = "room_box"
    marker: ClassVar[str] = "room_box.json"
    camera_to_world: np.ndarray
    center: np.ndarray
    half_size: np.ndarray
    yaw: float
    ceiling_visible: bool = True
    extra: dict[str, Any] = field(default_factory=dict)

    def corners(self) -> np.ndarray:
        """The 8 world-space corners, index bits (x, y, z) → sign (-, +)."""
        signs = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)]) * 2.0 - 1.0
        return self.center + (signs * self.half_size) @ rotation_y(self.yaw).T

    def save(self, directory: Path) -> None:
        _write_json(
            directory / "room_box.json",
            {
                "camera_to_world": np.asarray(self.camera_to_world).tolist(),
                "center": np.asarray(self.center).tolist(),
                "half_size": np.asarray(self.half_size).tolist(),
                "yaw": float(self.yaw),
                "ceiling_visible": bool(self.ceiling_visible),
                "extra": self.extra,
            },
        )

    @classmethod
    def load(cls, directory: Path) -> "RoomBox":
        d = _read_json(directory / "room_box.json")
        return cls(
            camera_to_world=np.array(d["camera_to_world"], dtype=np.float64),
            center=np.array(d["center"], dtype=np.float64),
            half_size=np.array(d["half_size"], dtype=np.float64),
            yaw=float(d["yaw"]),
            ceiling_visible=bool(d["ceiling_visible"]),
            extra=d.get("extra", {}),
        )


# ---------------------------------------------------------------------------------- object candidates
@dataclass(frozen=True)
class Candidate:
    """A database model ranked for an object segment."""

    model_id: str
    score: float
    """Retrieval similarity (higher is better; its scale depends on the retrieval implementation)."""


@dataclass
class ObjectCandidates:
    """Top-k database models per object segment (the paper's "user picks among top-k")."""

    kind: ClassVar[str] = "object_candidates"
    marker: ClassVar[str] = "candidates.json"
    ranked: dict[int, list[Candidate]]
    """Segment id → candidates, best first."""
    labels: dict[int, str]
    """Segment id → its label."""
    source: str = ""
    """The retrieval implementation and database that ranked them."""
    sheet: np.ndarray | None = None
    """RGB uint8 picture: per object, its crop then the candidates' thumbnails with their scores."""

    def save(self, directory: Path) -> None:
        if self.sheet is not None:
            write_png(directory / "candidates.png", self.sheet)
        _write_json(directory / "candidates.json", {"source": self.source, "objects": [
            {"segment_id": sid, "label": self.labels.get(sid, ""),
             "candidates": [{"model_id": c.model_id, "score": float(c.score)} for c in ranked]}
            for sid, ranked in sorted(self.ranked.items())]})

    @classmethod
    def load(cls, directory: Path) -> "ObjectCandidates":
        data = _read_json(directory / "candidates.json")
        try:
            ranked = {int(o["segment_id"]): [Candidate(str(c["model_id"]), float(c["score"])) for c in o["candidates"]]
                      for o in data["objects"]}
            labels = {int(o["segment_id"]): str(o.get("label", "")) for o in data["objects"]}
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(f"{directory / 'candidates.json'}: not as psdr-room writes it ({exc}); fix or regenerate it") from None
        sheet = _read_png(directory / "candidates.png") if (directory / "candidates.png").is_file() else None
        return cls(ranked=ranked, labels=labels, source=str(data.get("source", "")), sheet=sheet)


# ---------------------------------------------------------------------------------- object placements
@dataclass(frozen=True)
class ObjectMesh:
    """A database mesh in its canonical frame (Y up, bottom at y = 0, centred on x = z = 0, front +Z), metres."""

    vertices: np.ndarray
    faces: np.ndarray
    face_group: np.ndarray
    """(M,) index into ``groups`` per face: the material parts."""
    groups: tuple[str, ...]
    colors: np.ndarray
    """(G, 3) float sRGB base colour per group, in [0, 1]."""

    @property
    def extent(self) -> tuple[float, float, float]:
        size = np.ptp(self.vertices, axis=0)
        return float(size[0]), float(size[1]), float(size[2])

    def group_mesh(self, group: str | int) -> TriangleMesh:
        """The faces of one group (all vertices kept) as a :class:`~psdr_room_core.geometry.TriangleMesh`."""
        index = self.groups.index(group) if isinstance(group, str) else int(group)
        return TriangleMesh(vertices=self.vertices, faces=self.faces[self.face_group == index])

    def triangle_mesh(self) -> TriangleMesh:
        return TriangleMesh(vertices=self.vertices, faces=self.faces)

    def check(self, where: str) -> None:
        """Raise :class:`PsdrRoomError` unless the arrays are consistent (shapes, indices, finite values)."""
        v, f, g = self.vertices, self.faces, self.face_group
        problems = []
        if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
            problems.append("vertices must be finite (N, 3)")
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
            problems.append("faces must be (M, 3) with M > 0")
        elif f.min() < 0 or f.max() >= len(v):
            problems.append("faces index vertices out of range")
        if g.shape != (len(f),) or (len(g) and (g.min() < 0 or g.max() >= len(self.groups))):
            problems.append("face_group must give every face a group")
        if self.colors.shape != (len(self.groups), 3) or not np.all((self.colors >= 0) & (self.colors <= 1)):
            problems.append("colors must be (G, 3) in [0, 1]")
        if problems:
            raise PsdrRoomError(f"{where}: invalid mesh ({'; '.join(problems)}); re-export it")

    def write_obj(self, obj: Path) -> None:
        """An OBJ (+ MTL beside it) with one ``usemtl`` block per group."""
        mtl = obj.with_suffix(".mtl")
        lines = [f"mtllib {mtl.name}"] + [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in self.vertices]
        for g, name in enumerate(self.groups):
            lines.append(f"usemtl {name}")
            lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in self.faces[self.face_group == g]]
        obj.write_text("\n".join(lines) + "\n")
        mtl.write_text("".join(f"newmtl {name}\nKd {r:.4f} {g:.4f} {b:.4f}\n"
                               for name, (r, g, b) in zip(self.groups, self.colors)))

    @classmethod
    def read_obj(cls, obj: Path) -> "ObjectMesh":
        """Read what :meth:`write_obj` wrote (triangles, ``usemtl`` groups, ``Kd`` colours)."""
        vertices, faces, face_group, groups = [], [], [], []
        try:
            for line in obj.read_text().splitlines():
                head, _, rest = line.partition(" ")
                if head == "v":
                    vertices.append([float(v) for v in rest.split()[:3]])
                elif head == "usemtl":
                    groups.append(rest.strip())
                elif head == "f":
                    faces.append([int(v.split("/")[0]) - 1 for v in rest.split()])
                    face_group.append(max(len(groups) - 1, 0))
            colors = dict.fromkeys(groups, (0.5, 0.5, 0.5))
            name = None
            mtl = obj.with_suffix(".mtl")
            for line in (mtl.read_text().splitlines() if mtl.is_file() else []):
                head, _, rest = line.partition(" ")
                if head == "newmtl":
                    name = rest.strip()
                elif head == "Kd" and name in colors:
                    colors[name] = tuple(float(v) for v in rest.split()[:3])
        except FileNotFoundError:
            raise PsdrRoomError(f"{obj}: missing; the artifact directory is incomplete") from None
        except ValueError as exc:
            raise PsdrRoomError(f"{obj}: not a triangle OBJ as psdr-room writes it ({exc}); fix or regenerate it") from None
        groups = groups or ["default"]
        return cls(vertices=np.asarray(vertices, np.float64).reshape(-1, 3), faces=np.asarray(faces, np.int64).reshape(-1, 3),
                   face_group=np.asarray(face_group, np.int64), groups=tuple(groups),
                   colors=np.asarray([colors.get(g, (0.5, 0.5, 0.5)) for g in groups], np.float64))


SUPPORTS = ("floor", "parent", "wall", "free")
"""How an object is held: on the floor, on top of another object, on a wall, or not at all."""


@dataclass(frozen=True)
class Placement:
    """One retrieved object placed in the world: ``to_world = T(position) R_y(yaw) S(scale)``."""

    segment_id: int
    label: str
    model_id: str
    mesh: ObjectMesh
    position: tuple[float, float, float]
    """World position of the mesh's origin (the centre of its bottom)."""
    yaw: float
    scale: float
    support: str = "free"
    """One of :data:`SUPPORTS`."""
    anchor: int | None = None
    """The parent's segment id (``parent``) or the room box side (``wall``: 0..3 = -x, +x, -z, +z)."""

    @property
    def to_world(self) -> np.ndarray:
        matrix = np.eye(4)
        matrix[:3, :3] = rotation_y(self.yaw) * self.scale
        matrix[:3, 3] = self.position
        return matrix

    def world_vertices(self) -> np.ndarray:
        return self.mesh.vertices @ self.to_world[:3, :3].T + np.asarray(self.position)


@dataclass
class Placements:
    """The scene's objects: retrieved meshes (``meshes/<segment>.obj``) and their poses (``placements.json``)."""

    kind: ClassVar[str] = "placements"
    marker: ClassVar[str] = "placements.json"
    objects: list[Placement]
    extra: dict[str, Any] = field(default_factory=dict)

    def save(self, directory: Path) -> None:
        (directory / "meshes").mkdir()
        items = []
        for p in self.objects:
            p.mesh.write_obj(directory / "meshes" / f"{p.segment_id}.obj")
            items.append({"segment_id": p.segment_id, "label": p.label, "model_id": p.model_id,
                          "mesh": f"meshes/{p.segment_id}.obj", "position": [float(v) for v in p.position],
                          "yaw": float(p.yaw), "scale": float(p.scale), "support": p.support, "anchor": p.anchor,
                          "to_world": p.to_world.tolist()})
        _write_json(directory / "placements.json", {"objects": items, "extra": self.extra})

    @classmethod
    def load(cls, directory: Path) -> "Placements":
        data = _read_json(directory / "placements.json")
        try:
            objects = [Placement(segment_id=int(o["segment_id"]), label=str(o["label"]), model_id=str(o["model_id"]),
                                 mesh=ObjectMesh.read_obj(directory / o["mesh"]),
                                 position=tuple(float(v) for v in o["position"]), yaw=float(o["yaw"]),
                                 scale=float(o["scale"]), support=str(o["support"]),
                                 anchor=None if o.get("anchor") is None else int(o["anchor"]))
                       for o in data["objects"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(f"{directory / 'placements.json'}: not as psdr-room writes it ({exc}); fix or regenerate it") from None
        return cls(objects=objects, extra=dict(data.get("extra") or {}))


# ------------------------------------------------------------------------------------------ materials
Rect = tuple[int, int, int, int]
"""A crop window ``(x0, y0, x1, y1)`` in working-image pixels, ``x1``/``y1`` exclusive."""


@dataclass(frozen=True)
class PartMaterial:
    """The material assigned to one scene part (a room side or an object's material group), §4.4."""

    part: str
    """Shape id as exported: ``floor``, ``wall_x_neg`` ..., ``object_<segment>_<group>``."""
    kind: str
    """``homogeneous`` (constant albedo and roughness) or ``procedural`` (a library graph)."""
    albedo: tuple[float, float, float]
    """sRGB median colour of the part's pixels: the homogeneous albedo and eq. 4's colour target ``C_i``."""
    roughness: float = 0.5
    material: str | None = None
    """The library graph of a procedural part."""
    scale: float = 1.0
    """Texture transform: the graph's tile covers ``tile_size / scale`` metres of the surface ..."""
    rotation: float = 0.0
    """... rotated by this many degrees in the part's planar mapping."""
    crops: tuple[Rect, ...] = ()
    candidates: tuple[tuple[str, float], ...] = ()
    """Retrieved graphs (name, similarity), best first, after voting across crops."""
    scores: dict[str, float] = field(default_factory=dict)
    """``similarity`` of the chosen graph, ``texture_loss`` at the chosen transform, ``homogeneous_loss``."""
    reason: str = ""
    """Why the part got its kind, in words."""


@dataclass
class MaterialAssignment:
    """Initial materials of every visible part with their crop pairs (§4.4, first half)."""

    kind: ClassVar[str] = "materials"
    marker: ClassVar[str] = "materials.json"
    parts: list[PartMaterial]
    images: dict[str, np.ndarray] = field(default_factory=dict)
    """Name → RGB uint8 picture (crop windows over the photo, crop pairs sheet)."""
    samples: np.ndarray | None = None
    """(H, W) int16 at the working image's size: the index in ``parts`` of the part whose colour target this
    pixel gave (its clean pixels, else its region), -1 elsewhere."""

    def part(self, name: str) -> PartMaterial | None:
        return next((p for p in self.parts if p.part == name), None)

    def save(self, directory: Path) -> None:
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)
        if self.samples is not None:
            np.save(directory / "samples.npy", self.samples.astype(np.int16))
        _write_json(directory / "materials.json", {"images": sorted(self.images), "parts": [
            {**asdict(p), "crops": [list(c) for c in p.crops], "candidates": [list(c) for c in p.candidates]}
            for p in self.parts]})

    @classmethod
    def load(cls, directory: Path) -> "MaterialAssignment":
        data = _read_json(directory / "materials.json")
        try:
            parts = [PartMaterial(**{**p, "albedo": tuple(float(v) for v in p["albedo"]),
                                     "crops": tuple(tuple(int(v) for v in c) for c in p["crops"]),
                                     "candidates": tuple((str(n), float(s)) for n, s in p["candidates"])})
                     for p in data["parts"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(f"{directory / 'materials.json'}: not as psdr-room writes it ({exc}); fix or regenerate it") from None
        samples = _read_npy(directory / "samples.npy") if (directory / "samples.npy").is_file() else None
        return cls(parts=parts, images={n: _read_png(directory / f"{n}.png") for n in data.get("images", [])},
                   samples=samples)


# ------------------------------------------------------------------------------------------- lighting
@dataclass
class Light:
    """An area light: a world-space mesh emitting on the side its triangles face counter-clockwise."""

    name: str
    kind: str
    """``ceiling``, ``behind_camera``, ``invisible_wall``, ``window`` or ``lamp`` (§4.4)."""
    mesh: TriangleMesh
    radiance: tuple[float, float, float] = (1.0, 1.0, 1.0)
    """Linear RGB radiance."""
    part: str | None = None
    """The scene part this light replaces (a lamp's largest visible part), if any."""


def _save_meshes(path: Path, meshes: dict[str, TriangleMesh]) -> None:
    arrays = {}
    for k, (name, mesh) in enumerate(meshes.items()):
        arrays[f"v{k}"], arrays[f"f{k}"] = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    np.savez(path, **arrays)


def _load_meshes(path: Path, names: list[str]) -> dict[str, TriangleMesh]:
    try:
        with np.load(path, allow_pickle=False) as data:
            return {name: TriangleMesh(data[f"v{k}"], data[f"f{k}"]) for k, name in enumerate(names)}
    except (FileNotFoundError, KeyError, ValueError) as exc:
        raise PsdrRoomError(f"{path}: missing or incomplete ({exc}); regenerate the artifact") from None


@dataclass
class Lights:
    """The scene's initial lights (§4.4): emitters, window frames, and the chosen uniform radiance."""

    kind: ClassVar[str] = "lights"
    marker: ClassVar[str] = "lights.json"
    lights: list[Light]
    fixtures: dict[str, TriangleMesh] = field(default_factory=dict)
    """Non-emitting geometry the lights bring (window frames), world space."""
    sweep: list[tuple[float, float]] = field(default_factory=list)
    """(radiance, loss) of every uniform value tried."""
    images: dict[str, np.ndarray] = field(default_factory=dict)

    def save(self, directory: Path) -> None:
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)
        _save_meshes(directory / "meshes.npz", {**{l.name: l.mesh for l in self.lights}, **self.fixtures})
        _write_json(directory / "lights.json", {
            "lights": [{"name": l.name, "kind": l.kind, "radiance": list(l.radiance), "part": l.part} for l in self.lights],
            "fixtures": list(self.fixtures), "sweep": [list(s) for s in self.sweep], "images": sorted(self.images)})

    @classmethod
    def load(cls, directory: Path) -> "Lights":
        data = _read_json(directory / "lights.json")
        try:
            names = [l["name"] for l in data["lights"]] + list(data["fixtures"])
            meshes = _load_meshes(directory / "meshes.npz", names)
            lights = [Light(str(l["name"]), str(l["kind"]), meshes[l["name"]], tuple(float(v) for v in l["radiance"]),
                            l.get("part")) for l in data["lights"]]
            return cls(lights=lights, fixtures={n: meshes[n] for n in data["fixtures"]},
                       sweep=[(float(a), float(b)) for a, b in data["sweep"]],
                       images={n: _read_png(directory / f"{n}.png") for n in data.get("images", [])})
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(f"{directory / 'lights.json'}: not as psdr-room writes it ({exc}); fix or regenerate it") from None


@dataclass
class PartAppearance:
    """A scene part's optimised material (§4.4, eq. 4)."""

    part: str
    kind: str
    """``homogeneous`` or ``procedural``."""
    base_color: tuple[float, float, float]
    """Linear RGB (a procedural part: the mean of its map, for reference)."""
    roughness: float = 0.5
    specular: float = 0.5
    material: str | None = None
    scale: float = 1.0
    rotation: float = 0.0
    params: dict[str, Any] = field(default_factory=dict)
    """The graph's continuous parameters (``node.param`` → number or nested list) of a procedural part."""


@dataclass
class SceneAppearance:
    """Materials and light radiances after the joint optimisation, with its renders."""

    kind: ClassVar[str] = "appearance"
    marker: ClassVar[str] = "appearance.json"
    parts: list[PartAppearance]
    radiance: dict[str, tuple[float, float, float]]
    """Light name → linear RGB radiance."""
    images: dict[str, np.ndarray] = field(default_factory=dict)

    def part(self, name: str) -> PartAppearance | None:
        return next((p for p in self.parts if p.part == name), None)

    def save(self, directory: Path) -> None:
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)
        _write_json(directory / "appearance.json", {"parts": [asdict(p) for p in self.parts],
                                                    "radiance": {k: list(v) for k, v in self.radiance.items()},
                                                    "images": sorted(self.images)})

    @classmethod
    def load(cls, directory: Path) -> "SceneAppearance":
        data = _read_json(directory / "appearance.json")
        return cls(**appearance_fields(data, directory / "appearance.json"),
                   images={n: _read_png(directory / f"{n}.png") for n in data.get("images", [])})


def appearance_fields(data: Any, path: Path) -> dict[str, Any]:
    """``parts`` and ``radiance`` of a :class:`SceneAppearance` from its JSON form (``path`` for errors)."""
    try:
        parts = [PartAppearance(**{**p, "base_color": tuple(float(v) for v in p["base_color"]),
                                   "params": dict(p.get("params", {}))}) for p in data["parts"]]
        radiance = {str(k): tuple(float(x) for x in v) for k, v in data["radiance"].items()}
    except (KeyError, TypeError, ValueError) as exc:
        raise PsdrRoomError(f"{path}: not as psdr-room writes it ({exc}); fix or regenerate it") from None
    return {"parts": parts, "radiance": radiance}


# ------------------------------------------------------------------------------------------ scene files
@dataclass
class SceneFiles:
    """An exported scene: a directory of files (``scene.xml`` for Mitsuba 3, meshes, point cloud)."""

    kind: ClassVar[str] = "scene_files"
    marker: ClassVar[str] = "scene.xml"
    files: dict[str, bytes]
    """Relative path → content."""

    def save(self, directory: Path) -> None:
        for rel, content in self.files.items():
            target = directory / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(content)

    @classmethod
    def load(cls, directory: Path) -> "SceneFiles":
        return cls(files={p.relative_to(directory).as_posix(): p.read_bytes()
                          for p in sorted(directory.rglob("*")) if p.is_file()})


# --------------------------------------------------------------------------------------- optimisation
@dataclass
class OptimizationLog:
    """What an optimisation stage did: per-iteration loss terms and timings, pictures, and a summary."""

    kind: ClassVar[str] = "optimization_log"
    marker: ClassVar[str] = "log.json"
    history: list[dict[str, float]]
    images: dict[str, np.ndarray]
    """Name → RGB uint8 picture (before/after overlays, loss curves)."""
    summary: dict[str, Any] = field(default_factory=dict)

    def save(self, directory: Path) -> None:
        _write_json(directory / "log.json", {"history": self.history, "summary": self.summary,
                                             "images": sorted(self.images)})
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)

    @classmethod
    def load(cls, directory: Path) -> "OptimizationLog":
        data = _read_json(directory / "log.json")
        images = {name: _read_png(directory / f"{name}.png") for name in data["images"]}
        return cls(history=data["history"], images=images, summary=data["summary"])


ARTIFACT_TYPES: dict[str, type] = {
    t.kind: t
    for t in (Image, Camera, DepthMap, Detections, Panoptic, PointCloud, RoomBox, ObjectCandidates, Placements,
              MaterialAssignment, Lights, SceneAppearance, SceneFiles, OptimizationLog)
}
"""Artifact kind → class, for loading cached or user-supplied artifacts. Plugins may add their own."""

def artifact_kind_of(directory: Path) -> str:
    """Recognise a saved artifact directory (as published under a run's ``artifacts/``) by its files."""
    if not directory.is_dir():
        raise PsdrRoomError(f"{directory}: not a directory; inject.NAME= takes an artifact directory from a run's artifacts/")
    for kind, cls in ARTIFACT_TYPES.items():
        if (directory / cls.marker).is_file():
            return kind
    raise PsdrRoomError(
        f"{directory}: not a saved artifact (none of {', '.join(sorted(c.marker for c in ARTIFACT_TYPES.values()))}); "
        "use a directory from a run's artifacts/"
    )
