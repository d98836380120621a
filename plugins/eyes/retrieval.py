"""``retrieval=eyes``: the catalogue ranked by what the eyes network sees of the object, silhouettes breaking ties.

The network reads the object's segment in the whole photo (:attr:`~psdr_room_core.method.objects.ObjectQuery.photo`):
its embedding, averaged over the segment's pixels, against each catalogue model's (``eyes_models.npz`` beside the
network, learnt from renders of that model under many views, materials and occlusions), and its category vote
(the category probabilities averaged there). The models searched are those of the segment's label and alternates
and of the network's own vote, so a label the network disagrees with does not lock the object into the wrong
kind. Each model's appearance score is ``cosine + category_weight × p(its category)``; the ``shortlist`` best are
posed by ``retrieval=silhouette``'s view search, and ranked by ``appearance + silhouette_weight × silhouette
score``. A model the catalogue file does not hold (another database) has cosine 0.
"""

from __future__ import annotations

from dataclasses import asdict
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.artifacts import Camera, Candidate, Image, ObjectMesh
from psdr_room_core.method.objects import ObjectQuery
from psdr_room_plugins.retrieval_silhouette import SilhouetteRetrieval, SilhouetteSettings

from .box3d import CATALOGUE, EMBEDDING
from .decode import softmax
from .labels import CATEGORIES
from .perception import Eyes
from .plugin import EyesSettings


class EyesRetrieval:
    """Rank models by the eyes network's embedding and category vote, then by their posed silhouettes. Set the
    silhouette search's settings on ``retrieval.silhouette``."""

    def __init__(
        self,
        *,
        network: EyesSettings,
        silhouette: SilhouetteSettings,
        shortlist: int,
        category_weight: float,
        silhouette_weight: float,
    ) -> None:
        self.eyes = Eyes(**asdict(network))
        self.silhouette = SilhouetteRetrieval(**vars(silhouette))
        self.shortlist, self.category_weight, self.silhouette_weight = shortlist, category_weight, silhouette_weight

    # -- availability --------------------------------------------------------------------------------------
    @property
    def catalogue_path(self) -> Path:
        return self.eyes.path.with_name(CATALOGUE)

    def external_files(self, photo: Path) -> list[Path]:
        return [*self.eyes.external_files(photo), self.catalogue_path]

    def unavailable(self, photo: Path) -> str | None:
        reason = self.eyes.unavailable(photo)
        if reason:
            return reason
        if not self.catalogue_path.is_file():
            return f"no {CATALOGUE} beside {self.eyes.path} (psdr-room-train writes it with the network)"
        return None

    @cached_property
    def catalogue(self) -> dict[str, np.ndarray]:
        """Model id → unit embedding."""
        try:
            with np.load(self.catalogue_path) as data:
                ids, embeddings = data["model_ids"].astype(str), data["embeddings"].astype(np.float32)
        except (OSError, KeyError, ValueError):
            raise PsdrRoomError(
                f"{self.catalogue_path}: not a catalogue psdr-room-train wrote; copy it again with its network"
            ) from None
        if embeddings.shape != (len(ids), EMBEDDING):
            raise PsdrRoomError(
                f"{self.catalogue_path}: embeddings of shape {embeddings.shape}, not ({len(ids)}, {EMBEDDING}); "
                "copy it again with its network"
            )
        return dict(zip(ids, embeddings))

    # -- the retriever's data side: the silhouette retrieval's database ----------------------------------
    def mesh(self, model_id: str) -> ObjectMesh:
        return self.silhouette.mesh(model_id)

    def category(self, model_id: str) -> str:
        return self.silhouette.category(model_id)

    def thumbnail(self, model_id: str) -> np.ndarray:
        return self.silhouette.thumbnail(model_id)

    def describe(self) -> str:
        return f"{self.eyes.describe()} embedding and category vote, then {self.silhouette.describe()}"

    # -- ranking -------------------------------------------------------------------------------------------
    def seen(self, query: ObjectQuery) -> tuple[np.ndarray, np.ndarray]:
        """(unit embedding, category probabilities over :data:`.labels.CATEGORIES`) of the network's outputs
        averaged over the query's mask."""
        if query.photo is None:
            raise PsdrRoomError("retrieval=eyes needs the photo with each object query (ObjectQuery.photo)")
        out = self.eyes.outputs(Image(rgb=query.photo))
        if "embedding" not in out:
            raise PsdrRoomError(f"{self.eyes.path}: a network without the embedding head; train one with it")
        height, width = out["embedding"].shape[1:]
        share = cv2.resize(query.mask.astype(np.float32), (width, height), interpolation=cv2.INTER_AREA)
        cells = share >= 0.5 if (share >= 0.5).any() else share >= share.max()
        embedding = out["embedding"][:, cells].mean(axis=1)
        votes = softmax(out["category"][:, cells]).mean(axis=1)
        return embedding / max(float(np.linalg.norm(embedding)), 1e-9), votes

    def appearance(self, query: ObjectQuery) -> dict[str, tuple[float, float]]:
        """Model id → (cosine, category probability) of each model searched for ``query``."""
        embedding, votes = self.seen(query)
        database = self.silhouette.database
        vote = CATEGORIES[int(votes.argmax())]
        names = dict.fromkeys([*query.categories, *query.alternates, vote])
        models = [r for name in names if name in database.categories() for r in database.category(name)]
        probability = {name: float(p) for name, p in zip(CATEGORIES, votes)}
        zero = np.zeros(EMBEDDING, np.float32)
        return {
            r.id: (float(self.catalogue.get(r.id, zero) @ embedding), probability.get(r.category, 0.0))
            for r in models or database.records
        }

    def rank(self, query: ObjectQuery, camera: Camera, camera_to_world: np.ndarray, k: int) -> list[Candidate]:
        seen = self.appearance(query)
        score = {m: cosine + self.category_weight * p for m, (cosine, p) in seen.items()}
        shortlist = sorted(score, key=lambda m: (-score[m], m))[: max(self.shortlist, k)]
        posed = self.silhouette.rank_models(query, camera, camera_to_world, shortlist, len(shortlist))
        ranked = [
            Candidate(
                c.model_id,
                score[c.model_id] + self.silhouette_weight * c.score,
                c.category,
                {**c.terms, "cosine": seen[c.model_id][0], "category_p": seen[c.model_id][1], "silhouette": c.score},
            )
            for c in posed
        ]
        ranked.sort(key=lambda c: (-c.score, c.model_id))
        return ranked[:k]


if TYPE_CHECKING:  # mypy checks each implementation against its capability's protocol
    from psdr_room_core.method.capabilities import ObjectRetriever

    _EyesRetrieval_is_a_retrieval: type[ObjectRetriever] = EyesRetrieval
