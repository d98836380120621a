"""What a run leaves: a record per stage (its cache key, outputs' digests, time and memory) and the run's
record (artifacts in memory, where each was saved), the objects the run-event hooks (:mod:`.hookspecs`) receive."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from .artifacts import Artifact

ArtifactT = TypeVar("ArtifactT")


@dataclass
class StageRecord:
    """What happened to one stage in a run."""

    name: str
    function: str
    key: str
    cached: bool
    seconds: float
    """Wall time of this run's work for the stage (loading from the cache, or computing)."""
    compute_seconds: float
    """Wall time the computation took when the entry was made."""
    outputs: dict[str, str]
    """Artifact name → content digest."""
    implementations: dict[str, str]
    """Capability → implementation name."""
    peak_rss_mb: float = 0.0
    """Highest resident memory of the process while this run did the stage's work (MiB; :mod:`.memory`)."""
    timings: dict[str, float] = field(default_factory=dict)
    """What the stage measured of its own work when the entry was made (:attr:`StageContext.timings`)."""


@dataclass
class RunRecord:
    """A run: its stage records and artifacts in memory, for reports and publishing."""

    photo: Path
    config: dict[str, Any] = field(default_factory=dict)
    """The resolved config the run was composed from."""
    stages: list[StageRecord] = field(default_factory=list)
    artifacts: dict[str, Artifact] = field(default_factory=dict)
    digests: dict[str, str] = field(default_factory=dict)
    implementations: dict[str, dict[str, str]] = field(default_factory=dict)
    """Capability → {name, version, origin} for every capability a stage of this run used."""
    saved: dict[str, Path] = field(default_factory=dict)
    """Artifact → the cache entry folder it was read from (its files exactly as its type saves them)."""

    def artifact(self, names: str | Iterable[str], kind: type[ArtifactT]) -> ArtifactT | None:
        """The first of the artifacts ``names`` the run has, when it is a ``kind`` (None otherwise): what a
        run-event hook reads, typed (``run.artifact(("room_box_fit", "room_box"), RoomBox)``)."""
        return first_artifact(self.artifacts, names, kind)


def first_artifact(
    artifacts: Mapping[str, Artifact], names: str | Iterable[str], kind: type[ArtifactT]
) -> ArtifactT | None:
    """The first of ``names`` in ``artifacts`` (the fitted artifact before its initial estimate), when it is a
    ``kind`` (None otherwise)."""
    for name in [names] if isinstance(names, str) else names:
        if name in artifacts:
            found = artifacts[name]
            return found if isinstance(found, kind) else None
    return None
