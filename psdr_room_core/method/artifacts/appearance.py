"""The room's appearance: materials per part (§4.4), lights, the fitted appearance and the exported scene files."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError

from ..geometry import TriangleMesh
from .geometry import vec3
from .io import load_meshes, read_json, read_npy, read_png, save_meshes, write_json, write_png

Rect = tuple[int, int, int, int]
"""A crop window ``(x0, y0, x1, y1)`` in working-image pixels, ``x1``/``y1`` exclusive."""


@dataclass(frozen=True)
class PartMaterial:
    """The material assigned to one scene part (a room side or an object's material group), §4.4."""

    part: str
    """Shape id as exported: ``floor``, ``wall_x_neg`` ..., ``object_<segment>_<group>``."""
    kind: str
    """``homogeneous`` (constant albedo and roughness) or ``procedural`` (a library graph)."""
    albedo: tuple[float, float, float]
    """sRGB median colour of the part's pixels (the paper's ``C_i``): the homogeneous albedo the fit starts from;
    ``samples`` names the pixels it was measured on, where eq. 4's colour term compares means."""
    roughness: float = 0.5
    material: str | None = None
    """The library graph of a procedural part."""
    scale: float = 1.0
    """Texture transform: the graph's tile covers ``tile_size / scale`` metres of the surface ..."""
    rotation: float = 0.0
    """... rotated by this many degrees in the part's planar mapping."""
    crops: tuple[Rect, ...] = ()
    candidates: tuple[tuple[str, float], ...] = ()
    """Retrieved graphs (name, similarity), best first, after voting across crops."""
    scores: dict[str, float] = field(default_factory=dict)
    """``similarity`` of the chosen graph, ``texture_loss`` at the chosen transform, ``homogeneous_loss``."""
    reason: str = ""
    """Why the part got its kind, in words."""


@dataclass
class MaterialAssignment:
    """Initial materials of every visible part with their crop pairs (§4.4, first half)."""

    kind: ClassVar[str] = "materials"
    marker: ClassVar[str] = "materials.json"
    parts: list[PartMaterial]
    images: dict[str, np.ndarray] = field(default_factory=dict)
    """Name → RGB uint8 picture (crop windows over the photo, crop pairs sheet)."""
    samples: np.ndarray | None = None
    """(H, W) int16 at the working image's size: the index in ``parts`` of the part whose colour target this
    pixel gave (its clean pixels, else its region), -1 elsewhere."""

    def part(self, name: str) -> PartMaterial | None:
        return next((p for p in self.parts if p.part == name), None)

    def save(self, directory: Path) -> None:
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)
        if self.samples is not None:
            np.save(directory / "samples.npy", self.samples.astype(np.int16))
        write_json(
            directory / "materials.json",
            {
                "images": sorted(self.images),
                "parts": [
                    {**asdict(p), "crops": [list(c) for c in p.crops], "candidates": [list(c) for c in p.candidates]}
                    for p in self.parts
                ],
            },
        )

    @classmethod
    def load(cls, directory: Path) -> MaterialAssignment:
        data = read_json(directory / "materials.json")
        try:
            parts = [
                PartMaterial(
                    **{
                        **p,
                        "albedo": tuple(float(v) for v in p["albedo"]),
                        "crops": tuple(tuple(int(v) for v in c) for c in p["crops"]),
                        "candidates": tuple((str(n), float(s)) for n, s in p["candidates"]),
                    }
                )
                for p in data["parts"]
            ]
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(
                f"{directory / 'materials.json'}: not as psdr-room writes it ({exc}); fix or regenerate it"
            ) from None
        samples = read_npy(directory / "samples.npy") if (directory / "samples.npy").is_file() else None
        return cls(
            parts=parts, images={n: read_png(directory / f"{n}.png") for n in data.get("images", [])}, samples=samples
        )


@dataclass
class Light:
    """An area light: a world-space mesh emitting on the side its triangles face counter-clockwise."""

    name: str
    kind: str
    """``ceiling``, ``behind_camera``, ``invisible_wall``, ``window`` or ``lamp`` (§4.4)."""
    mesh: TriangleMesh
    radiance: tuple[float, float, float] = (1.0, 1.0, 1.0)
    """Linear RGB radiance."""
    part: str | None = None
    """The scene part this light replaces (a lamp's largest visible part), if any."""


@dataclass
class Lights:
    """The scene's initial lights (§4.4): emitters, window frames, and the chosen uniform radiance."""

    kind: ClassVar[str] = "lights"
    marker: ClassVar[str] = "lights.json"
    lights: list[Light]
    fixtures: dict[str, TriangleMesh] = field(default_factory=dict)
    """Non-emitting geometry the lights bring (window frames), world space."""
    sweep: list[tuple[float, float]] = field(default_factory=list)
    """(radiance, loss) of every uniform value tried."""
    images: dict[str, np.ndarray] = field(default_factory=dict)

    def save(self, directory: Path) -> None:
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)
        save_meshes(directory / "meshes.npz", {**{l.name: l.mesh for l in self.lights}, **self.fixtures})
        write_json(
            directory / "lights.json",
            {
                "lights": [
                    {"name": l.name, "kind": l.kind, "radiance": list(l.radiance), "part": l.part} for l in self.lights
                ],
                "fixtures": list(self.fixtures),
                "sweep": [list(s) for s in self.sweep],
                "images": sorted(self.images),
            },
        )

    @classmethod
    def load(cls, directory: Path) -> Lights:
        data = read_json(directory / "lights.json")
        try:
            names = [l["name"] for l in data["lights"]] + list(data["fixtures"])
            meshes = load_meshes(directory / "meshes.npz", names)
            lights = [
                Light(
                    str(l["name"]),
                    str(l["kind"]),
                    meshes[l["name"]],
                    vec3(l["radiance"]),
                    l.get("part"),
                )
                for l in data["lights"]
            ]
            return cls(
                lights=lights,
                fixtures={n: meshes[n] for n in data["fixtures"]},
                sweep=[(float(a), float(b)) for a, b in data["sweep"]],
                images={n: read_png(directory / f"{n}.png") for n in data.get("images", [])},
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise PsdrRoomError(
                f"{directory / 'lights.json'}: not as psdr-room writes it ({exc}); fix or regenerate it"
            ) from None


@dataclass
class PartAppearance:
    """A scene part's optimised material (§4.4, eq. 4)."""

    part: str
    kind: str
    """``homogeneous`` or ``procedural``."""
    base_color: tuple[float, float, float]
    """Linear RGB (a procedural part: the mean of its map, for reference)."""
    roughness: float = 0.5
    specular: float = 0.5
    material: str | None = None
    scale: float = 1.0
    rotation: float = 0.0
    params: dict[str, Any] = field(default_factory=dict)
    """The graph's continuous parameters (``node.param`` → number or nested list) of a procedural part."""


@dataclass
class SceneAppearance:
    """Materials and light radiances after the joint optimisation, with its renders."""

    kind: ClassVar[str] = "appearance"
    marker: ClassVar[str] = "appearance.json"
    parts: list[PartAppearance]
    radiance: dict[str, tuple[float, float, float]]
    """Light name → linear RGB radiance."""
    images: dict[str, np.ndarray] = field(default_factory=dict)

    def part(self, name: str) -> PartAppearance | None:
        return next((p for p in self.parts if p.part == name), None)

    def save(self, directory: Path) -> None:
        for name, picture in self.images.items():
            write_png(directory / f"{name}.png", picture)
        write_json(
            directory / "appearance.json",
            {
                "parts": [asdict(p) for p in self.parts],
                "radiance": {k: list(v) for k, v in self.radiance.items()},
                "images": sorted(self.images),
            },
        )

    @classmethod
    def load(cls, directory: Path) -> SceneAppearance:
        data = read_json(directory / "appearance.json")
        return cls(
            **appearance_fields(data, directory / "appearance.json"),
            images={n: read_png(directory / f"{n}.png") for n in data.get("images", [])},
        )


def appearance_fields(data: Any, path: Path) -> dict[str, Any]:
    """``parts`` and ``radiance`` of a :class:`SceneAppearance` from its JSON form (``path`` for errors)."""
    try:
        parts = [
            PartAppearance(
                **{**p, "base_color": tuple(float(v) for v in p["base_color"]), "params": dict(p.get("params", {}))}
            )
            for p in data["parts"]
        ]
        radiance = {str(k): tuple(float(x) for x in v) for k, v in data["radiance"].items()}
    except (KeyError, TypeError, ValueError) as exc:
        raise PsdrRoomError(f"{path}: not as psdr-room writes it ({exc}); fix or regenerate it") from None
    return {"parts": parts, "radiance": radiance}


@dataclass
class SceneFiles:
    """An exported scene: a directory of files (``scene.xml`` for Mitsuba 3, meshes, point cloud)."""

    kind: ClassVar[str] = "scene_files"
    marker: ClassVar[str] = "scene.xml"
    published_as: ClassVar[str] = "scene"
    """Also written at the top of the run directory, as ``scene/`` (the engine's ``publish``)."""
    files: dict[str, bytes]
    """Relative path → content."""

    def save(self, directory: Path) -> None:
        for rel, content in self.files.items():
            target = directory / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(content)

    @classmethod
    def load(cls, directory: Path) -> SceneFiles:
        return cls(
            files={
                p.relative_to(directory).as_posix(): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()
            }
        )
