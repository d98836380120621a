"""Electronics: televisions and computer monitors."""

from __future__ import annotations

import math

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, cylinder, tube
from .common import METALS, WOODS, colour


def tv(diagonal_inches: float = 55.0, stand: str = "feet", frame: str = "black metal") -> ObjectMesh:
    """A flat television, screen facing +Z: groups ``screen``, ``frame`` (bezel and back) and ``stand``
    (``feet``, ``pedestal`` or ``none`` for a wall-mounted set)."""
    b = MeshBuilder().group("screen", (0.04, 0.045, 0.05)).group("frame", colour(frame, METALS, WOODS))
    b.group("stand", colour(frame, METALS, WOODS))
    diag = diagonal_inches * 0.0254
    w, h = diag * 16 / math.hypot(16, 9), diag * 9 / math.hypot(16, 9)
    bottom = {"feet": 0.07, "pedestal": 0.09, "none": 0.0}[stand]
    b.add("frame", box((0, bottom + h / 2, 0), (w + 0.02, h + 0.02, 0.03)))
    b.add("frame", box((0, bottom + h / 2, -0.035), (w * 0.6, h * 0.6, 0.05)))
    b.add("screen", box((0, bottom + h / 2 + 0.002, 0.016), (w, h - 0.004, 0.004)))
    if stand == "feet":
        for sx in (-1, 1):
            x = sx * w * 0.38
            b.add("stand", tube((x, 0.0, 0.12), (x, bottom + 0.05, 0.0), 0.01, 8))
            b.add("stand", tube((x, 0.0, -0.1), (x, bottom + 0.05, 0.0), 0.01, 8))
    elif stand == "pedestal":
        b.add("stand", box((0, 0.01, 0), (w * 0.3, 0.02, 0.22)))
        b.add("stand", box((0, bottom / 2 + 0.02, -0.03), (0.06, bottom + 0.06, 0.03)))
    return b.build()


def monitor(diagonal_inches: float = 24.0, stand: str = "arm", frame: str = "black metal") -> ObjectMesh:
    """A computer monitor standing on a desk, screen facing +Z: groups ``screen``, ``frame`` (bezel and back)
    and ``stand`` (``arm``: a post on a foot plate; ``disc``: a round foot)."""
    if stand not in ("arm", "disc"):
        raise ValueError(f"monitor: stand {stand!r}")
    b = MeshBuilder().group("screen", (0.04, 0.045, 0.05)).group("frame", colour(frame, METALS, WOODS))
    b.group("stand", colour(frame, METALS, WOODS))
    diag = diagonal_inches * 0.0254
    w, h = diag * 16 / math.hypot(16, 9), diag * 9 / math.hypot(16, 9)
    bottom = 0.1
    b.add("frame", box((0, bottom + h / 2, 0), (w + 0.015, h + 0.015, 0.02)))
    b.add("frame", box((0, bottom + h / 2, -0.025), (w * 0.4, h * 0.4, 0.03)))
    b.add("screen", box((0, bottom + h / 2 + 0.002, 0.011), (w, h - 0.004, 0.003)))
    b.add("stand", box((0, (bottom + h / 2) / 2, -0.05), (0.05, bottom + h / 2, 0.02)))
    if stand == "arm":
        b.add("stand", box((0, 0.006, -0.02), (0.22, 0.012, 0.18)))
    else:
        b.add("stand", cylinder((0, 0.0, -0.03), 0.11, 0.012, 28))
    return b.build()
