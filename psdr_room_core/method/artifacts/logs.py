"""Optimisation logs: loss histories, summaries and the pictures a fit leaves for the report."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .io import read_json, read_png, write_json, write_png


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
        write_json(
            directory / "log.json", {"history": self.history, "summary": self.summary, "images": sorted(self.images)}
        )
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)

    @classmethod
    def load(cls, directory: Path) -> OptimizationLog:
        data = read_json(directory / "log.json")
        images = {name: read_png(directory / f"{name}.png") for name in data["images"]}
        return cls(history=data["history"], images=images, summary=data["summary"])
