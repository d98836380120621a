"""Thumbnails of database models, rendered with Mitsuba and cached.

The paper searches 3D-FUTURE by encoding the renderings the database ships (§4.3 "Model search"); our
databases have none, so :class:`ThumbnailRenderer` makes them: the mesh's groups in their base colours
(diffuse), a sky-like constant light plus a sun, path traced (one bounce), seen from :data:`VIEWS`
(azimuth from the front, +Z, towards +X; elevation) with the object framed tightly, composited on white.

Renders are cached as PNG files under ``<cache>/object_db/<digest>/<model id>/view<k>.png`` (``<cache>``
is ``$PSDR_ROOM_CACHE_DIR`` or ``~/.cache/psdr-room``; ``<digest>`` hashes the database's digest and the
renderer settings), each written atomically, so concurrent builders and interrupted builds are safe.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.files import write_whole
from psdr_room_core.method.artifacts import ObjectMesh
from psdr_room_core.method.shading import linear_to_srgb, srgb_to_linear
from psdr_room_core.method.visualize import to_uint8

VIEWS: tuple[tuple[float, float], ...] = ((30.0, 22.0), (-40.0, 22.0), (150.0, 22.0), (-130.0, 22.0))
"""(azimuth, elevation) in degrees: front-right, front-left, back-right, back-left, at one elevation."""
SIZE = 128
SPP = 32
RENDER_VERSION = 1
"""Bump when the look of the thumbnails changes (it is part of the cache key)."""


class Identified(Protocol):
    @property
    def id(self) -> str: ...


class Models(Protocol):
    """What thumbnails read of a database (an :class:`~.database.ObjectDatabase` is one): the digest naming its
    cache folder, its records' ids and each model's mesh."""

    @property
    def digest(self) -> str: ...

    @property
    def records(self) -> Sequence[Identified]: ...

    def mesh(self, model_id: str) -> ObjectMesh: ...


def camera_for(
    extent: Sequence[float], azimuth: float, elevation: float, fov: float, margin: float = 0.92
) -> tuple[np.ndarray, np.ndarray]:
    """(origin, target) of a camera looking at the canonical bounding box from (azimuth, elevation),
    at the distance where every box corner is inside ``margin`` of the half field of view."""
    ex, ey, ez = (max(float(e), 1e-3) for e in extent)
    target = np.array([0.0, ey / 2, 0.0])
    a, e = math.radians(azimuth), math.radians(elevation)
    back = np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])  # towards the camera
    right = np.cross([0.0, 1.0, 0.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    corners = np.array([[sx * ex / 2, sy * ey / 2, sz * ez / 2] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    t = math.tan(math.radians(fov) / 2) * margin
    distance = max(float(c @ back + max(abs(c @ right), abs(c @ up)) / t) for c in corners)
    return target + back * distance, target


class ThumbnailRenderer:
    """Renders a :class:`~psdr_room_core.method.artifacts.ObjectMesh` from :data:`VIEWS` (H×W×3 uint8 sRGB each, on white)."""

    def __init__(
        self,
        size: int = SIZE,
        spp: int = SPP,
        views: Sequence[tuple[float, float]] = VIEWS,
        fov: float = 30.0,
        variant: str = "auto",
    ) -> None:
        self.size, self.spp, self.fov = int(size), int(spp), float(fov)
        self.views = tuple((float(a), float(e)) for a, e in views)
        self.variant = variant

    def settings_key(self) -> str:
        return f"v{RENDER_VERSION} size={self.size} spp={self.spp} fov={self.fov:g} views={self.views}"

    def _mi(self) -> Any:
        from psdr_room_core.libraries.llvm import resolve_variant

        variant = resolve_variant(self.variant)
        import mitsuba as mi

        if mi.variant() != variant:
            mi.set_variant(variant)
        return mi

    def render(self, mesh: ObjectMesh, views: Sequence[int] | None = None) -> list[np.ndarray]:
        """The mesh seen from each of ``views`` (indices into :attr:`views`; default all)."""
        views = range(len(self.views)) if views is None else views
        mi = self._mi()
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(
            {
                "type": "twosided",
                "bsdf": {"type": "diffuse", "reflectance": {"type": "mesh_attribute", "name": "face_color"}},
            }
        )
        corners = mesh.vertices[mesh.faces].reshape(-1, 3).astype(np.float32)  # unshared: flat shading
        count = len(mesh.faces)
        shape = mi.Mesh("object", 3 * count, count, props=props, has_vertex_normals=False, has_vertex_texcoords=False)
        params = mi.traverse(shape)
        params["vertex_positions"] = type(params["vertex_positions"])(corners.reshape(-1))
        params["faces"] = type(params["faces"])(np.arange(3 * count, dtype=np.uint32))
        params.update()
        albedo = srgb_to_linear(mesh.colors[mesh.face_group]).astype(np.float32)
        shape.add_attribute("face_color", 3, mi.Float(albedo.reshape(-1)))
        scene: dict[str, Any] = {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 3, "hide_emitters": True},
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.62, 0.64, 0.68]}},
            "sun": {
                "type": "directional",
                "direction": [0.35, -1.0, -0.55],
                "irradiance": {"type": "rgb", "value": [2.1, 2.0, 1.9]},
            },
            "object": shape,
        }
        for sensor, k in enumerate(views):
            azimuth, elevation = self.views[k]
            origin, target = camera_for(mesh.extent, azimuth, elevation, self.fov)
            scene[f"sensor{sensor}"] = {
                "type": "perspective",
                "fov": self.fov,
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=origin.tolist(), target=target.tolist(), up=[0.0, 1.0, 0.0]
                ),
                "film": {
                    "type": "hdrfilm",
                    "width": self.size,
                    "height": self.size,
                    "pixel_format": "rgba",
                    "rfilter": {"type": "gaussian"},
                },
                "sampler": {"type": "independent", "sample_count": self.spp},
            }
        loaded = mi.load_dict(scene)
        images = []
        for sensor, k in enumerate(views):
            rgba = np.array(mi.render(loaded, sensor=sensor, seed=k), dtype=np.float64)
            alpha = np.clip(rgba[..., 3:4], 0.0, 1.0)
            rgb = rgba[..., :3] + (1.0 - alpha)  # premultiplied (hidden background is black) over white
            images.append(to_uint8(linear_to_srgb(rgb)))
        return images


_RENDERERS: dict[tuple[Any, ...], ThumbnailRenderer] = {}


def default_renderer() -> ThumbnailRenderer:
    key = (SIZE, SPP, VIEWS)
    if key not in _RENDERERS:
        _RENDERERS[key] = ThumbnailRenderer()
    return _RENDERERS[key]


def cache_dir(db: Models, renderer: ThumbnailRenderer | None = None) -> Path:
    """Where ``db``'s thumbnails live: ``<cache>/object_db/<digest of db and renderer settings>``."""
    from psdr_room_core.engine.cache import default_cache_dir

    renderer = renderer or default_renderer()
    key = hashlib.sha256(f"{db.digest}\0{renderer.settings_key()}".encode()).hexdigest()[:20]
    return default_cache_dir() / "object_db" / key


def _view_path(folder: Path, model_id: str, view: int) -> Path:
    return folder / model_id / f"view{view}.png"


def _write_png(path: Path, rgb: np.ndarray) -> None:
    import cv2

    ok, data = cv2.imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
    if not ok:
        raise PsdrRoomError(f"{path}: could not encode the thumbnail")
    write_whole(path, data.tobytes())


def _read_png(path: Path) -> np.ndarray | None:
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_COLOR) if path.is_file() else None
    return None if image is None else np.ascontiguousarray(image[:, :, ::-1])


def cached_thumbnails(db: Models, model_id: str, renderer: ThumbnailRenderer | None = None) -> list[np.ndarray] | None:
    """The cached views of a model, or None if any is missing."""
    renderer = renderer or default_renderer()
    folder = cache_dir(db, renderer)
    images = [_read_png(_view_path(folder, model_id, k)) for k in range(len(renderer.views))]
    return None if any(image is None for image in images) else images  # type: ignore[return-value]


def thumbnails_for(
    db: Models, model_id: str, renderer: ThumbnailRenderer | None = None, views: Sequence[int] | None = None
) -> list[np.ndarray]:
    """The model's ``views`` (indices into the renderer's; default all) from the cache; the missing ones are
    rendered, in one scene, and stored there first (a contact sheet needs one view: it renders only that)."""
    renderer = renderer or default_renderer()
    views = list(range(len(renderer.views)) if views is None else views)
    folder = cache_dir(db, renderer)
    images = {k: _read_png(_view_path(folder, model_id, k)) for k in views}
    missing = [k for k, image in images.items() if image is None]
    if missing:
        for k, image in zip(missing, renderer.render(db.mesh(model_id), missing)):
            _write_png(_view_path(folder, model_id, k), image)
            images[k] = image
    return [images[k] for k in views]  # type: ignore[misc]


def build_thumbnails(
    db: Models,
    renderer: ThumbnailRenderer | None = None,
    progress: Callable[[Iterable[Any]], Iterable[Any]] | None = None,
) -> tuple[int, int]:
    """Render every missing thumbnail of ``db``; returns (models rendered, models already cached)."""
    renderer = renderer or default_renderer()
    rendered = cached = 0
    records = db.records if progress is None else progress(db.records)
    for record in records:
        if cached_thumbnails(db, record.id, renderer) is not None:
            cached += 1
            continue
        thumbnails_for(db, record.id, renderer)
        rendered += 1
    return rendered, cached
