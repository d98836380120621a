"""What a stage function gets besides its input artifacts: its settings, seed, photo and implementations."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar, overload

from tqdm import tqdm

from .errors import PsdrRoomError
from .stage_config import typed_settings

SettingsT = TypeVar("SettingsT")
ImplT = TypeVar("ImplT")


class Deferred:
    """An implementation the engine constructs only when the stage asks for it (:meth:`StageContext.impl`): a
    cached stage never constructs one that reads no files, so a cached run imports none of its libraries."""

    def __init__(self, construct: Callable[[], Any]) -> None:
        self.construct = construct


@dataclass
class StageContext:
    """What a stage function gets besides its input artifacts."""

    stage: str
    params: dict[str, Any]
    seed: int
    photo: Path
    implementations: dict[str, Any]
    timings: dict[str, float] = field(default_factory=dict)
    """Seconds the stage measured of its own work (say, per iteration): kept in the cache entry's manifest and
    ``metrics.json``, never in an artifact, so that no result's digest depends on the clock."""

    def settings(self, schema: type[SettingsT]) -> SettingsT:
        """:attr:`params` as an instance of ``schema``, the dataclass the stage registered them with (checked
        before the run: :mod:`.settings`): typed fields instead of dict lookups and casts."""
        return typed_settings(schema, self.params)

    @overload
    def impl(self, capability: str) -> Any: ...

    @overload
    def impl(self, capability: str, protocol: type[ImplT]) -> ImplT: ...

    def impl(self, capability: str, protocol: type[Any] | None = None) -> Any:
        """The selected implementation of ``capability`` (declared in the stage's ``uses``), typed as
        ``protocol`` (the capability's, which the engine checked when it constructed the implementation)."""
        try:
            implementation = self.implementations[capability]
        except KeyError:
            raise PsdrRoomError(f"stage '{self.stage}' uses capability '{capability}' without declaring it") from None
        if isinstance(implementation, Deferred):
            implementation = self.implementations[capability] = implementation.construct()
        if protocol is not None and not isinstance(implementation, protocol):
            raise PsdrRoomError(
                f"stage '{self.stage}' wants its {capability} to be a {protocol.__qualname__}; "
                f"{type(implementation).__name__} is not"
            )
        return implementation

    def progress(self, iterable: Iterable[Any], total: int | None = None, desc: str | None = None) -> Iterable[Any]:
        """Wrap a loop to show a progress bar (on a terminal)."""
        bar: Iterable[Any] = tqdm(
            iterable, total=total, desc=desc or self.stage, leave=False, disable=None, dynamic_ncols=True
        )
        return bar
