"""Pictures of artifacts for reports and debugging: segment overlays, projected room edges, depth colour maps."""

from __future__ import annotations

import cv2
import numpy as np

from .artifacts import CATEGORIES, Camera, Panoptic, RoomBox

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
