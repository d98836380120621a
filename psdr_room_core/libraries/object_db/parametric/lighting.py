"""Table, floor and arc lamps."""

from __future__ import annotations

import math

import numpy as np

from psdr_room_core.method.artifacts import ObjectMesh

from ..primitives import MeshBuilder, box, cylinder, lathe, polyline_tube, sphere, tube
from .common import FABRICS, METALS, WOODS, colour

LAMP_SHADES = ("drum", "cone", "bell", "globe", "dome")


def lamp(
    kind: str = "table",
    shade: str = "drum",
    base: str = "disk",
    height: float | None = None,
    shade_size: float | None = None,
    shade_colour: str = "cream",
    body: str = "brass",
    base_colour: str | None = None,
) -> ObjectMesh:
    """A table or floor lamp (``kind="arc"`` is an arched floor lamp): groups ``shade``, ``stem`` and
    ``base``; ``base`` is disk/tripod/square/urn."""
    if (
        kind not in ("table", "floor", "arc")
        or shade not in LAMP_SHADES
        or base not in ("disk", "tripod", "square", "urn")
    ):
        raise ValueError(f"lamp: kind {kind!r} / shade {shade!r} / base {base!r}")
    b = MeshBuilder().group("shade", colour(shade_colour, FABRICS, METALS))
    b.group("stem", colour(body, METALS, WOODS)).group("base", colour(base_colour or body, METALS, WOODS, FABRICS))
    floor = kind != "table"
    height = height or (1.62 if floor else 0.55)
    size = shade_size or (0.42 if floor else 0.32)
    shade_h = size * (0.75 if shade in ("drum", "cone") else 0.6)
    if kind == "arc":
        b.add("base", box((0, 0.04, 0), (0.3, 0.08, 0.3)) if base == "square" else cylinder((0, 0, 0), 0.18, 0.07, 28))
        radius, rise = 0.6, (height or 1.9) - 0.6
        points = [(0.0, 0.07, 0.0)] + [
            (radius - radius * math.cos(a), rise + radius * math.sin(a), 0.0)
            for a in np.radians(np.linspace(0.0, 150.0, 9))
        ]
        b.add_all("stem", polyline_tube(points, 0.012, 10))
        end = points[-1]
        d = size
        b.add(
            "shade",
            lathe(
                [(d / 2, 0.0), (d * 0.45, d * 0.18), (d * 0.3, d * 0.3), (0.03, d * 0.36)],
                28,
                (end[0], end[1] - d * 0.36 - 0.02, 0.0),
            ),
        )
        return b.build()
    shade_bottom = height - shade_h
    stem_top = shade_bottom + shade_h * 0.4
    if base == "tripod":
        spread = 0.28 if floor else 0.12
        joint = height * (0.55 if floor else 0.3)
        for k in range(3):
            a = math.radians(90 + 120 * k)
            b.add("base", tube((spread * math.cos(a), 0.0, spread * math.sin(a)), (0, joint, 0), 0.012, 8))
        b.add("stem", cylinder((0, joint - 0.02, 0), 0.012, stem_top - joint + 0.02, 10))
    else:
        if base == "disk":
            b.add(
                "base",
                lathe(
                    [(0.14 if floor else 0.09, 0.0), (0.14 if floor else 0.09, 0.02), (0.05, 0.035), (0.0, 0.035)], 28
                ),
            )
            neck = 0.03
        elif base == "square":
            s = 0.26 if floor else 0.14
            b.add("base", box((0, 0.015, 0), (s, 0.03, s)))
            neck = 0.03
        else:  # urn: a vase-shaped body
            r = 0.09 if floor else 0.08
            tall = (0.5 if floor else 0.55) * shade_bottom
            b.add(
                "base",
                lathe(
                    [
                        (r * 0.55, 0.0),
                        (r * 0.8, tall * 0.15),
                        (r, tall * 0.45),
                        (r * 0.8, tall * 0.8),
                        (r * 0.3, tall),
                        (0.0, tall),
                    ],
                    28,
                ),
            )
            neck = tall
        b.add("stem", cylinder((0, neck, 0), 0.01 if floor else 0.009, stem_top - neck, 10))
    y = shade_bottom
    if shade == "drum":
        b.add("shade", lathe([(size / 2, 0.0), (size / 2, shade_h)], 32, (0, y, 0)))
    elif shade == "cone":
        b.add("shade", lathe([(size / 2, 0.0), (size * 0.3, shade_h)], 32, (0, y, 0)))
    elif shade == "bell":
        b.add(
            "shade",
            lathe(
                [(size / 2, 0.0), (size * 0.46, shade_h * 0.15), (size * 0.33, shade_h * 0.55), (size * 0.24, shade_h)],
                32,
                (0, y, 0),
            ),
        )
    elif shade == "dome":
        prof = [(size / 2 * math.cos(a), shade_h * math.sin(a)) for a in np.linspace(0, math.pi / 2, 8)]
        prof[-1] = (0.0, shade_h)
        b.add("shade", lathe(prof, 32, (0, y, 0)))
    else:  # globe
        b.add("shade", sphere((0, y + size / 2, 0), size / 2, 24))
    return b.build()
