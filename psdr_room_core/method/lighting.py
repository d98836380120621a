"""Light layout of §4.4: a grid of ceiling panels outside the camera's view, a large panel behind the camera,
a window panel on every wall the photo does not show, visible windows as framed emissive panels.

Every light is a mesh that emits on the side its triangles face counter-clockwise; quads are built facing
into the room. Geometry only: which lamp parts emit and how bright everything is are decided by the
``init_lights`` stage.
"""

from __future__ import annotations

import numpy as np

from .artifacts import Camera, Light, RoomBox
from .geometry import TriangleMesh, box_mesh, quad_mesh


def shrink(quad: np.ndarray, ratio: float) -> np.ndarray:
    """A quad scaled by ``ratio`` about its centre (corner order kept)."""
    centre = quad.mean(axis=0)
    return centre + (quad - centre) * ratio


def offset(quad: np.ndarray, distance: float) -> np.ndarray:
    """A quad moved ``distance`` along the side it faces (counter-clockwise)."""
    normal = np.cross(quad[1] - quad[0], quad[2] - quad[0])
    return quad + normal / np.linalg.norm(normal) * distance


def grid_cells(quad: np.ndarray, rows: int, cols: int) -> list[np.ndarray]:
    """The quad split into ``rows`` × ``cols`` cells, each in the quad's corner order."""
    a, b, d = quad[0], quad[1], quad[3]
    u, v = (b - a) / cols, (d - a) / rows
    return [
        np.array([a + i * u + j * v, a + (i + 1) * u + j * v, a + (i + 1) * u + (j + 1) * v, a + i * u + (j + 1) * v])
        for j in range(rows)
        for i in range(cols)
    ]


def camera_points(points: np.ndarray, camera_to_world: np.ndarray) -> np.ndarray:
    """World points in OpenCV camera coordinates."""
    c2w = np.asarray(camera_to_world, dtype=np.float64)
    return (np.asarray(points, dtype=np.float64) - c2w[:3, 3]) @ c2w[:3, :3]


def in_view(quad: np.ndarray, camera: Camera, camera_to_world: np.ndarray, samples: int = 9) -> bool:
    """Whether any point of the quad (a ``samples``² grid over it, edges included) is in front of the
    camera and inside the image: the quad intersects the view frustum."""
    s = np.linspace(0.0, 1.0, samples)
    su, sv = np.meshgrid(s, s)
    a, b, d = quad[0], quad[1], quad[3]
    points = a + su.reshape(-1, 1) * (b - a) + sv.reshape(-1, 1) * (d - a)
    local = camera_points(points, camera_to_world)
    front = local[:, 2] > 1e-6
    x = camera.fx * local[front, 0] / local[front, 2] + camera.cx
    y = camera.fy * local[front, 1] / local[front, 2] + camera.cy
    return bool(np.any((x >= 0) & (x <= camera.width) & (y >= 0) & (y <= camera.height)))


def behind_camera(quad: np.ndarray, camera_to_world: np.ndarray) -> bool:
    """Whether every corner of the quad is behind the camera's image plane."""
    return bool(np.all(camera_points(quad, camera_to_world)[:, 2] <= 0.0))


def ceiling_lights(
    ceiling: np.ndarray, camera: Camera, camera_to_world: np.ndarray, rows: int, cols: int, ratio: float, drop: float
) -> list[Light]:
    """§4.4: the ceiling split into a grid, each cell scaled by ``ratio`` and lowered by ``drop`` metres;
    cells in the camera's view or wholly behind it are removed."""
    lights = []
    for k, cell in enumerate(grid_cells(ceiling, rows, cols)):
        quad = offset(shrink(cell, ratio), drop)
        if in_view(quad, camera, camera_to_world) or behind_camera(quad, camera_to_world):
            continue
        lights.append(Light(f"light_ceiling_{k}", "ceiling", quad_mesh(quad)))
    return lights


def behind_camera_light(room: RoomBox, quads: dict[str, np.ndarray], ratio: float) -> Light:
    """One large panel behind the camera, facing the way it looks: parallel to the wall its back faces,
    ``ratio`` of that wall's size, halfway between the camera and the wall."""
    c2w = np.asarray(room.camera_to_world, dtype=np.float64)
    origin, forward = c2w[:3, 3], c2w[:3, 2]
    walls = {n: q for n, q in quads.items() if n.startswith("wall")}

    def facing(quad: np.ndarray) -> float:  # how squarely the wall's inward normal looks along the camera
        normal = np.cross(quad[1] - quad[0], quad[2] - quad[0])
        return float(np.dot(normal / np.linalg.norm(normal), forward))

    name = max(walls, key=lambda n: facing(walls[n]))
    wall = walls[name]
    normal = np.cross(wall[1] - wall[0], wall[2] - wall[0])
    normal /= np.linalg.norm(normal)
    distance = float(np.dot(origin - wall[0], normal))
    panel = shrink(wall, ratio) + normal * max(0.5 * distance, 0.01)
    return Light("light_behind_camera", "behind_camera", quad_mesh(panel))


def wall_window_light(name: str, wall: np.ndarray, ratio: float, drop: float) -> Light:
    """A window-sized panel (``ratio`` of the wall) at the centre of a wall the photo does not show."""
    return Light(f"light_{name}", "invisible_wall", quad_mesh(offset(shrink(wall, ratio), drop)))


def window_panel(
    mask: np.ndarray, wall: np.ndarray, camera: Camera, camera_to_world: np.ndarray, drop: float, frame_width: float
) -> tuple[np.ndarray, list[TriangleMesh]] | None:
    """A visible window as a panel on its wall: the mask's bounding box back-projected onto the wall plane,
    moved ``drop`` into the room, and a frame of four bars ``frame_width`` wide around it; None when the
    box's rays miss the wall plane."""
    ys, xs = np.nonzero(mask)
    if not len(xs):
        return None
    scale = camera.width / mask.shape[1]
    x0, x1, y0, y1 = xs.min() * scale, (xs.max() + 1) * scale, ys.min() * scale, (ys.max() + 1) * scale
    c2w = np.asarray(camera_to_world, dtype=np.float64)
    origin = c2w[:3, 3]
    normal = np.cross(wall[1] - wall[0], wall[2] - wall[0])
    normal /= np.linalg.norm(normal)
    corners = []
    for x, y in ((x0, y1), (x1, y1), (x1, y0), (x0, y0)):
        ray = c2w[:3, :3] @ np.array([(x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0])
        denom = float(np.dot(ray, normal))
        if abs(denom) < 1e-9:
            return None
        t = float(np.dot(wall[0] - origin, normal)) / denom
        if t <= 0:
            return None
        corners.append(origin + t * ray)
    quad = np.array(corners)
    if np.dot(np.cross(quad[1] - quad[0], quad[2] - quad[0]), normal) < 0:
        quad = quad[::-1]
    quad = quad + normal * drop
    bars = []
    for i in range(4):
        a, b = quad[i], quad[(i + 1) % 4]
        centre = 0.5 * (a + b) + normal * frame_width * 0.5
        along = (b - a) / max(np.linalg.norm(b - a), 1e-9)
        side = np.cross(normal, along)
        rotation = np.stack([along, side, normal], axis=1)
        half = np.array([0.5 * np.linalg.norm(b - a) + frame_width, 0.5 * frame_width, 0.5 * frame_width])
        bars.append(box_mesh(centre, half, rotation))
    return quad, bars
