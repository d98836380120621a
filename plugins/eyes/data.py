"""Training data of the eyes network: a data set folder of ``psdr-room-synth-data`` packed into one file, the
per-batch augmentation that makes a render look like any photo, and the targets of each head.

A pack (:func:`build_pack`) holds each sample's photo as JPEG bytes at the network's input size and its labels
at the heads' quarter resolution (surface, category, instance, depth in whole centimetres): small enough to copy
to another machine (about 11 KB a sample: 3,600 samples in 41 MB), fast enough to read every epoch.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.visualize import to_uint8

from .labels import OBJECT
from .network import INPUT_SIZE

STRIDE = 4
LABEL_SIZE = (INPUT_SIZE[0] // STRIDE, INPUT_SIZE[1] // STRIDE)
IGNORE = -100


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
    for seed in seeds:
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
    pack = Pack(
        np.array(seeds, np.int64),
        np.concatenate(chunks) if chunks else np.zeros(0, np.uint8),
        np.array(offsets, np.int64),
        surface=np.stack(labels["surface"]),
        category=np.stack(labels["category"]),
        instance=np.stack(labels["instance"]),
        depth_cm=np.round(np.stack(labels["depth"]).astype(np.float32) * 100.0).astype(np.uint16),
    )
    pack.save(path)
    return pack


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
    """One training example (augmented when ``rng`` is given): image uint8 [3, 240, 320] (sRGB), and the
    targets surface, category (IGNORE off objects), center, offset, offset_weight, depth (0: none)."""
    image = pack.photo(index)
    surface, category = pack.surface[index].astype(np.int64), pack.category[index].astype(np.int64)
    instance, depth = pack.instance[index], pack.depth_cm[index].astype(np.float32) / 100.0
    if rng is not None:
        zoom = rng.uniform(1.0, 1.4)
        lh, lw = int(round(LABEL_SIZE[0] / zoom)), int(round(LABEL_SIZE[1] / zoom))
        y0, x0 = int(rng.integers(0, LABEL_SIZE[0] - lh + 1)), int(rng.integers(0, LABEL_SIZE[1] - lw + 1))
        crop = (slice(y0, y0 + lh), slice(x0, x0 + lw))
        image = cv2.resize(
            image[y0 * STRIDE : (y0 + lh) * STRIDE, x0 * STRIDE : (x0 + lw) * STRIDE],
            INPUT_SIZE[::-1],
            interpolation=cv2.INTER_LINEAR,
        )
        rows = (np.arange(LABEL_SIZE[0]) * lh // LABEL_SIZE[0])[:, None]
        cols = (np.arange(LABEL_SIZE[1]) * lw // LABEL_SIZE[1])[None, :]
        surface, category, instance, depth = (a[crop][rows, cols] for a in (surface, category, instance, depth))
        if rng.random() < 0.5:
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
    }
