"""Training data of the eyes network: a data set folder of ``psdr-room-synth-data`` packed into one file, the
per-batch augmentation that makes a render look like any photo, and the targets of each head.

A pack (:func:`build_pack`) holds each sample's photo as JPEG bytes at the network's input size, its labels
at the heads' quarter resolution (surface, category, instance, depth in whole centimetres) and a table of its
instances' 3D boxes: small enough to copy to another machine (about 11 KB a sample: 3,600 samples in 41 MB), fast
enough to read every epoch.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.libraries.synth.instances import camera_frame_corners
from psdr_room_core.method.visualize import to_uint8

from .box3d import AMODAL_UNIT, REFERENCE_FOCAL, amodal_box, observation_angle, yaw_targets
from .labels import OBJECT
from .network import INPUT_SIZE

STRIDE = 4
LABEL_SIZE = (INPUT_SIZE[0] // STRIDE, INPUT_SIZE[1] // STRIDE)
IGNORE = -100
MAX_SLOTS = 64
"""Instances of one example the embedding loss pools (the data engine places fewer)."""


@dataclass
class Pack:
    """Samples in memory: seeds, JPEG bytes (concatenated, with offsets) and quarter-resolution labels."""

    seeds: np.ndarray
    jpeg: np.ndarray
    offsets: np.ndarray
    surface: np.ndarray
    category: np.ndarray
    instance: np.ndarray
    depth_cm: np.ndarray
    """z-depth in centimetres, uint16 (0: none); compressed, about half the size of float16 metres."""
    focal: np.ndarray
    """[N, 2] each sample's (fx, fy) in input pixels."""
    models: np.ndarray
    """The catalogue model ids the boxes name (str)."""
    box_sample: np.ndarray
    """Per box row (one per instance with a catalogue model): its sample's index, int32; then, per row,"""
    box_instance: np.ndarray
    """its id in the sample's instance map (uint16),"""
    box_center: np.ndarray
    """its centre in the camera frame (float32 [K, 3], m),"""
    box_size: np.ndarray
    """its size along its own axes (float32 [K, 3], m),"""
    box_alpha: np.ndarray
    """its observation angle (float32, :func:`.box3d.observation_angle`),"""
    box_amodal: np.ndarray
    """its projected box (float32 [K, 4], x0 y0 x1 y1 in input pixels),"""
    box_model: np.ndarray
    """and its model's index in ``models`` (int32)."""

    def __len__(self) -> int:
        return len(self.seeds)

    def photo(self, index: int) -> np.ndarray:
        """Sample ``index``'s photo, RGB uint8 [240, 320, 3]."""
        data = self.jpeg[self.offsets[index] : self.offsets[index + 1]]
        image = cv2.imdecode(data, cv2.IMREAD_COLOR)
        if image is None:
            raise PsdrRoomError(
                f"sample {index} (seed {self.seeds[index]}): damaged JPEG in the pack; delete the pack to rebuild it"
            )
        return image[..., ::-1]

    def boxes(self, index: int) -> np.ndarray:
        """The box rows of sample ``index``."""
        return np.flatnonzero(self.box_sample == index)

    def split(self, validation: float) -> tuple[np.ndarray, np.ndarray]:
        """(training, validation) indices: the highest seeds are held out."""
        order = np.argsort(self.seeds)
        held = max(1, int(round(len(order) * validation)))
        return np.sort(order[:-held]), np.sort(order[-held:])

    def save(self, path: Path) -> Path:
        partial = path.with_suffix(".part.npz")
        np.savez_compressed(partial, **{k: getattr(self, k) for k in self.__dataclass_fields__})
        partial.replace(path)
        return path

    @classmethod
    def load(cls, path: Path) -> Pack:
        with np.load(path) as data:
            missing = [k for k in cls.__dataclass_fields__ if k not in data]
            if missing:
                raise PsdrRoomError(
                    f"{path}: a pack of an older format (no {', '.join(missing)}); delete it to rebuild"
                )
            return cls(**{k: data[k] for k in cls.__dataclass_fields__})


def _quarter(array: np.ndarray) -> np.ndarray:
    """A full-resolution label map sampled at the centre of each quarter-resolution cell."""
    h, w = array.shape
    ys = (np.arange(LABEL_SIZE[0]) + 0.5) * h / LABEL_SIZE[0]
    xs = (np.arange(LABEL_SIZE[1]) + 0.5) * w / LABEL_SIZE[1]
    return array[ys.astype(int)[:, None], xs.astype(int)[None, :]]


def build_pack(folder: Path, path: Path, quality: int = 80, limit: int | None = None) -> Pack:
    """Pack every complete sample of ``folder`` (at most ``limit``, lowest seeds first) into ``path``."""
    seeds = sorted(
        int(p.stem) for p in folder.glob("*.npz") if p.stem.isdigit() and (folder / f"{p.stem}.jpg").is_file()
    )
    seeds = seeds[:limit] if limit else seeds
    chunks: list[np.ndarray] = []
    offsets = [0]
    labels: dict[str, list[np.ndarray]] = {k: [] for k in ("surface", "category", "instance", "depth")}
    focals: list[tuple[float, float]] = []
    rows: list[dict[str, np.ndarray]] = []
    for index, seed in enumerate(seeds):
        image = cv2.imread(str(folder / f"{seed:06d}.jpg"), cv2.IMREAD_COLOR)
        if image is None:
            raise PsdrRoomError(
                f"{folder / f'{seed:06d}.jpg'}: not a readable JPEG; delete it and render the sample again"
            )
        image = cv2.resize(image, INPUT_SIZE[::-1], interpolation=cv2.INTER_AREA)
        chunks.append(cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])[1].reshape(-1))
        offsets.append(offsets[-1] + len(chunks[-1]))
        with np.load(folder / f"{seed:06d}.npz") as data:
            for key in labels:
                labels[key].append(_quarter(data[key]))
            zoom = (INPUT_SIZE[1] / data["surface"].shape[1], INPUT_SIZE[0] / data["surface"].shape[0])
            focals.append((float(data["camera"][0]) * zoom[0], float(data["camera"][1]) * zoom[1]))
            rows.append(_box_rows(data, index, zoom))
    table = {k: np.concatenate([r[k] for r in rows]) if rows else np.zeros(0) for k in _BOX_KEYS}
    models, model_index = np.unique(table["model"].astype(str), return_inverse=True)
    pack = Pack(
        np.array(seeds, np.int64),
        np.concatenate(chunks) if chunks else np.zeros(0, np.uint8),
        np.array(offsets, np.int64),
        surface=np.stack(labels["surface"]),
        category=np.stack(labels["category"]),
        instance=np.stack(labels["instance"]),
        depth_cm=np.round(np.stack(labels["depth"]).astype(np.float32) * 100.0).astype(np.uint16),
        focal=np.array(focals, np.float32).reshape(-1, 2),
        models=models,
        box_sample=table["sample"].astype(np.int32),
        box_instance=table["instance"].astype(np.uint16),
        box_center=table["center"].astype(np.float32).reshape(-1, 3),
        box_size=table["size"].astype(np.float32).reshape(-1, 3),
        box_alpha=table["alpha"].astype(np.float32),
        box_amodal=table["amodal"].astype(np.float32).reshape(-1, 4),
        box_model=model_index.astype(np.int32),
    )
    pack.save(path)
    return pack


_BOX_KEYS = ("sample", "instance", "center", "size", "alpha", "amodal", "model")


def _box_rows(data: np.lib.npyio.NpzFile, index: int, zoom: tuple[float, float]) -> dict[str, np.ndarray]:
    """The box rows of one sample file: its instances with a catalogue model, amodal boxes in input pixels."""
    if "instance_ids" not in data:
        raise PsdrRoomError(
            "a data set sample without 3D labels (made by an older psdr-room-synth-data); render it again"
        )
    keep = np.char.str_len(data["instance_model"].astype(str)) > 0
    fx, fy, cx, cy = (float(v) for v in data["camera"])
    centers, sizes, yaws = data["instance_center"][keep], data["instance_size"][keep], data["instance_yaw"][keep]
    amodal = [
        amodal_box(camera_frame_corners(c, s, float(y), data["camera_to_world"]), fx, fy, cx, cy)
        for c, s, y in zip(centers, sizes, yaws)
    ]
    scale = np.array([zoom[0], zoom[1], zoom[0], zoom[1]])
    return {
        "sample": np.full(int(keep.sum()), index),
        "instance": data["instance_ids"][keep],
        "center": centers,
        "size": sizes,
        "alpha": observation_angle(yaws, centers),
        "amodal": np.array(amodal).reshape(-1, 4) * scale,
        "model": data["instance_model"][keep].astype(str),
    }


def augment_photo(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A render made to look like another camera's photo: exposure, gamma, white balance, saturation, blur,
    sensor noise and JPEG (uint8 RGB in and out)."""
    x = image.astype(np.float32) / 255.0
    x = np.clip(x * np.exp(rng.uniform(np.log(0.6), np.log(2.0))), 0, 1) ** rng.uniform(0.7, 1.25)  # renders
    # exposed for a bright window leave the room dark: brighten more often than darken
    x = x * rng.uniform(0.85, 1.15, 3)
    grey = x.mean(axis=2, keepdims=True)
    x = grey + (x - grey) * rng.uniform(0.6, 1.3)
    if rng.random() < 0.3:
        x = cv2.GaussianBlur(x, (0, 0), rng.uniform(0.4, 1.2))
    x = x + rng.normal(0.0, rng.uniform(0.0, 0.03), x.shape)
    out = to_uint8(x)
    if rng.random() < 0.5:
        data = cv2.imencode(".jpg", out[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, int(rng.integers(40, 96))])[1]
        decoded = cv2.imdecode(data, cv2.IMREAD_COLOR)
        assert decoded is not None, "a JPEG encoded just now decodes"
        out = decoded[..., ::-1]
    return out


def centre_targets(instance: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre heatmap [h, w], offsets [2, h, w] in label pixels, offset weight [h, w]) of an instance map:
    a Gaussian at each instance's centroid (sigma from its size), and on its pixels the vector to it."""
    h, w = instance.shape
    heat = np.zeros((h, w), np.float32)
    offset = np.zeros((2, h, w), np.float32)
    weight = np.zeros((h, w), np.float32)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    for value in np.unique(instance):
        if value == 0:
            continue
        mask = instance == value
        cy, cx = float(ys[mask].mean()), float(xs[mask].mean())
        sigma = max(0.8, float(np.sqrt(mask.sum())) / 6.0)
        heat = np.maximum(heat, np.exp(-((xs - cx) ** 2 + (ys - cy) ** 2) / (2 * sigma**2)))
        heat[min(int(round(cy)), h - 1), min(int(round(cx)), w - 1)] = 1.0  # the focal loss's positive
        offset[0][mask], offset[1][mask] = cx - xs[mask], cy - ys[mask]
        weight[mask] = 1.0
    return heat, offset, weight


def example(pack: Pack, index: int, rng: np.random.Generator | None) -> dict[str, np.ndarray]:
    """One training example (augmented when ``rng`` is given): image uint8 [3, 240, 320] (sRGB), the image-plane
    targets surface, category (IGNORE off objects), center, offset, offset_weight, depth (0: none), and the 3D
    heads' (:func:`box_targets`)."""
    image = pack.photo(index)
    surface, category = pack.surface[index].astype(np.int64), pack.category[index].astype(np.int64)
    instance, depth = pack.instance[index], pack.depth_cm[index].astype(np.float32) / 100.0
    window, flipped = (0, 0, LABEL_SIZE[1], LABEL_SIZE[0]), False
    if rng is not None:
        zoom = rng.uniform(1.0, 1.4)
        lh, lw = int(round(LABEL_SIZE[0] / zoom)), int(round(LABEL_SIZE[1] / zoom))
        y0, x0 = int(rng.integers(0, LABEL_SIZE[0] - lh + 1)), int(rng.integers(0, LABEL_SIZE[1] - lw + 1))
        window = (x0, y0, lw, lh)
        crop = (slice(y0, y0 + lh), slice(x0, x0 + lw))
        image = cv2.resize(
            image[y0 * STRIDE : (y0 + lh) * STRIDE, x0 * STRIDE : (x0 + lw) * STRIDE],
            INPUT_SIZE[::-1],
            interpolation=cv2.INTER_LINEAR,
        )
        rows = (np.arange(LABEL_SIZE[0]) * lh // LABEL_SIZE[0])[:, None]
        cols = (np.arange(LABEL_SIZE[1]) * lw // LABEL_SIZE[1])[None, :]
        surface, category, instance, depth = (a[crop][rows, cols] for a in (surface, category, instance, depth))
        flipped = bool(rng.random() < 0.5)
        if flipped:
            image, surface, category, instance, depth = (
                np.ascontiguousarray(a[:, ::-1]) for a in (image, surface, category, instance, depth)
            )
        image = augment_photo(image, rng)
    heat, offset, weight = centre_targets(instance)
    category = np.where((surface == OBJECT) & (category > 0), category - 1, IGNORE)
    return {
        "image": np.ascontiguousarray(image.transpose(2, 0, 1)),
        "surface": surface,
        "category": category,
        "center": heat[None],
        "offset": offset,
        "offset_weight": weight[None],
        "depth": depth[None],
        **box_targets(pack, index, instance * (surface == OBJECT), window, flipped),
    }


def box_targets(
    pack: Pack, index: int, instance: np.ndarray, window: tuple[int, int, int, int], flipped: bool
) -> dict[str, np.ndarray]:
    """The 3D heads' targets of sample ``index`` whose label maps were cut to ``window`` (x0, y0, width, height in
    label pixels), scaled back to the label size and mirrored when ``flipped``; ``instance`` is the instance map
    so transformed, 0 off objects. On the pixels of each instance with a box (``box_weight`` 1): box_depth,
    box_size, yaw_bin (IGNORE elsewhere), yaw_residual, amodal (:mod:`.box3d`); ``slot`` numbers the instances
    (-1: none), and ``slot_model`` and ``slot_row`` [MAX_SLOTS] give each one's model index and box row (-1:
    none)."""
    h, w = LABEL_SIZE
    x0, y0, lw, lh = window
    sx, sy = w / lw, h / lh
    targets: dict[str, np.ndarray] = {
        "box_depth": np.zeros((1, h, w), np.float32),
        "box_size": np.zeros((3, h, w), np.float32),
        "yaw_bin": np.full((h, w), IGNORE, np.int64),
        "yaw_residual": np.zeros((h, w), np.float32),
        "amodal": np.zeros((4, h, w), np.float32),
        "box_weight": np.zeros((1, h, w), np.float32),
        "slot": np.full((h, w), -1, np.int64),
        "slot_model": np.full(MAX_SLOTS, -1, np.int64),
        "slot_row": np.full(MAX_SLOTS, -1, np.int64),
    }
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32) + 0.5
    fy = float(pack.focal[index, 1]) * sy
    slot = 0
    for row in pack.boxes(index):
        mask = instance == pack.box_instance[row]
        if not mask.any() or slot == MAX_SLOTS:
            continue
        left, top, right, bottom = pack.box_amodal[row] / STRIDE
        left, right = (left - x0) * sx, (right - x0) * sx
        top, bottom = (top - y0) * sy, (bottom - y0) * sy
        alpha = float(pack.box_alpha[row])
        if flipped:
            left, right, alpha = w - right, w - left, -alpha
        yaw_bin, residual = yaw_targets(np.array(alpha))
        targets["box_depth"][0][mask] = np.log(pack.box_center[row, 2] * REFERENCE_FOCAL / fy)
        targets["box_size"][:, mask] = np.log(pack.box_size[row])[:, None]
        targets["yaw_bin"][mask] = yaw_bin
        targets["yaw_residual"][mask] = residual
        for k, reach in enumerate((xs - left, ys - top, right - xs, bottom - ys)):
            targets["amodal"][k][mask] = reach[mask] / AMODAL_UNIT
        targets["box_weight"][0][mask] = 1.0
        targets["slot"][mask] = slot
        targets["slot_model"][slot] = pack.box_model[row]
        targets["slot_row"][slot] = row
        slot += 1
    return targets
