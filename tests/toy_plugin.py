"""A tiny plugin for engine tests, on the engine alone: its own artifact type (numbers), its own capability
(``scaler``) with two implementations, and three stages."""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar, Protocol, runtime_checkable

from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry

CALLS: Counter[str] = Counter()
VERSION = {"toy": "1"}


@dataclass
class Number:
    kind: ClassVar[str] = "test_number"
    marker: ClassVar[str] = "number.json"
    value: float

    def save(self, directory: Path) -> None:
        (directory / "number.json").write_text(json.dumps({"value": self.value}))

    @classmethod
    def load(cls, directory: Path) -> Number:
        return cls(json.loads((directory / "number.json").read_text())["value"])


@runtime_checkable
class Scaler(Protocol):
    """The ``scaler`` capability: what its implementations do."""

    def apply(self, value: float, photo: Path) -> float: ...


class Multiplier:
    """Multiplies by ``factor``."""

    def __init__(self, factor: float = 2.0) -> None:
        self.factor = factor

    def apply(self, value: float, photo: Path) -> float:
        return value * self.factor


class SidecarMultiplier:
    """Multiplies by the number in ``<photo>.factor``; unavailable without that file (for ``auto``)."""

    def external_files(self, photo: Path) -> list[Path]:
        return [photo.with_suffix(".factor")]

    def unavailable(self, photo: Path) -> str | None:
        return None if photo.with_suffix(".factor").is_file() else "no .factor file"

    def apply(self, value: float, photo: Path) -> float:
        return value * float(photo.with_suffix(".factor").read_text())


def source(ctx: StageContext) -> Number:
    """A number from the config (``start``), plus the photo's size in bytes when ``use_photo``."""
    CALLS[ctx.stage] += 1
    extra = ctx.photo.stat().st_size if ctx.params.get("use_photo") else 0
    return Number(float(ctx.params["start"]) + extra)


def scale(ctx: StageContext, x: Number) -> Number:
    CALLS[ctx.stage] += 1
    if ctx.params.get("fail"):
        raise RuntimeError("toy failure")
    return Number(ctx.impl("scaler", Scaler).apply(x.value, ctx.photo))


def add(ctx: StageContext, x: Number, y: Number) -> dict[str, Number]:
    CALLS[ctx.stage] += 1
    return {"total": Number(x.value + y.value)}


@hookimpl
def register_capabilities(registry: Registry) -> None:
    registry.add_capability("scaler", "multiplies a number", Scaler)


@hookimpl
def register_artifacts(registry: Registry) -> None:
    registry.add_artifact(Number)


@hookimpl
def register_implementations(registry: Registry) -> None:
    registry.add_implementation("scaler", "toy", Multiplier, version=VERSION["toy"])
    registry.add_implementation("scaler", "toy_sidecar", SidecarMultiplier)


@hookimpl
def register_stages(registry: Registry) -> None:
    registry.add_stage("toy_source", source, reads_photo=True)
    registry.add_stage("toy_scale", scale, uses=["scaler"])
    registry.add_stage("toy_add", add)
