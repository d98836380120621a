"""The room's geometry: point cloud, room box (§4.2), retrieved candidates, object meshes and their placements (§4.3)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError

from ..geometry import TriangleMesh
from .io import ply_bytes, read_json, read_ply, read_png, write_json, write_png
from .segmentation import SeenBox, Segment


@dataclass
class PointCloud:
    """The segmented point cloud in the camera frame, with a segment id per point (see ``segments``)."""

    kind: ClassVar[str] = "point_cloud"
    marker: ClassVar[str] = "points.ply"
    points: np.ndarray
    colors: np.ndarray
    segment: np.ndarray
    segments: list[Segment]

    def category_points(self, category: str) -> np.ndarray:
        wanted = [s.id for s in self.segments if s.category == category]
        return self.points[np.isin(self.segment, wanted)]

    def save(self, directory: Path) -> None:
        (directory / "points.ply").write_bytes(ply_bytes(self.points, self.colors, self.segment))
        write_json(directory / "segments.json", [asdict(s) for s in self.segments])

    @classmethod
    def load(cls, directory: Path) -> PointCloud:
        data = read_ply(directory / "points.ply")
        segments = [
            Segment(**{**s, "seen": None if s.get("seen") is None else SeenBox.from_json(s["seen"])})
            for s in read_json(directory / "segments.json")
        ]
        points = np.stack([data["x"], data["y"], data["z"]], axis=1).astype(np.float32)
        colors = np.stack([data["red"], data["green"], data["blue"]], axis=1)
        return cls(points=points, colors=colors, segment=data["segment"].astype(np.int32), segments=segments)


def vec3(values: Iterable[Any]) -> tuple[float, float, float]:
    """Three numbers (a position, an RGB colour) as a typed tuple of floats."""
    x, y, z = (float(v) for v in values)
    return x, y, z


def rotation_y(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about +Y."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass
class RoomBox:
    """The room as a box in the world frame, and the camera's pose in that frame.

    World corner = ``center + R_y(yaw) @ (±hx, ±hy, ±hz)``; the floor is ``y = 0`` so ``center[1] ==
    half_size[1]`` for a box standing on the floor.
    """

    kind: ClassVar[str] = "room_box"
    marker: ClassVar[str] = "room_box.json"
    camera_to_world: np.ndarray
    center: np.ndarray
    half_size: np.ndarray
    yaw: float
    ceiling_visible: bool = True
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def floor(self) -> float:
        """Height of the box's floor (0 for a box standing on the floor; ``room_fit`` may move it a little)."""
        return float(self.center[1] - self.half_size[1])

    def local(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) in the box's own frame: axes along its sides, origin at its centre."""
        return (np.asarray(points) - np.asarray(self.center)) @ rotation_y(self.yaw)

    def corners(self) -> np.ndarray:
        """The 8 world-space corners, index bits (x, y, z) → sign (-, +)."""
        signs = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)]) * 2.0 - 1.0
        return self.center + (signs * self.half_size) @ rotation_y(self.yaw).T

    def save(self, directory: Path) -> None:
        write_json(
            directory / "room_box.json",
            {
                "camera_to_world": np.asarray(self.camera_to_world).tolist(),
                "center": np.asarray(self.center).tolist(),
                "half_size": np.asarray(self.half_size).tolist(),
                "yaw": float(self.yaw),
                "ceiling_visible": bool(self.ceiling_visible),
                "extra": self.extra,
            },
        )

    @classmethod
    def load(cls, directory: Path) -> RoomBox:
        d = read_json(directory / "room_box.json")
        return cls(
            camera_to_world=np.array(d["camera_to_world"], dtype=np.float64),
            center=np.array(d["center"], dtype=np.float64),
            half_size=np.array(d["half_size"], dtype=np.float64),
            yaw=float(d["yaw"]),
            ceiling_visible=bool(d["ceiling_visible"]),
            extra=d.get("extra", {}),
        )


@dataclass(frozen=True)
class Candidate:
    """A database model ranked for an object segment."""

    model_id: str
    score: float
    """Retrieval similarity (higher is better; its scale depends on the retrieval implementation)."""
    category: str = ""
    """The model's database category."""
    terms: dict[str, float] = field(default_factory=dict)
    """What the score is made of, by name, where the retrieval can say (silhouette retrieval: ``iou`` of the posed
    model's silhouette with the mask, then its error's terms, :data:`~psdr_room_core.method.view_search.ERROR_TERMS`)."""


@dataclass
class ObjectCandidates:
    """Top-k database models per object segment (the paper's "user picks among top-k")."""

    kind: ClassVar[str] = "object_candidates"
    marker: ClassVar[str] = "candidates.json"
    ranked: dict[int, list[Candidate]]
    """Segment id → candidates, best first."""
    labels: dict[int, str]
    """Segment id → its label."""
    source: str = ""
    """The retrieval implementation and database that ranked them."""
    sheet: np.ndarray | None = None
    """RGB uint8 picture: per object, its crop then the candidates' thumbnails with their scores."""

    def save(self, directory: Path) -> None:
        if self.sheet is not None:
            write_png(directory / "candidates.png", self.sheet)
        write_json(
            directory / "candidates.json",
            {
                "source": self.source,
                "objects": [
                    {
                        "segment_id": sid,
                        "label": self.labels.get(sid, ""),
                        "candidates": [
                            {
                                "model_id": c.model_id,
                                "score": float(c.score),
                                "category": c.category,
                                "terms": {k: float(v) for k, v in c.terms.items()},
                            }
                            for c in ranked
                        ],
                    }
                    for sid, ranked in sorted(self.ranked.items())
                ],
            },
        )

    @classmethod
    def load(cls, directory: Path) -> ObjectCandidates:
        data = read_json(directory / "candidates.json")
        try:
            ranked = {
                int(o["segment_id"]): [
                    Candidate(
                        str(c["model_id"]),
                        float(c["score"]),
                        str(c.get("category", "")),
                        {str(k): float(v) for k, v in c.get("terms", {}).items()},
                    )
                    for c in o["candidates"]
                ]
                for o in data["objects"]
            }
            labels = {int(o["segment_id"]): str(o.get("label", "")) for o in data["objects"]}
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(
                f"{directory / 'candidates.json'}: not as psdr-room writes it ({exc}); fix or regenerate it"
            ) from None
        sheet = read_png(directory / "candidates.png") if (directory / "candidates.png").is_file() else None
        return cls(ranked=ranked, labels=labels, source=str(data.get("source", "")), sheet=sheet)


@dataclass(frozen=True)
class ObjectMesh:
    """A database mesh in its canonical frame (Y up, bottom at y = 0, centred on x = z = 0, front +Z), metres."""

    vertices: np.ndarray
    faces: np.ndarray
    face_group: np.ndarray
    """(M,) index into ``groups`` per face: the material parts."""
    groups: tuple[str, ...]
    colors: np.ndarray
    """(G, 3) float sRGB base colour per group, in [0, 1]."""

    @property
    def extent(self) -> tuple[float, float, float]:
        size = np.ptp(self.vertices, axis=0)
        return float(size[0]), float(size[1]), float(size[2])

    def group_mesh(self, group: str | int) -> TriangleMesh:
        """The faces of one group (all vertices kept) as a :class:`~psdr_room_core.method.geometry.TriangleMesh`."""
        index = self.groups.index(group) if isinstance(group, str) else int(group)
        return TriangleMesh(vertices=self.vertices, faces=self.faces[self.face_group == index])

    def triangle_mesh(self) -> TriangleMesh:
        return TriangleMesh(vertices=self.vertices, faces=self.faces)

    def check(self, where: str) -> None:
        """Raise :class:`PsdrRoomError` unless the arrays are consistent (shapes, indices, finite values)."""
        v, f, g = self.vertices, self.faces, self.face_group
        problems = []
        if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
            problems.append("vertices must be finite (N, 3)")
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
            problems.append("faces must be (M, 3) with M > 0")
        elif f.min() < 0 or f.max() >= len(v):
            problems.append("faces index vertices out of range")
        if g.shape != (len(f),) or (len(g) and (g.min() < 0 or g.max() >= len(self.groups))):
            problems.append("face_group must give every face a group")
        if self.colors.shape != (len(self.groups), 3) or not np.all((self.colors >= 0) & (self.colors <= 1)):
            problems.append("colors must be (G, 3) in [0, 1]")
        if problems:
            raise PsdrRoomError(f"{where}: invalid mesh ({'; '.join(problems)}); re-export it")

    def write_obj(self, obj: Path) -> None:
        """An OBJ (+ MTL beside it) with one ``usemtl`` block per group."""
        mtl = obj.with_suffix(".mtl")
        lines = [f"mtllib {mtl.name}"] + [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in self.vertices]
        for g, name in enumerate(self.groups):
            lines.append(f"usemtl {name}")
            lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in self.faces[self.face_group == g]]
        obj.write_text("\n".join(lines) + "\n")
        mtl.write_text(
            "".join(f"newmtl {name}\nKd {r:.4f} {g:.4f} {b:.4f}\n" for name, (r, g, b) in zip(self.groups, self.colors))
        )

    @classmethod
    def read_obj(cls, obj: Path) -> ObjectMesh:
        """Read what :meth:`write_obj` wrote (triangles, ``usemtl`` groups, ``Kd`` colours)."""
        vertices, faces, face_group, groups = [], [], [], []
        try:
            for line in obj.read_text().splitlines():
                head, _, rest = line.partition(" ")
                if head == "v":
                    vertices.append([float(v) for v in rest.split()[:3]])
                elif head == "usemtl":
                    groups.append(rest.strip())
                elif head == "f":
                    faces.append([int(v.split("/")[0]) - 1 for v in rest.split()])
                    face_group.append(max(len(groups) - 1, 0))
            colors = dict.fromkeys(groups, (0.5, 0.5, 0.5))
            name = None
            mtl = obj.with_suffix(".mtl")
            for line in mtl.read_text().splitlines() if mtl.is_file() else []:
                head, _, rest = line.partition(" ")
                if head == "newmtl":
                    name = rest.strip()
                elif head == "Kd" and name in colors:
                    colors[name] = vec3(rest.split()[:3])
        except FileNotFoundError:
            raise PsdrRoomError(f"{obj}: missing; the artifact directory is incomplete") from None
        except ValueError as exc:
            raise PsdrRoomError(
                f"{obj}: not a triangle OBJ as psdr-room writes it ({exc}); fix or regenerate it"
            ) from None
        groups = groups or ["default"]
        return cls(
            vertices=np.asarray(vertices, np.float64).reshape(-1, 3),
            faces=np.asarray(faces, np.int64).reshape(-1, 3),
            face_group=np.asarray(face_group, np.int64),
            groups=tuple(groups),
            colors=np.asarray([colors.get(g, (0.5, 0.5, 0.5)) for g in groups], np.float64),
        )


SUPPORTS = ("floor", "parent", "wall", "free")
"""How an object is held: on the floor, on top of another object, on a wall, or not at all."""


@dataclass(frozen=True)
class Placement:
    """One retrieved object placed in the world: ``to_world = T(position) R_y(yaw) S(scale)``."""

    segment_id: int
    label: str
    model_id: str
    mesh: ObjectMesh
    position: tuple[float, float, float]
    """World position of the mesh's origin (the centre of its bottom)."""
    yaw: float
    scale: float
    support: str = "free"
    """One of :data:`SUPPORTS`."""
    anchor: int | None = None
    """The parent's segment id (``parent``) or the room box side (``wall``: 0..3 = -x, +x, -z, +z)."""
    category: str = "other"
    """The model's database category (its size range: :mod:`psdr_room_core.method.sizes`)."""
    explained: float | None = None
    """How much of its segment the posed model explains (the view search's visible-silhouette IoU); None: not
    measured."""

    @property
    def to_world(self) -> np.ndarray:
        matrix = np.eye(4)
        matrix[:3, :3] = rotation_y(self.yaw) * self.scale
        matrix[:3, 3] = self.position
        return matrix

    def world_vertices(self) -> np.ndarray:
        return self.mesh.vertices @ self.to_world[:3, :3].T + np.asarray(self.position)


@dataclass
class Placements:
    """The scene's objects: retrieved meshes (``meshes/<segment>.obj``) and their poses (``placements.json``)."""

    kind: ClassVar[str] = "placements"
    marker: ClassVar[str] = "placements.json"
    objects: list[Placement]
    extra: dict[str, Any] = field(default_factory=dict)

    def save(self, directory: Path) -> None:
        (directory / "meshes").mkdir()
        items = []
        for p in self.objects:
            p.mesh.write_obj(directory / "meshes" / f"{p.segment_id}.obj")
            items.append(
                {
                    "segment_id": p.segment_id,
                    "label": p.label,
                    "model_id": p.model_id,
                    "mesh": f"meshes/{p.segment_id}.obj",
                    "position": [float(v) for v in p.position],
                    "yaw": float(p.yaw),
                    "scale": float(p.scale),
                    "support": p.support,
                    "anchor": p.anchor,
                    "category": p.category,
                    "explained": p.explained,
                    "to_world": p.to_world.tolist(),
                }
            )
        write_json(directory / "placements.json", {"objects": items, "extra": self.extra})

    @classmethod
    def load(cls, directory: Path) -> Placements:
        data = read_json(directory / "placements.json")
        try:
            objects = [
                Placement(
                    segment_id=int(o["segment_id"]),
                    label=str(o["label"]),
                    model_id=str(o["model_id"]),
                    mesh=ObjectMesh.read_obj(directory / o["mesh"]),
                    position=vec3(o["position"]),
                    yaw=float(o["yaw"]),
                    scale=float(o["scale"]),
                    support=str(o["support"]),
                    anchor=None if o.get("anchor") is None else int(o["anchor"]),
                    category=str(o.get("category", "other")),
                    explained=None if o.get("explained") is None else float(o["explained"]),
                )
                for o in data["objects"]
            ]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(
                f"{directory / 'placements.json'}: not as psdr-room writes it ({exc}); fix or regenerate it"
            ) from None
        return cls(objects=objects, extra=dict(data.get("extra") or {}))
