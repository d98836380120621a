"""Furniture arrangements that real rooms have, from the object database: a bed with nightstands, a sofa with a
coffee table, a dining set, rows of desks, a kitchen run, shelves with things on them, frames on the walls.

Everything is laid out in the room box's own frame (x across, z away from the camera's wall, floor y = 0) on
footprint rectangles that may not overlap, then turned into world :class:`Placement` s. A model stands with its
front (+Z in its canonical frame) facing into the room; things on top of others rest on their top.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from psdr_room_core.method.artifacts import Placement, rotation_y

SCALE_JITTER = 0.08
"""Relative random size change of a model (real sizes stay plausible)."""
CLEARANCE = 0.03
"""Gap (m) kept between footprints and from the walls."""
THEMES = ("bedroom", "living", "dining", "office", "kitchen", "storage", "mixed")


@dataclass(frozen=True)
class Footprint:
    """A placed model's rectangle on the floor, room frame: centre, half sizes along x and z."""

    x: float
    z: float
    hx: float
    hz: float

    def overlaps(self, other: Footprint, gap: float = CLEARANCE) -> bool:
        return abs(self.x - other.x) < self.hx + other.hx + gap and abs(self.z - other.z) < self.hz + other.hz + gap


class Furnisher:
    """Places database models in a room box (half sizes ``half``; the camera at room-frame ``camera``)."""

    def __init__(self, database: object, half: np.ndarray, camera: np.ndarray, rng: np.random.Generator) -> None:
        self.database = database
        self.half = np.asarray(half, dtype=float)
        self.rng = rng
        self.taken: list[Footprint] = [Footprint(float(camera[0]), float(camera[2]), 0.45, 0.45)]
        self.placed: list[tuple[Placement, float]] = []  # (room-frame placement, top height)

    # -- models -------------------------------------------------------------------------------------------
    def model(self, category: str, fits: Callable[[np.ndarray], bool] | None = None) -> tuple[str, np.ndarray] | None:
        """A random model of ``category`` (its id and jittered size x, y, z) whose size ``fits`` (if given)."""
        records = list(self.database.category(category))  # type: ignore[attr-defined]
        self.rng.shuffle(records)
        for record in records:
            size = np.asarray(record.extent) * (1.0 + self.rng.uniform(-SCALE_JITTER, SCALE_JITTER))
            if fits is None or fits(size):
                return record.id, size
        return None

    def _add(
        self, model_id: str, size: np.ndarray, x: float, z: float, yaw: float, y: float = 0.0, floor: bool = True
    ) -> Placement | None:
        """Put the model (room-frame yaw, a multiple of 90° plus noise) at (x, y, z) if its footprint is free
        and inside the room (``floor``: it takes floor space; a rug never does); its room-frame placement, or
        None."""
        record = self.database.record(model_id)  # type: ignore[attr-defined]
        floor = floor and record.category != "rug"  # things stand on rugs
        quarter = int(round(yaw / (math.pi / 2))) % 2
        hx, hz = (size[2] / 2, size[0] / 2) if quarter else (size[0] / 2, size[2] / 2)
        box = Footprint(x, z, hx, hz)
        if abs(x) + hx > self.half[0] - 0.005 or abs(z) + hz > self.half[2] - 0.005 or y + size[1] > 2 * self.half[1]:
            return None
        if floor and any(box.overlaps(other) for other in self.taken):
            return None
        mesh = self.database.mesh(model_id)  # type: ignore[attr-defined]
        scale = float(size[1] / max(mesh.extent[1], 1e-6))
        placement = Placement(
            segment_id=len(self.placed) + 1,
            label=record.category,
            model_id=model_id,
            mesh=mesh,
            position=(x, y, z),
            yaw=yaw,
            scale=scale,
            category=record.category,
        )
        if floor:
            self.taken.append(box)
        self.placed.append((placement, y + size[1]))
        return placement

    # -- positions ----------------------------------------------------------------------------------------
    def wall_spot(
        self, size: np.ndarray, wall: int | None = None, along: float | None = None
    ) -> tuple[float, float, float]:
        """(x, z, yaw) of a model with its back against wall ``wall`` (0 = +z, the far wall; 1 = -x; 2 = +x;
        3 = -z, behind the camera) at ``along`` (room-frame coordinate along the wall; random when None)."""
        wall = int(self.rng.choice([0, 0, 1, 2])) if wall is None else wall
        depth = size[2] / 2 + CLEARANCE
        if wall in (0, 3):
            span = max(self.half[0] - size[0] / 2 - CLEARANCE, 0.0)
            x = float(self.rng.uniform(-span, span)) if along is None else along
            z = (self.half[2] - depth) * (1 if wall == 0 else -1)
            return x, z, math.pi if wall == 0 else 0.0
        span = max(self.half[2] - size[0] / 2 - CLEARANCE, 0.0)
        z = float(self.rng.uniform(-span * 0.3, span)) if along is None else along
        x = (self.half[0] - depth) * (-1 if wall == 1 else 1)
        return x, z, math.pi / 2 if wall == 1 else -math.pi / 2

    def free_spot(self, size: np.ndarray) -> tuple[float, float, float]:
        """A random (x, z, yaw) in the room's open floor, facing the camera's side or sideways."""
        span = np.maximum(self.half - max(size[0], size[2]) / 2 - CLEARANCE, 0.0)
        x, z = self.rng.uniform(-span[0], span[0]), self.rng.uniform(-span[2] * 0.3, span[2])
        return float(x), float(z), float(self.rng.choice([0.0, math.pi / 2, -math.pi / 2, math.pi]))

    @staticmethod
    def _ahead(x: float, z: float, yaw: float, distance: float, side: float = 0.0) -> tuple[float, float]:
        """The point ``distance`` in front of (and ``side`` to the left of) a model at (x, z) turned by ``yaw``."""
        forward, left = rotation_y(yaw) @ np.array([0.0, 0.0, 1.0]), rotation_y(yaw) @ np.array([1.0, 0.0, 0.0])
        return float(x + forward[0] * distance + left[0] * side), float(z + forward[2] * distance + left[2] * side)

    def on_top(self, parent: Placement, top: float, category: str, parent_size: np.ndarray) -> Placement | None:
        """A model of ``category`` resting on ``parent``'s top (``top`` m high), inside its footprint."""
        chosen = self.model(category, lambda s: s[0] < parent_size[0] * 0.9 and s[2] < parent_size[2] * 0.9)
        if chosen is None:
            return None
        model_id, size = chosen
        x, z = self._ahead(
            parent.position[0],
            parent.position[2],
            parent.yaw,
            0.0,
            float(self.rng.uniform(-0.3, 0.3) * (parent_size[0] - size[0])),
        )
        return self._add(model_id, size, x, z, parent.yaw + float(self.rng.normal(0, 0.15)), y=top, floor=False)

    # -- arrangements -------------------------------------------------------------------------------------
    def piece(
        self,
        category: str,
        wall: int | None = None,
        along: float | None = None,
        free: bool = False,
        fits: Callable[[np.ndarray], bool] | None = None,
        tries: int = 8,
    ) -> tuple[Placement, np.ndarray] | None:
        """One model of ``category`` against a wall (or on the open floor when ``free``); it and its size."""
        for _ in range(tries):
            chosen = self.model(category, fits)
            if chosen is None:
                return None
            model_id, size = chosen
            x, z, yaw = self.free_spot(size) if free else self.wall_spot(size, wall, along)
            placed = self._add(model_id, size, x, z, yaw + float(self.rng.normal(0, 0.02)))
            if placed is not None:
                return placed, size
            along = None
        return None

    def beside(
        self,
        anchor: tuple[Placement, np.ndarray],
        category: str,
        side: int,
        fits: Callable[[np.ndarray], bool] | None = None,
    ) -> tuple[Placement, np.ndarray] | None:
        """A model of ``category`` against the same wall as ``anchor``, next to it on ``side`` (±1)."""
        chosen = self.model(category, fits)
        if chosen is None:
            return None
        model_id, size = chosen
        placement, anchor_size = anchor
        offset = side * (anchor_size[0] / 2 + size[0] / 2 + 0.05)
        back = anchor_size[2] / 2 - size[2] / 2  # same wall: align the backs
        x, z = self._ahead(placement.position[0], placement.position[2], placement.yaw, -back, offset)
        placed = self._add(model_id, size, x, z, placement.yaw)
        return None if placed is None else (placed, size)

    def facing(
        self,
        anchor: tuple[Placement, np.ndarray],
        category: str,
        distance: float,
        side: float = 0.0,
        turn: float = 0.0,
        fits: Callable[[np.ndarray], bool] | None = None,
        back: bool = False,
    ) -> Placement | None:
        """A model of ``category`` ``distance`` m in front of ``anchor``'s front (its back when ``back``),
        ``side`` m to the left, turned ``turn`` from that direction (π: facing the anchor)."""
        chosen = self.model(category, fits)
        if chosen is None:
            return None
        model_id, size = chosen
        placement, anchor_size = anchor
        direction = placement.yaw + (math.pi if back else 0.0)
        x, z = self._ahead(
            placement.position[0], placement.position[2], direction, anchor_size[2] / 2 + distance + size[2] / 2, side
        )
        return self._add(model_id, size, x, z, direction + turn + float(self.rng.normal(0, 0.04)))

    def bedroom(self) -> None:
        bed = self.piece("bed", wall=int(self.rng.choice([0, 1, 2])))
        if bed is None:
            return
        for side in (-1, 1):
            if self.rng.random() < 0.8:
                stand = self.beside(bed, "cabinet", side, lambda s: s[1] < 0.8 and s[0] < 0.7)
                if stand is not None and self.rng.random() < 0.7:
                    self.on_top(stand[0], stand[1][1], "lamp", stand[1])
        if self.rng.random() < 0.6:
            self.facing(bed, "rug", -bed[1][2] * 0.6, turn=0.0)
        self.piece("cabinet", fits=lambda s: s[1] > 0.7)
        if self.rng.random() < 0.5:
            self.piece("desk")

    def living(self) -> None:
        sofa = self.piece("sofa", wall=int(self.rng.choice([0, 1, 2])))
        if sofa is None:
            return
        if self.rng.random() < 0.7:
            self.facing(sofa, "rug", 0.1, fits=lambda s: s[1] < 0.05)
        self.facing(sofa, "table", float(self.rng.uniform(0.3, 0.6)), fits=lambda s: s[1] < 0.6)
        for side in (-1, 1):
            if self.rng.random() < 0.5:
                self.beside(sofa, "table", side, lambda s: s[1] < 0.75 and s[0] < 0.7)
        if self.rng.random() < 0.5:
            self.facing(
                sofa,
                str(self.rng.choice(["sofa", "chair", "ottoman"])),
                float(self.rng.uniform(1.2, 2.0)),
                turn=math.pi,
            )
        stand = self.piece("cabinet", fits=lambda s: s[1] < 1.0)
        if stand is not None and self.rng.random() < 0.7:
            self.on_top(stand[0], stand[1][1], "tv", stand[1])
        for category in ("plant", "lamp", "shelf"):
            if self.rng.random() < 0.5:
                self.piece(category)

    def dining(self) -> None:
        table = self.piece("table", free=True, fits=lambda s: s[1] > 0.65)
        if table is None:
            return
        per_side = max(1, int(table[1][0] // 0.55))
        for back in (False, True):
            for k in range(per_side):
                if self.rng.random() < 0.85:  # chairs at the table's edges, facing it
                    self.facing(table, "chair", 0.05, side=(k - (per_side - 1) / 2) * 0.55, turn=math.pi, back=back)
        if self.rng.random() < 0.5:
            self.piece("cabinet")

    def office(self) -> None:
        rows, columns = int(self.rng.integers(1, 4)), int(self.rng.integers(1, 4))
        facing_camera = self.rng.random() < 0.5
        yaw = 0.0 if facing_camera else math.pi
        chosen = self.model(str(self.rng.choice(["desk", "table"])), lambda s: 0.6 < s[1] < 0.85 and s[0] < 1.8)
        if chosen is None:
            return
        model_id, size = chosen
        pitch_x, pitch_z = size[0] + float(self.rng.uniform(0.2, 0.6)), size[2] + float(self.rng.uniform(0.7, 1.1))
        x0, z0 = float(self.rng.uniform(-0.5, 0.5)), float(self.rng.uniform(-0.2, 0.6)) * self.half[2]
        for r in range(rows):
            for c in range(columns):
                x, z = x0 + (c - (columns - 1) / 2) * pitch_x, z0 + r * pitch_z
                desk = self._add(model_id, size, x, z, yaw + float(self.rng.normal(0, 0.03)))
                if desk is not None and self.rng.random() < 0.9:
                    self.facing((desk, size), "chair", 0.05, turn=math.pi)

    def kitchen(self) -> None:
        wall = int(self.rng.choice([0, 1, 2]))
        run = self.piece("cabinet", wall=wall, fits=lambda s: 0.7 < s[1] < 1.0)
        if run is None:
            return
        for side in (-1, 1):
            anchor = run
            for _ in range(int(self.rng.integers(0, 4))):
                nxt = self.beside(anchor, "cabinet", side, lambda s: 0.7 < s[1] < 1.0)
                if nxt is None:
                    break
                anchor = nxt
                if self.rng.random() < 0.3:
                    self.on_top(nxt[0], nxt[1][1], "appliance", nxt[1])
            if self.rng.random() < 0.5:
                self.beside(anchor, "refrigerator", side)
        if self.rng.random() < 0.5:
            self.dining()

    def storage(self) -> None:
        for _ in range(int(self.rng.integers(1, 4))):
            shelf = self.piece("shelf")
            if shelf is not None and shelf[1][1] < 1.3 and self.rng.random() < 0.7:
                self.on_top(shelf[0], shelf[1][1], str(self.rng.choice(["box", "plant", "lamp"])), shelf[1])
        for _ in range(int(self.rng.integers(0, 4))):
            self.piece("box", free=self.rng.random() < 0.5)

    def mixed(self) -> None:
        for _ in range(int(self.rng.integers(3, 8))):
            category = str(
                self.rng.choice(
                    ["chair", "table", "sofa", "cabinet", "shelf", "desk", "lamp", "plant", "ottoman", "box", "bed"]
                )
            )
            self.piece(category, free=self.rng.random() < 0.4)

    def frames(self) -> None:
        """Pictures and mirrors hung on the walls (no floor space)."""
        for _ in range(int(self.rng.integers(0, 4))):
            chosen = self.model("frame")
            if chosen is None:
                return
            model_id, size = chosen
            x, z, yaw = self.wall_spot(size, int(self.rng.choice([0, 1, 2])))
            y = float(self.rng.uniform(1.0, 1.7))
            if y + size[1] < 2 * self.half[1] - 0.1:
                self._add(model_id, size, x, z, yaw, y=y, floor=False)

    def furnish(self, theme: str) -> list[tuple[Placement, float]]:
        """The room-frame placements (with their top heights) of a room of ``theme`` (one of :data:`THEMES`)."""
        getattr(self, theme)()
        if self.rng.random() < 0.6:
            self.frames()
        for category in ("plant", "box", "chair", "lamp"):  # clutter
            if self.rng.random() < 0.3:
                self.piece(category, free=self.rng.random() < 0.5)
        for _ in range(int(self.rng.integers(0, 4))):  # whatever else a room holds along its walls
            self.piece(str(self.rng.choice(["cabinet", "shelf", "chair", "table", "sofa", "desk", "refrigerator"])))
        return self.placed


def to_world(placement: Placement, center: np.ndarray, yaw: float) -> Placement:
    """A room-frame placement in a room box centred at ``center`` (its floor at y = 0) turned by ``yaw``."""
    local = np.array([placement.position[0], placement.position[1], placement.position[2]])
    world = np.asarray(center, dtype=float) * np.array([1.0, 0.0, 1.0]) + rotation_y(yaw) @ local
    return Placement(
        placement.segment_id,
        placement.label,
        placement.model_id,
        placement.mesh,
        (float(world[0]), float(world[1]), float(world[2])),
        placement.yaw + yaw,
        placement.scale,
        category=placement.category,
    )
