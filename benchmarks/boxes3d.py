"""3D boxes of SUN RGB-D's reference objects and of a fitted scene in one frame, and the measures between them.

The reference is Total3DUnderstanding's preprocessed SUN RGB-D ground truth (``gt_3d_total3d.json`` beside the
photo, with ``cam_K.txt``): each object's box as 8 corners (``bdb3D``) and the room's (``layout_bdb3D``) in
Total3D's world frame, and the camera's pitch and roll as Total3D's bins (``camera_pitch_roll_bins``).

Frames (metres):

- Total3D world: x forward (the camera's heading), y up, z right, the camera at the origin; the camera's
  rotation ``cam_R = R_z(pitch) R_x(roll)`` has the camera's toward, up and right vectors as columns, and a world
  point ``p`` is ``(p @ cam_R)`` in the camera's (toward, up, right) axes (Total3D's ``proj_from_point_to_2d``);
- a box's corners (Total3D's ``get_corners_of_bb3d_no_index``): 0-3 on top, 4-7 below them; ``1 - 0`` runs
  along the box's front axis, ``3 - 0`` along its width;
- pitch: the optical axis's angle above the horizontal (+ looking up); roll: the turn about the optical axis
  (+ the camera's right side down), as both Total3D and :func:`~psdr_room_core.libraries.synth.instances.
  camera_angles` define them;
- level frame: the OpenCV camera frame (x right, y down, z forward) turned by the camera's pitch and roll so that
  y points along gravity: the camera at the origin, z its heading. Each scene is compared in its own camera's
  level frame (the reference's with the reference pitch and roll, the fitted scene's with the fitted
  ``camera_to_world``), so object errors do not include the camera's tilt, which is measured on its own.

Boxes are compared gravity-aligned: IoU is the footprint polygons' intersection times the vertical overlap, over
the union of the volumes.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from psdr_room_core.libraries.synth.instances import InstanceBox, camera_angles
from psdr_room_core.method.artifacts import ObjectMesh, Placement, RoomBox, rotation_y

REFERENCE_FILE = "gt_3d_total3d.json"
INTRINSICS_FILE = "cam_K.txt"
PITCH_BIN_CENTRES = (-40.0, 0.0)
PITCH_BIN_WIDTH = 40.0
ROLL_BIN_CENTRES = (-10.0, 10.0)
ROLL_BIN_WIDTH = 20.0
"""Total3D's camera bins in degrees (``configs/data_config.py``): an angle is ``centre[cls] + reg × width``."""
TOTAL3D_TO_OPENCV = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])
"""(toward, up, right) → OpenCV (x right, y down, z forward); the same matrix takes Total3D's level world
(x forward, y up, z right) to the level frame."""


@dataclass(frozen=True)
class LevelBox:
    """A gravity-aligned box in a level frame: ``size`` (width, height, depth) along its own right, vertical and
    front axes; ``yaw``: the front's direction in the floor plane, ``atan2(front_x, front_z)`` (0: facing away
    from the camera)."""

    center: np.ndarray
    size: np.ndarray
    yaw: float

    def footprint(self) -> np.ndarray:
        """(4, 2) floor-plane (x, z) corners, counter-clockwise in (x, z)."""
        front = np.array([math.sin(self.yaw), math.cos(self.yaw)])
        side = np.array([front[1], -front[0]])
        half_w, half_d = self.size[0] / 2, self.size[2] / 2
        middle = self.center[[0, 2]]
        signs = ((-1, -1), (1, -1), (1, 1), (-1, 1))
        corners = np.array([middle + a * half_w * side + b * half_d * front for a, b in signs])
        return corners if _area(corners) > 0 else corners[::-1]

    def vertical(self) -> tuple[float, float]:
        """(top, bottom): the box's extent along the level frame's y (down)."""
        return float(self.center[1] - self.size[1] / 2), float(self.center[1] + self.size[1] / 2)


@dataclass(frozen=True)
class ReferenceScene:
    """One photo's reference in its level frame, objects in ``detections_raw`` order."""

    classes: list[str]
    """Each object's class (lower case, spaces as ``_``)."""
    boxes2d: list[np.ndarray]
    """Each object's 2D box (x0, y0, x1, y1) in photo pixels: ``detections_raw``."""
    boxes: list[LevelBox]
    corners: list[np.ndarray]
    """Each object's (8, 3) corners in the OpenCV camera frame."""
    layout: LevelBox
    pitch: float
    roll: float
    """Radians."""
    K: np.ndarray

    def box_of(self, name: str, box2d: np.ndarray) -> LevelBox | None:
        """The 3D box of the first object of class ``name`` with exactly this 2D box (``detections.json`` drops
        exact duplicates of ``detections_raw``'s boxes, keeping the first); None when there is none."""
        for cls, box, box3d in zip(self.classes, self.boxes2d, self.boxes):
            if cls == name and np.array_equal(box, box2d):
                return box3d
        return None


# ------------------------------------------------------------------------------------------ the reference
def total3d_angles(bins: dict[str, float]) -> tuple[float, float]:
    """(pitch, roll) in radians from Total3D's ``pitch_cls``, ``pitch_reg``, ``roll_cls``, ``roll_reg``."""
    pitch = PITCH_BIN_CENTRES[int(bins["pitch_cls"])] + float(bins["pitch_reg"]) * PITCH_BIN_WIDTH
    roll = ROLL_BIN_CENTRES[int(bins["roll_cls"])] + float(bins["roll_reg"]) * ROLL_BIN_WIDTH
    return math.radians(pitch), math.radians(roll)


def total3d_rotation(pitch: float, roll: float) -> np.ndarray:
    """Total3D's ``cam_R`` of a camera with no yaw (``R_from_yaw_pitch_roll(0, pitch, roll)``)."""
    cp, sp, cr, sr = math.cos(pitch), math.sin(pitch), math.cos(roll), math.sin(roll)
    return np.array([[cp, -cr * sp, sp * sr], [sp, cp * cr, -cp * sr], [0.0, sr, cr]])


def total3d_to_camera(points: np.ndarray, pitch: float, roll: float) -> np.ndarray:
    """(N, 3) Total3D world points in the OpenCV camera frame."""
    return np.asarray(np.asarray(points) @ total3d_rotation(pitch, roll) @ TOTAL3D_TO_OPENCV.T)


def project(points: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(N, 2) pixels of OpenCV camera-frame points."""
    pixels = np.asarray(np.asarray(points) @ K.T)
    return np.asarray(pixels[:, :2] / pixels[:, 2:])


def total3d_box(corners: np.ndarray) -> LevelBox:
    """The level-frame box of Total3D corners (Total3D's level world, see the module's frames)."""
    level = np.asarray(corners, np.float64) @ TOTAL3D_TO_OPENCV.T
    front = level[1] - level[0]
    return LevelBox(
        center=level.mean(axis=0),
        size=np.array([np.linalg.norm(level[3] - level[0]), level[4, 1] - level[0, 1], np.linalg.norm(front)]),
        yaw=math.atan2(front[0], front[2]),
    )


def read_reference(folder: Path) -> ReferenceScene | None:
    """The reference of a photo's folder; None when it has no ``gt_3d_total3d.json``."""
    file = folder / REFERENCE_FILE
    if not file.is_file():
        return None
    data = json.loads(file.read_text())
    pitch, roll = total3d_angles(data["camera_pitch_roll_bins"])
    return ReferenceScene(
        classes=[str(d["class"]).lower().replace(" ", "_") for d in data["detections_raw"]],
        boxes2d=[np.asarray(d["bbox"], np.float64) for d in data["detections_raw"]],
        boxes=[total3d_box(np.asarray(c)) for c in data["bdb3D"]],
        corners=[total3d_to_camera(np.asarray(c), pitch, roll) for c in data["bdb3D"]],
        layout=total3d_box(np.asarray(data["layout_bdb3D"])),
        pitch=pitch,
        roll=roll,
        K=np.loadtxt(folder / INTRINSICS_FILE),
    )


# ------------------------------------------------------------------------------------------ the fitted scene
def level_rotation(camera_to_world: np.ndarray) -> np.ndarray:
    """World → level frame rotation of a camera pose (world Y up): rows right, down, forward, horizontal."""
    heading = camera_angles(camera_to_world)[0]
    c, s = math.cos(heading), math.sin(heading)
    return np.array([[-c, 0.0, s], [0.0, -1.0, 0.0], [s, 0.0, c]])


def world_box(center: np.ndarray, size: np.ndarray, yaw: float, camera_to_world: np.ndarray) -> LevelBox:
    """The level-frame box of a world box (corner = ``center + R_y(yaw) @ (±size / 2)``, front along its +Z)."""
    level = level_rotation(camera_to_world)
    front = level @ rotation_y(yaw) @ np.array([0.0, 0.0, 1.0])
    return LevelBox(
        center=level @ (np.asarray(center, np.float64) - camera_to_world[:3, 3]),
        size=np.asarray(size, np.float64),
        yaw=math.atan2(front[0], front[2]),
    )


# ------------------------------------------------------------------------------------------ measures
def _area(polygon: np.ndarray) -> float:
    """Signed shoelace area (positive counter-clockwise in (x, z))."""
    x, y = polygon[:, 0], polygon[:, 1]
    return float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2


def _clip(polygon: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """The part of ``polygon`` left of the directed line ``start → end`` (Sutherland–Hodgman)."""
    edge = end - start
    side = edge[0] * (polygon[:, 1] - start[1]) - edge[1] * (polygon[:, 0] - start[0])
    kept = []
    for k in range(len(polygon)):
        j = (k + 1) % len(polygon)
        if side[k] >= 0:
            kept.append(polygon[k])
        if (side[k] >= 0) != (side[j] >= 0):
            t = side[k] / (side[k] - side[j])
            kept.append(polygon[k] + t * (polygon[j] - polygon[k]))
    return np.array(kept).reshape(-1, 2)


def footprint_intersection(a: np.ndarray, b: np.ndarray) -> float:
    """Area shared by two convex counter-clockwise polygons."""
    inside = a
    for k in range(len(b)):
        if not len(inside):
            return 0.0
        inside = _clip(inside, b[k], b[(k + 1) % len(b)])
    return abs(_area(inside)) if len(inside) >= 3 else 0.0


def box_iou_3d(a: LevelBox, b: LevelBox) -> float:
    """IoU of two gravity-aligned boxes: footprint intersection × vertical overlap over the union."""
    (a0, a1), (b0, b1) = a.vertical(), b.vertical()
    shared = footprint_intersection(a.footprint(), b.footprint()) * max(0.0, min(a1, b1) - max(a0, b0))
    union = float(np.prod(a.size) + np.prod(b.size)) - shared
    return shared / union if union > 0 else 0.0


def footprint_iou(a: LevelBox, b: LevelBox) -> float:
    """IoU of two boxes' footprints on the floor plane (a room layout's ceiling may be unknown)."""
    shared = footprint_intersection(a.footprint(), b.footprint())
    union = float(a.size[0] * a.size[2] + b.size[0] * b.size[2]) - shared
    return shared / union if union > 0 else 0.0


def size_error(fitted: LevelBox, reference: LevelBox) -> float:
    """Mean relative error of the height and of the footprint's long and short sides (sides sorted: a box
    turned by 90° is a yaw error, not a size error)."""

    def sides(box: LevelBox) -> np.ndarray:
        return np.array([*sorted((box.size[0], box.size[2])), box.size[1]])

    truth = sides(reference)
    return float(np.mean(np.abs(sides(fitted) - truth) / truth))


def yaw_error(fitted: LevelBox, reference: LevelBox, period: float = 2 * math.pi) -> float:
    """Degrees between the fronts, modulo ``period`` (the fitted model's rotational symmetry, radians)."""
    delta = (fitted.yaw - reference.yaw) % period
    return math.degrees(min(delta, period - delta))


def pair_scores(fitted: LevelBox, reference: LevelBox, period: float) -> dict[str, float]:
    """3D IoU, centre error (m), relative size error and yaw error (degrees) of a matched pair."""
    return {
        "iou": box_iou_3d(fitted, reference),
        "centre": float(np.linalg.norm(fitted.center - reference.center)),
        "size": size_error(fitted, reference),
        "yaw": yaw_error(fitted, reference, period),
    }


def camera_errors(camera_to_world: np.ndarray, reference: ReferenceScene) -> dict[str, float]:
    """Fitted minus reference pitch and roll, degrees."""
    _, pitch, roll = camera_angles(camera_to_world)
    return {"pitch": math.degrees(pitch - reference.pitch), "roll": math.degrees(roll - reference.roll)}


# ------------------------------------------------------------------------------------------ one photo
def scene_scores(
    reference: ReferenceScene,
    *,
    references: list[tuple[str, np.ndarray]],
    pairs: list[tuple[int, int]],
    fitted: list[Placement],
    symmetry: Callable[[ObjectMesh], float],
    room: RoomBox,
) -> dict[str, Any]:
    """A photo's 3D row: ``references``: the (class, photo-pixel box) the 2D recall counts, as
    ``detections.json`` has them; ``pairs``: its (reference, fitted) matches; ``fitted``: the seen placements
    ``pairs`` index; ``symmetry``: a mesh's rotational symmetry about the vertical (radians, 2π: none);
    ``room``: the fitted room box, whose ``camera_to_world`` poses everything fitted."""
    c2w = np.asarray(room.camera_to_world)
    boxes = [reference.box_of(name, box) for name, box in references]
    scored = []
    for r, b in pairs:
        truth = boxes[r]
        if truth is not None:
            placement = InstanceBox.of_placement(fitted[b], 0)
            box = world_box(placement.center, placement.size, placement.yaw, c2w)
            scored.append({"class": references[r][0], **pair_scores(box, truth, symmetry(fitted[b].mesh))})
    layout = world_box(room.center, 2 * np.asarray(room.half_size), room.yaw, c2w)
    return {
        "references": sum(b is not None for b in boxes),
        "pairs": scored,
        "layout_iou": box_iou_3d(layout, reference.layout),
        "layout_floor_iou": footprint_iou(layout, reference.layout),
        "height": layout.vertical()[1] - reference.layout.vertical()[1],
        **camera_errors(c2w, reference),
    }


# ------------------------------------------------------------------------------------------ table
IOU_3D = 0.25
"""3D IoU at which a matched pair counts as found (SUN RGB-D 3D detection's usual mAP@0.25 threshold)."""


def _line(name: str, pairs: list[dict[str, float]], references: int, scene: list[str]) -> str:
    """A table line: the matched pairs' columns, then the scene's (already formatted)."""

    def median(key: str, fmt: str, width: int) -> str:
        values = [p[key] for p in pairs]
        return format(float(np.median(values)), fmt).rjust(width) if values else "-".rjust(width)

    found = sum(p["iou"] >= IOU_3D for p in pairs)
    mean_iou = format(float(np.mean([p["iou"] for p in pairs])), ".3f") if pairs else "-"
    return (
        f"{name:<24} {f'{len(pairs)}/{references}':>7} {f'{found}/{references}':>7} {mean_iou:>6} "
        f"{median('centre', '.2f', 8)} {median('size', '.2f', 6)} {median('yaw', '.0f', 6)} " + " ".join(scene)
    )


def format_table(rows: list[dict[str, Any]]) -> str:
    """One line per photo with a 3D reference (``row["boxes3d"]``: :func:`scene_scores`), then all together."""
    header = (
        f"{'photo':<24} {'matched':>7} {'IoU≥.25':>7} {'IoU3D':>6} {'centre m':>8} {'size':>6} {'yaw°':>6} "
        f"{'room 3D':>7} {'floor':>6} {'cam h m':>7} {'pitch°':>7} {'roll°':>7}"
    )
    lines = [header, "-" * len(header)]
    named = [(r["photo"], r["boxes3d"]) for r in rows if "boxes3d" in r]
    judged = [s for _, s in named]
    for photo, s in named:
        scene = [
            f"{s['layout_iou']:7.3f}",
            f"{s['layout_floor_iou']:6.3f}",
            f"{s['height']:+7.2f}",
            f"{s['pitch']:+7.1f}",
            f"{s['roll']:+7.1f}",
        ]
        lines.append(_line(photo, s["pairs"], s["references"], scene))
    lines.append("-" * len(header))
    if judged:
        total = [
            f"{np.median([s['layout_iou'] for s in judged]):7.3f}",
            f"{np.median([s['layout_floor_iou'] for s in judged]):6.3f}",
            f"{np.median([abs(s['height']) for s in judged]):7.2f}",
            f"{np.median([abs(s['pitch']) for s in judged]):7.1f}",
            f"{np.median([abs(s['roll']) for s in judged]):7.1f}",
        ]
        pairs = [p for s in judged for p in s["pairs"]]
        lines.append(_line(f"total ({len(judged)} photos)", pairs, sum(s["references"] for s in judged), total))
    lines.append(
        "(references with a 3D box, matched as the 2D recall matches (box IoU >= 0.5 and category); IoU≥.25: "
        "matched pairs whose 3D IoU reaches 0.25; IoU3D: mean 3D IoU of the matched pairs; centre, size, yaw: "
        "medians of the centre distance, the relative size error and the yaw error (modulo the fitted model's "
        "rotational symmetry); room 3D, floor: 3D and floor-plan IoU of the final room box and the reference layout; "
        "cam h, pitch, roll: the camera's height above the floor, pitch and roll, fitted minus reference. Total: "
        "all pairs together, medians of the photos' room IoUs and |camera errors|. Boxes gravity-aligned, each "
        "scene in its own camera's level frame)"
    )
    return "\n".join(lines)
