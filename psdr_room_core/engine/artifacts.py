"""What the engine knows of artifacts: the protocol every artifact type satisfies, and how a saved one is
recognised. Which types exist is the plugins' business (the ``register_artifacts`` hook fills
:attr:`~psdr_room_core.engine.registry.Registry.artifacts`)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import ClassVar, Protocol, runtime_checkable

from .errors import PsdrRoomError


@runtime_checkable
class Artifact(Protocol):
    """What every artifact type provides. Optional: a ``published_as`` class attribute naming a folder at the top
    of the run directory where it is also published (besides ``artifacts/<name>/``)."""

    kind: ClassVar[str]
    """Its name in cache manifests (unique among the registered types)."""
    marker: ClassVar[str]
    """A file every saved artifact of this kind has: how a directory's kind is recognised."""

    def save(self, directory: Path) -> None:
        """Write the artifact's files into ``directory`` (which exists and is empty)."""

    @classmethod
    def load(cls, directory: Path) -> Artifact:
        """Read an artifact written by :meth:`save` (possibly edited by a user)."""


def artifact_kind_of(directory: Path, types: Mapping[str, type[Artifact]]) -> str:
    """Recognise a saved artifact directory (as published under a run's ``artifacts/``) by its marker file."""
    if not directory.is_dir():
        raise PsdrRoomError(
            f"{directory}: not a directory; +inject.NAME= takes an artifact directory from a run's artifacts/"
        )
    for kind, cls in types.items():
        if (directory / cls.marker).is_file():
            return kind
    raise PsdrRoomError(
        f"{directory}: not a saved artifact (none of {', '.join(sorted(c.marker for c in types.values()))}); "
        "use a directory from a run's artifacts/"
    )
