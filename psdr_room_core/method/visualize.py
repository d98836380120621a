"""Pictures of artifacts for reports and debugging: segment overlays, projected room edges, depth colour maps,
loss curves, contact sheets, the material stages' crop sheets, the object stages' candidate sheets and posed
objects' outlines; and :func:`to_uint8`, the one conversion of a float image to 8 bits."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import cv2
import numpy as np

from psdr_room_core.engine.errors import PsdrRoomError

from .artifacts import CATEGORIES, Camera, Candidate, Panoptic, PartMaterial, Placements, Rect, RoomBox
from .objects import ObjectQuery
from .silhouette import silhouette

CATEGORY_COLORS = {
    "wall": (230, 159, 0),
    "floor": (0, 158, 115),
    "ceiling": (86, 180, 233),
    "window": (240, 228, 66),
    "door": (213, 94, 0),
    "lamp": (255, 255, 255),
    "object": (204, 121, 167),
}
"""RGB per category (Okabe-Ito palette, readable by colour-blind viewers)."""

BOX_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
"""The 12 edges of a box as pairs of corner indices (corners differ in one bit)."""


def to_uint8(image: np.ndarray) -> np.ndarray:
    """A float image (any shape) as 8 bits: clipped to [0, 1], times 255, rounded half up."""
    return (np.clip(image, 0, 1) * 255 + 0.5).astype(np.uint8)


def segment_overlay(rgb8: np.ndarray, panoptic: Panoptic, alpha: float = 0.45, text_scale: float = 0.4) -> np.ndarray:
    """Blend each segment's category colour over the image, outline every segment and name the large ones (in
    OpenCV's ``text_scale``; a segment is large from 200 pixels at 0.4, in proportion to the text's area)."""
    ids = panoptic.ids
    lookup = np.zeros((int(ids.max()) + 1, 3), np.float32)
    for segment in panoptic.segments:
        lookup[segment.id] = CATEGORY_COLORS[segment.category]
    labelled = ids > 0
    out = rgb8.astype(np.float32)
    out[labelled] = (1.0 - alpha) * out[labelled] + alpha * lookup[ids[labelled]]
    out = out.astype(np.uint8)
    edges = cv2.morphologyEx(ids.astype(np.float32), cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
    out[edges] = (20, 20, 20)
    ys, xs = np.indices(ids.shape)
    count = np.bincount(ids.ravel(), minlength=len(lookup))
    cx = np.bincount(ids.ravel(), weights=xs.ravel(), minlength=len(lookup)) / np.maximum(count, 1)
    cy = np.bincount(ids.ravel(), weights=ys.ravel(), minlength=len(lookup)) / np.maximum(count, 1)
    grow = text_scale / 0.4
    for segment in panoptic.segments:
        if count[segment.id] > 200 * grow * grow:
            cv2.putText(
                out,
                segment.label[:14],
                (int(cx[segment.id]) - round(20 * grow), int(cy[segment.id])),
                cv2.FONT_HERSHEY_SIMPLEX,
                text_scale,
                (255, 255, 255),
                max(1, round(grow)),
                cv2.LINE_AA,
            )
    return out


def legend(height: int = 22) -> np.ndarray:
    """A strip naming the category colours."""
    strip = np.full((height, 90 * len(CATEGORIES), 3), 255, np.uint8)
    for i, name in enumerate(CATEGORIES):
        cv2.rectangle(strip, (90 * i + 4, 4), (90 * i + 18, height - 5), CATEGORY_COLORS[name], -1)
        cv2.putText(strip, name, (90 * i + 22, height - 7), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    return strip


def project_room_edges(camera: Camera, room: RoomBox, near: float = 1e-3) -> list[tuple[np.ndarray, np.ndarray, str]]:
    """Image-space segments of the room box's 12 edges, clipped at the near plane, with the edge kind
    (``floor``, ``ceiling`` or ``vertical``)."""
    c2w = np.asarray(room.camera_to_world)
    corners = (room.corners() - c2w[:3, 3]) @ c2w[:3, :3]  # world → camera: R^T (x - t)
    segments = []
    for a, b in BOX_EDGES:
        p, q = corners[a].copy(), corners[b].copy()
        if p[2] < near and q[2] < near:
            continue
        if p[2] < near or q[2] < near:  # clip the part behind the camera
            t = (near - p[2]) / (q[2] - p[2])
            clipped = p + t * (q - p)
            p, q = (clipped, q) if p[2] < near else (p, clipped)
        uv = [(camera.fx * v[0] / v[2] + camera.cx, camera.fy * v[1] / v[2] + camera.cy) for v in (p, q)]
        kind = "vertical" if (a ^ b) == 2 else ("floor" if not a & 2 else "ceiling")
        segments.append((np.array(uv[0]), np.array(uv[1]), kind))
    return segments


def room_edges_overlay(rgb8: np.ndarray, camera: Camera, room: RoomBox, thickness: int = 2) -> np.ndarray:
    """Draw the projected room box edges (floor green, ceiling blue, vertical orange) over the image."""
    out = rgb8.copy()
    colors = {
        "floor": CATEGORY_COLORS["floor"],
        "ceiling": CATEGORY_COLORS["ceiling"],
        "vertical": CATEGORY_COLORS["wall"],
    }
    height, width = out.shape[:2]
    for p, q, kind in project_room_edges(camera, room):
        ok, a, b = cv2.clipLine((0, 0, width, height), _pixel(p), _pixel(q))
        if ok:
            cv2.line(out, a, b, colors[kind], thickness, cv2.LINE_AA)
    return out


def _pixel(p: np.ndarray) -> tuple[int, int]:
    limit = 1e6  # keep far-away projections inside int range for clipping
    return int(np.clip(p[0] - 0.5, -limit, limit)), int(np.clip(p[1] - 0.5, -limit, limit))


def depth_colormap(depth: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Depth as an RGB image (turbo, near = blue); invalid pixels black."""
    values = depth[valid]
    if values.size == 0:
        return np.zeros((*depth.shape, 3), np.uint8)
    lo, hi = np.percentile(values, [1, 99])
    norm = np.clip((depth - lo) / max(hi - lo, 1e-6), 0, 1)
    colored = cv2.applyColorMap((norm * 255).astype(np.uint8), cv2.COLORMAP_TURBO)[..., ::-1].copy()
    colored[~valid] = 0
    return colored


def contact_sheet(images: Sequence[tuple[str, np.ndarray]], *, columns: int = 8, font_scale: float = 0.3) -> np.ndarray:
    """Labelled images (uint8, all the same size) in a grid at most ``columns`` wide, each outlined, its label
    underneath in OpenCV's ``font_scale`` (wrapped after a '/' when too wide, then shortened): H×W×3 uint8."""
    if not images:
        raise PsdrRoomError("contact sheet: no images")
    h, w = images[0][1].shape[:2]

    def width(text: str) -> int:
        return cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, font_scale, 1)[0][0]

    def fit(text: str) -> str:
        if width(text) <= w - 4:
            return text
        while len(text) > 1 and width(text + "..") > w - 4:
            text = text[:-1]
        return text + ".."

    labels = []
    for label, _ in images:
        head, sep, tail = label.rpartition("/")
        labels.append([fit(label)] if width(label) <= w - 4 or not sep else [fit(head + sep), fit(tail)])
    line = int(round(22 * font_scale / 0.4 * 1.1)) + 2
    label_height = line * max(len(lines) for lines in labels) + 3
    columns = max(1, min(columns, len(images)))
    rows = (len(images) + columns - 1) // columns
    sheet = np.full((rows * (h + label_height), columns * w, 3), 255, np.uint8)
    for index, ((_, image), lines) in enumerate(zip(images, labels)):
        r, c = divmod(index, columns)
        y, x = r * (h + label_height), c * w
        sheet[y : y + h, x : x + w] = image[:, :, :3]
        cv2.rectangle(sheet, (x, y), (x + w - 1, y + h - 1), (225, 225, 225), 1)
        for k, text in enumerate(lines):
            at = (x + 2, y + h + line * (k + 1) - 2)
            cv2.putText(sheet, text, at, cv2.FONT_HERSHEY_SIMPLEX, font_scale, (20, 20, 20), 1, cv2.LINE_AA)
    return sheet


def fit_in_cell(rgb8: np.ndarray, cell: int, *, centred: bool = True) -> np.ndarray:
    """A white ``cell``×``cell`` tile holding ``rgb8`` scaled to a long side of ``cell`` (area-averaged when it
    shrinks, nearest pixel when it grows), centred or in the top-left corner."""
    scale = cell / max(rgb8.shape[:2])
    small = cv2.resize(
        rgb8,
        (max(1, round(rgb8.shape[1] * scale)), max(1, round(rgb8.shape[0] * scale))),
        interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_NEAREST,
    )
    tile = np.full((cell, cell, 3), 255, np.uint8)
    y0, x0 = ((cell - small.shape[0]) // 2, (cell - small.shape[1]) // 2) if centred else (0, 0)
    tile[y0 : y0 + small.shape[0], x0 : x0 + small.shape[1]] = small
    return tile


def crop_overlay(rgb8: np.ndarray, *, unclean: np.ndarray, crops: Sequence[tuple[str, Sequence[Rect]]]) -> np.ndarray:
    """The photo with the ``unclean`` pixels (of the parts' regions: clutter, strong edges) tinted red, and each
    part's crop windows outlined and named in a colour of its own."""
    out = rgb8.copy()
    out[unclean] = (0.5 * out[unclean] + [127, 0, 0]).astype(np.uint8)
    for k, (name, rects) in enumerate(crops):
        colour = tuple(
            int(c) for c in cv2.applyColorMap(np.array([[53 * k % 255]], np.uint8), cv2.COLORMAP_HSV)[0, 0][::-1]
        )
        for x0, y0, x1, y1 in rects:
            cv2.rectangle(out, (x0, y0), (x1 - 1, y1 - 1), colour, 2)
            cv2.putText(out, name, (x0 + 3, y0 + 12), cv2.FONT_HERSHEY_SIMPLEX, 0.38, colour, 1, cv2.LINE_AA)
    return out


def crop_sheet(
    rows: Sequence[tuple[str, Any, Any, tuple[float, float, float], PartMaterial]], *, cell: int = 96
) -> np.ndarray:
    """One row per crop pair (part name, photo crop and the retrieved material's view of it as [3, H, W] tensors,
    flat colour, chosen material): the crop, the view at the chosen transform, the flat median colour, and what
    was chosen."""
    lines = []
    for name, crop, view, albedo, chosen in rows:
        tiles = [
            fit_in_cell(to_uint8(crop.permute(1, 2, 0).numpy()), cell),
            fit_in_cell(to_uint8(view.permute(1, 2, 0).numpy()), cell),
            np.full((cell, cell, 3), np.round(np.asarray(albedo) * 255), np.uint8),
        ]
        caption = np.full((cell, 3 * cell, 3), 255, np.uint8)
        text = [
            name[:30],
            f"-> {chosen.material or 'homogeneous'}",
            f"scale {chosen.scale:g} rot {chosen.rotation:g}",
            f"tex {chosen.scores.get('texture_loss', float('nan')):.3f} flat {chosen.scores.get('homogeneous_loss', float('nan')):.3f}",
            f"sim {chosen.scores.get('similarity', float('nan')):.3f}",
        ]
        for i, line in enumerate(text):
            cv2.putText(caption, line, (4, 16 + 17 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (0, 0, 0), 1, cv2.LINE_AA)
        lines.append(np.hstack(tiles + [caption]))
    return np.vstack(lines)


def crop_pairs(
    photo: np.ndarray, start: np.ndarray, final: np.ndarray, rects: Sequence[Sequence[int]], *, cell: int = 96
) -> np.ndarray:
    """Fig. 7: each crop window of the photo beside the same window of the initial and of the final render (sRGB
    float images [H, W, 3])."""

    def tile(image: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        return fit_in_cell(to_uint8(image[y0:y1, x0:x1]), cell, centred=False)

    return np.vstack([np.hstack([tile(image, *rect) for image in (photo, start, final)]) for rect in rects])


def plot_curves(curves: dict[str, list[float]], size: tuple[int, int] = (520, 260), title: str = "") -> np.ndarray:
    """A line plot (RGB uint8) of curves against the iteration, each scaled to its own range; the legend
    gives each curve's first and last value."""
    width, height = size
    left, right, top, bottom = 12, 190, 24, 24
    plot = np.full((height, width, 3), 255, np.uint8)
    n = max(max((len(v) for v in curves.values()), default=1) - 1, 1)
    cv2.rectangle(plot, (left, top), (width - right, height - bottom), (160, 160, 160), 1)
    cv2.putText(
        plot, f"iterations 0-{n}", (left, height - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1, cv2.LINE_AA
    )
    cv2.putText(plot, title, (left, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    palette = list(CATEGORY_COLORS.values())
    for k, (name, curve) in enumerate(curves.items()):
        values = np.asarray(curve, dtype=np.float64)
        lo, hi = float(values.min()), float(values.max())
        color = tuple(int(c * 0.8) for c in palette[k % len(palette)])
        xs = left + np.arange(len(values)) / n * (width - right - left)
        ys = height - bottom - (values - lo) / max(hi - lo, 1e-12) * (height - bottom - top)
        cv2.polylines(plot, [np.stack([xs, ys], 1).round().astype(np.int32)], False, color, 1, cv2.LINE_AA)
        label = f"{name} {values[0]:.3g} > {values[-1]:.3g}"
        cv2.putText(
            plot, label, (width - right + 6, top + 16 * (k + 1)), cv2.FONT_HERSHEY_SIMPLEX, 0.36, color, 1, cv2.LINE_AA
        )
    return plot


def candidate_sheet(
    queries: list[ObjectQuery], ranked: dict[int, list[Candidate]], retriever: Any, cell: int = 96
) -> np.ndarray | None:
    """One row per object: its crop, then each candidate's thumbnail (``retriever.thumbnail``) with its id and
    score."""
    rows = []
    for q in queries:
        tiles = [_captioned_tile(q.crop, f"{q.segment_id}: {q.label}", cell)]
        tiles += [
            _captioned_tile(retriever.thumbnail(c.model_id), f"{c.model_id.split('/')[-1]} {c.score:.2f}", cell)
            for c in ranked[q.segment_id]
        ]
        row = np.full((cell + 14, cell * (1 + max(len(r) for r in ranked.values())), 3), 255, np.uint8)
        row[:, : cell * len(tiles)] = np.hstack(tiles)
        rows.append(row)
    return np.vstack(rows) if rows else None


def _captioned_tile(rgb8: np.ndarray, caption: str, cell: int) -> np.ndarray:
    """``rgb8`` area-resized to a long side of ``cell``, centred in a white tile with ``caption`` under it."""
    scale = cell / max(rgb8.shape[:2])
    small = cv2.resize(
        rgb8, (max(1, round(rgb8.shape[1] * scale)), max(1, round(rgb8.shape[0] * scale))), interpolation=cv2.INTER_AREA
    )
    tile = np.full((cell + 14, cell, 3), 255, np.uint8)
    y0, x0 = (cell - small.shape[0]) // 2, (cell - small.shape[1]) // 2
    tile[y0 : y0 + small.shape[0], x0 : x0 + small.shape[1]] = small
    cv2.putText(tile, caption[:18], (2, cell + 11), cv2.FONT_HERSHEY_SIMPLEX, 0.32, (0, 0, 0), 1, cv2.LINE_AA)
    return tile


def placement_outlines(rgb8: np.ndarray, camera: Camera, room: RoomBox, placements: Placements) -> np.ndarray:
    """Each placed object's silhouette outlined over the image in a colour of its own, named by its segment id,
    model and support."""
    out = rgb8.copy()
    c2w = np.asarray(room.camera_to_world)
    for k, p in enumerate(placements.objects):
        mask = silhouette(camera, c2w, p.world_vertices(), p.mesh.faces).astype(np.uint8)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        colour = tuple(
            int(c) for c in cv2.applyColorMap(np.array([[37 * k % 255]], np.uint8), cv2.COLORMAP_HSV)[0, 0][::-1]
        )
        cv2.drawContours(out, contours, -1, colour, 2)
        if contours:
            x, y = contours[0][0][0]
            cv2.putText(
                out,
                f"{p.segment_id}:{p.model_id.split('/')[-1]} ({p.support})",
                (int(x), max(12, int(y) - 4)),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.4,
                colour,
                1,
                cv2.LINE_AA,
            )
    return out


def object_fit_pictures(
    rgb8: np.ndarray,
    panoptic: Panoptic,
    camera: Camera,
    room: RoomBox,
    *,
    before: Placements,
    after: Placements,
    history: list[dict[str, float]],
) -> dict[str, np.ndarray]:
    """The object fit's pictures: the objects outlined over the faint segmentation ``before`` and ``after`` it,
    and its ``loss`` curves (of ``history``, the per-iteration log)."""
    base = segment_overlay(rgb8, panoptic, alpha=0.25)
    curves = {k: [h[k] for h in history] for k in history[0]}
    return {
        "before": placement_outlines(base, camera, room, before),
        "after": placement_outlines(base, camera, room, after),
        "loss": plot_curves(curves, title="fit_objects"),
    }
