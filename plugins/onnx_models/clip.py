"""``retrieval=clip_onnx``: object retrieval by CLIP image embeddings (§4.3, Fig. 4).

The object's crop and every database model's thumbnails are embedded by a CLIP image tower exported to ONNX
(input ``pixel_values`` [N,3,224,224], output ``image_embeds`` [N,D]); models are ranked by the best cosine
similarity over their views. Preprocessing is CLIP's: shorter side to 224 (bicubic), centre crop, CLIP
mean/std. Thumbnail embeddings are cached on disk per model file and thumbnail content.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from psdr_room_core.engine.cache import default_cache_dir
from psdr_room_core.method.artifacts import Camera, Candidate, ObjectMesh
from psdr_room_core.method.objects import ObjectQuery

from .network import InputSpec, ModelFile, OnnxNetwork, resolve_model, to_network, unusable_reason

FAMILIES = ("clip_vit_b32_image", "clip_vit_l14_image")
CLIP_SPEC = InputSpec(
    224, False, 1, (0.48145466, 0.4578275, 0.40821073), (0.26862954, 0.26130258, 0.27577711), cv2.INTER_CUBIC
)


def clip_input(rgb8: np.ndarray) -> np.ndarray:
    """The [1,3,224,224] CLIP input of a uint8 RGB image: shorter side 224, centre crop, normalised."""
    height, width = rgb8.shape[:2]
    scale = 224.0 / min(height, width)
    size = (max(224, round(width * scale)), max(224, round(height * scale)))
    resized = cv2.resize(rgb8, size, interpolation=cv2.INTER_CUBIC if scale > 1 else cv2.INTER_AREA)
    y0, x0 = (size[1] - 224) // 2, (size[0] - 224) // 2
    crop = resized[y0 : y0 + 224, x0 : x0 + 224].astype(np.float32) / 255.0
    return to_network(crop, CLIP_SPEC, (224, 224))


class ClipRetrieval:
    """Rank models by cosine similarity of CLIP embeddings of the object crop and the model thumbnails."""

    def __init__(
        self,
        model: str | None = "clip_vit_b32_image",
        path: str | None = None,
        family: str | None = None,
        models_dir: str | None = None,
        database: str = "builtin",
        fraction: float = 1.0,
        seed: int = 0,
        category_filter: bool = True,
        batch: int = 16,
        intra_op_threads: int = 0,
        providers: Sequence[str] = ("CPUExecutionProvider",),
        cache_dir: str | None = None,
    ) -> None:
        self._params = dict(model=model, path=path, family=family, models_dir=models_dir)
        self.spec = (str(database), float(fraction), int(seed))
        self.category_filter = bool(category_filter)
        self.batch = max(1, int(batch))
        self.threads = int(intra_op_threads)
        self.providers = tuple(providers or ())
        self.cache_dir = Path(cache_dir) if cache_dir else default_cache_dir()
        self._network: OnnxNetwork | None = None
        self._db: Any = None

    @property
    def model_file(self) -> ModelFile:
        return resolve_model("retrieval", FAMILIES, **self._params)

    @property
    def network(self) -> OnnxNetwork:
        if self._network is None:
            self._network = OnnxNetwork(self.model_file, self.threads, self.providers)
        return self._network

    @property
    def database(self) -> Any:
        if self._db is None:
            from psdr_room_core.libraries.object_db.opening import open_database

            self._db = open_database(*self.spec)
        return self._db

    def external_files(self, photo: Path) -> list[Path]:
        return [self.model_file.path]

    def unavailable(self, photo: Path) -> str | None:
        return unusable_reason(self.model_file)

    def describe(self) -> str:
        return f"clip_onnx ({self.model_file.name}) over {self.spec[0]} database"

    def thumbnail(self, model_id: str) -> np.ndarray:
        return self.database.thumbnails(model_id, views=[0])[0]

    def mesh(self, model_id: str) -> ObjectMesh:
        from psdr_room_core.libraries.object_db.opening import object_mesh

        return object_mesh(self.database, model_id)

    def category(self, model_id: str) -> str:
        return self.database.record(model_id).category

    def embed(self, images: Sequence[np.ndarray]) -> np.ndarray:
        """Unit-norm embeddings [N,D] of uint8 RGB images."""
        net = self.network
        net.image_input()
        out = []
        for start in range(0, len(images), self.batch):
            pixels = np.concatenate([clip_input(im) for im in images[start : start + self.batch]])
            values = net.run(pixels)
            if "image_embeds" not in values or values["image_embeds"].ndim != 2:
                raise net.signature_error("expected an output image_embeds [N,D]")
            out.append(values["image_embeds"].astype(np.float32))
        embeds = np.concatenate(out)
        return embeds / np.maximum(np.linalg.norm(embeds, axis=1, keepdims=True), 1e-12)

    def _thumbnail_embeddings(self, model_ids: Sequence[str]) -> dict[str, np.ndarray]:
        """Model id → [V,D] embeddings of its thumbnails, cached in ``<cache>/clip/<model file>.npz``."""
        stat = self.model_file.path.stat()
        identity = hashlib.sha256(
            f"{self.model_file.path.name}:{stat.st_size}:{stat.st_mtime_ns}".encode()
        ).hexdigest()[:16]
        store = self.cache_dir / "clip" / f"{identity}.npz"
        cached = dict(np.load(store)) if store.is_file() else {}
        found, todo = {}, {}
        for model_id in model_ids:
            views = self.database.thumbnails(model_id)
            key = hashlib.sha256(b"".join(v.tobytes() for v in views)).hexdigest()[:24]
            if key in cached:
                found[model_id] = cached[key]
            else:
                todo[model_id] = (key, views)
        if todo:
            flat = [v for _, views in todo.values() for v in views]
            embeds = self.embed(flat)
            start = 0
            for model_id, (key, views) in todo.items():
                found[model_id] = cached[key] = embeds[start : start + len(views)]
                start += len(views)
            store.parent.mkdir(parents=True, exist_ok=True)
            partial = store.with_name(f".{store.name}.{os.getpid()}.tmp.npz")
            np.savez(partial, **cached)
            os.replace(partial, store)
        return found

    def rank(self, query: ObjectQuery, camera: Camera, camera_to_world: np.ndarray, k: int) -> list[Candidate]:
        models = [r for name in query.categories for r in self.database.category(name)] if self.category_filter else []
        models = models or list(self.database.records)
        thumbs = self._thumbnail_embeddings([r.id for r in models])
        crop = self.embed([query.crop])[0]
        scored = [Candidate(r.id, float(np.max(thumbs[r.id] @ crop)), r.category) for r in models]
        scored.sort(key=lambda c: (-c.score, c.model_id))
        return scored[:k]


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import ObjectRetriever

    _ClipRetrieval_is_a_retrieval: type[ObjectRetriever] = ClipRetrieval
