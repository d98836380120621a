"""``segmentation=eyes``, ``depth=eyes`` and ``detector=eyes``: psdr-room's own network, trained on its renders
(:mod:`psdr_room_core.applications.train`) and shipped in the package (``eyes.onnx`` with ``eyes.json``: its
sha256 and how it was made), run with onnxruntime alone.

The network (the shipped one, or ``path``) is checked against the sha256 of the ``eyes.json`` beside it before it
runs (:mod:`psdr_room_core.method.checksums`): a damaged one stops a run that chose ``eyes`` by name, and ``auto``
passes over it (and over ``layout_eyes`` and ``nanodet_eyes``, which use it) with a warning line.

The photo is stretched to the network's 320×240 input; its outputs (a quarter of that) are resized back to the
working image: surface logits bilinearly, then argmax; depth bilinearly; instances (:func:`.decode.instances`)
by nearest neighbour inside the full-resolution object pixels, each with its 3D box in the photo's camera frame
(:func:`.box3d.read_box`, for the camera's focal) where the network has the 3D heads.
"""

from __future__ import annotations

import functools
import hashlib
import json
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import cv2
import numpy as np

from psdr_room_core.engine import threads as run_threads
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method import checksums
from psdr_room_core.method.artifacts import (
    Camera,
    DepthMap,
    Detection,
    Detections,
    Image,
    Panoptic,
    SeenBox,
    Segment,
)
from psdr_room_core.method.image_boxes import mask_box

from .box3d import BOX_OUTPUTS, read_box
from .decode import instances
from .labels import CATEGORIES, SURFACES

SHIPPED = Path(__file__).resolve().parent / "eyes.onnx"
INPUT_SIZE = (240, 320)
STUFF = ("wall", "floor", "ceiling")
"""Surface classes that become one segment each; windows and doors one per connected region."""


def shipped_note() -> dict:
    """``eyes.json`` beside the shipped network (how it was made), or {} when none is shipped."""
    note = SHIPPED.with_suffix(".json")
    return json.loads(note.read_text()) if note.is_file() else {}


def missing(path: Path) -> str | None:
    """Why the network at ``path`` cannot run (None: it can)."""
    if not path.is_file():
        return f"no eyes network at {path} (train one with psdr-room-train and copy its eyes.onnx there)"
    return None


def checked_sha256(path: Path) -> str:
    """The sha256 of the network at ``path``, checked against the ``eyes.json`` beside it
    (:func:`~psdr_room_core.method.checksums.check_beside`)."""
    if path.resolve() == SHIPPED:
        fix = "restore it (`git checkout -- plugins/eyes/eyes.onnx` in a checkout) or reinstall psdr-room"
    else:
        fix = "copy it again with the eyes.json psdr-room-train wrote beside it"
    return checksums.check_beside(path, fix)


@functools.lru_cache(maxsize=2)
def _session(path: str, threads: int, digest: str) -> object:
    """An onnxruntime session of the file at ``path`` whose content has sha256 ``digest``."""
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    try:
        return ort.InferenceSession(path, options, providers=["CPUExecutionProvider"])
    except Exception:  # onnxruntime raises its own types for damaged files
        raise PsdrRoomError(
            f"{path}: not a loadable ONNX network; train or copy it again (psdr-room-train writes eyes.onnx)"
        ) from None


_RECENT: dict[tuple[str, bytes], dict[str, np.ndarray]] = {}
"""Outputs of the last few (network, image) pairs: the three stages that use the network run it once."""


class Eyes:
    """The shipped (or another trained) eyes network on one photo's working image."""

    def __init__(
        self,
        path: str | None = None,
        intra_op_threads: int = 0,
        center_threshold: float = 0.3,
        min_instance_fraction: float = 0.002,
    ) -> None:
        self.path = Path(path) if path else SHIPPED
        self.threads = int(intra_op_threads)
        self.center_threshold = float(center_threshold)
        self.min_instance_fraction = float(min_instance_fraction)
        self._digest: str | None = None

    def external_files(self, photo: Path) -> list[Path]:
        return [self.path]

    def unavailable(self, photo: Path) -> str | None:
        return missing(self.path) or self.damaged()

    def damaged(self) -> str | None:
        """Why ``auto`` passes over the network: it is not the file its note records (a warning line says so);
        None when it is."""
        return checksums.damage(self.sha256)

    def sha256(self) -> str:
        """The network's sha256, checked against its note once per instance (one per stage and run)."""
        if self._digest is None:
            self._digest = checked_sha256(self.path)
        return self._digest

    def outputs(self, image: Image) -> dict[str, np.ndarray]:
        """The network's outputs for ``image`` (name → [C, 60, 80]); one run per image, shared by the stages
        of one process."""
        reason = missing(self.path)
        if reason:
            raise PsdrRoomError(reason)
        rgb = np.ascontiguousarray(image.rgb, np.float32)
        digest = self.sha256()
        key = (digest, hashlib.sha256(rgb.tobytes()).digest())
        if key not in _RECENT:
            session = _session(str(self.path), self.threads or run_threads.count(), digest)
            small = cv2.resize(rgb, INPUT_SIZE[::-1], interpolation=cv2.INTER_AREA)
            names = [o.name for o in session.get_outputs()]  # type: ignore[attr-defined]
            values = session.run(names, {"image": np.ascontiguousarray(small.transpose(2, 0, 1)[None])})  # type: ignore[attr-defined]
            while len(_RECENT) >= 4:
                _RECENT.pop(next(iter(_RECENT)))
            _RECENT[key] = {name: value[0] for name, value in zip(names, values)}
        return _RECENT[key]

    def describe(self) -> str:
        note = shipped_note() if self.path == SHIPPED else {}
        return f"eyes ({self.path.name}{', sha256 ' + note['sha256'][:12] if note else ''})"

    # -- what the outputs say ------------------------------------------------------------------------------
    def surfaces(self, image: Image, out: dict[str, np.ndarray]) -> np.ndarray:
        """Surface class per working-image pixel (:data:`.labels.SURFACES`)."""
        logits = np.stack(
            [cv2.resize(c, (image.width, image.height), interpolation=cv2.INTER_LINEAR) for c in out["surface"]]
        )
        return logits.argmax(axis=0)

    def room(self, surface: np.ndarray) -> Panoptic:
        """The room's segments of a :meth:`surfaces` map: wall, floor and ceiling one each, windows and doors
        one per connected region (regions under ``min_instance_fraction`` of the photo dropped)."""
        ids = np.zeros(surface.shape, np.int32)
        segments: list[Segment] = []
        least = max(1, int(self.min_instance_fraction * surface.size))
        for name in ("wall", "floor", "ceiling", "window", "door"):
            mask = (surface == SURFACES.index(name)).astype(np.uint8)
            if name in STUFF:
                parts = [mask.astype(bool)]
            else:
                count, labels = cv2.connectedComponents(mask, connectivity=8)
                parts = [labels == c for c in range(1, count)]
            for part in parts:
                if part.sum() >= least:
                    segments.append(Segment(len(segments) + 1, name, name))
                    ids[part] = segments[-1].id
        return Panoptic(ids=ids, segments=segments)

    def objects(
        self, image: Image, out: dict[str, np.ndarray], surface: np.ndarray, camera: Camera | None = None
    ) -> list[Found]:
        """Each piece of furniture found, at working resolution; with the photo's ``camera``, its 3D box where the
        network has the 3D heads."""
        found = instances(out["surface"], out["category"], out["center"], out["offset"], self.center_threshold)
        if not found:
            return []
        owner = np.zeros(found[0].mask.shape, np.int32)
        for k, item in reversed(list(enumerate(found))):  # the best centre keeps a shared cell
            owner[item.mask] = k + 1
        full = cv2.resize(owner, (image.width, image.height), interpolation=cv2.INTER_NEAREST)
        full[surface != SURFACES.index("object")] = 0
        least = self.min_instance_fraction * image.width * image.height
        result = []
        for k, item in enumerate(found):
            mask = full == k + 1
            if mask.sum() >= least:
                seen = _seen_box(out, owner == k + 1, camera) if camera is not None else None
                result.append(Found(mask, CATEGORIES[item.category], item.score, seen))
        return result

    def panoptic(self, image: Image, camera: Camera) -> Panoptic:
        """The room's segments (:meth:`room`) and one segment per piece of furniture, labelled with its
        category, with its 3D box where the network sees one."""
        out = self.outputs(image)
        surface = self.surfaces(image, out)
        room = self.room(surface)
        segments = list(room.segments)
        for item in self.objects(image, out, surface, camera):
            segments.append(Segment(len(segments) + 1, _category(item.name), item.name, seen=item.seen))
            room.ids[item.mask] = segments[-1].id
        return Panoptic(ids=room.ids, segments=segments)


class Found(NamedTuple):
    """A piece of furniture the network found."""

    mask: np.ndarray
    """(H, W) bool at working resolution."""
    name: str
    """Its category (:data:`.labels.CATEGORIES`)."""
    score: float
    """Its centre's score."""
    seen: SeenBox | None
    """Its 3D box in the photo's camera frame (None: the network has no 3D heads, or no camera was given)."""


def _seen_box(out: dict[str, np.ndarray], mask: np.ndarray, camera: Camera) -> SeenBox | None:
    """The 3D box of the instance on ``mask`` (output resolution) for a photo seen by ``camera``: the network's
    input is the photo stretched to :data:`INPUT_SIZE`, so its focal is the camera's in input pixels."""
    if any(name not in out for name in BOX_OUTPUTS):
        return None
    fx, fy = camera.fx * INPUT_SIZE[1] / camera.width, camera.fy * INPUT_SIZE[0] / camera.height
    box = read_box(out, mask, fx, fy)
    if not (np.all(np.isfinite(box.center)) and box.center[2] > 0):
        return None
    return SeenBox(tuple(box.center), tuple(box.size), box.yaw, min(max(box.yaw_confidence, 0.0), 1.0))


def _category(name: str) -> str:
    """The room category of an eyes furniture category (ceiling lights and lamps are ``lamp``)."""
    return "lamp" if name == "lamp" else "object"


class EyesSegmentation(Eyes):
    """Panoptic segmentation by the eyes network: wall, floor and ceiling one segment each, windows and doors
    per region, one segment per piece of furniture labelled with its category. It does not take box prompts:
    ``segmentation=auto`` passes it over for a photo with the user's boxes beside it, which ``layout`` cuts out."""

    def unavailable(self, photo: Path) -> str | None:
        from psdr_room_plugins.detectors.boxes_file import sidecar_path

        boxes = sidecar_path(photo)
        if boxes.is_file():
            return f"the photo has your boxes ({boxes.name}), which segmentation=layout cuts out"
        return super().unavailable(photo)

    def segment(self, image: Image, camera: Camera, detections: Detections, photo: Path) -> Panoptic:
        return self.panoptic(image, camera)


class EyesDepth(Eyes):
    """Relative depth by the eyes network, normalised to a unit range (``metric=False``) as the paper's."""

    def estimate(self, image: Image, camera: Camera, panoptic: Panoptic, photo: Path) -> DepthMap:
        log_depth = cv2.resize(
            self.outputs(image)["depth"][0], (image.width, image.height), interpolation=cv2.INTER_LINEAR
        )
        depth = np.exp(log_depth - log_depth.max()).astype(np.float32)
        return DepthMap(depth=depth, valid=np.isfinite(depth) & (depth > 0), metric=False, source=self.describe())


class EyesDetector(Eyes):
    """Furniture boxes from the eyes network's instances (label: its category; score: the centre's)."""

    def detect(self, image: Image, photo: Path) -> Detections:
        out = self.outputs(image)
        items = []
        for item in self.objects(image, out, self.surfaces(image, out)):
            box = mask_box(item.mask)
            assert box is not None  # an instance has pixels
            x0, y0, x1, y1 = (float(v) for v in box)
            items.append(Detection(item.name, _category(item.name), (x0, y0, x1, y1), min(max(item.score, 0.0), 1.0)))
        return Detections(sorted(items, key=lambda d: -d.score), source=self.describe())


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import DepthEstimator, Detector, Segmenter

    _EyesDepth_is_a_depth: type[DepthEstimator] = EyesDepth
    _EyesDetector_is_a_detector: type[Detector] = EyesDetector
    _EyesSegmentation_is_a_segmentation: type[Segmenter] = EyesSegmentation
