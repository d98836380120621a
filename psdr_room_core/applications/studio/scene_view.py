"""The studio's 3D view: a run's artifacts as viser scene nodes.

Nodes (world frame of the room box: metres, floor at ``y = 0``, +y up):
``/photo`` the photo's camera, ``/photo_plane`` the photo on its image plane (hidden unless asked for or drawn on:
it stands in front of what the photo became), ``/room`` the room box's edges,
``/objects/<segment id>`` each placed model (the fitted pose when ``fit_objects`` ran), ``/cloud`` the
segmented point cloud, ``/scene`` the exported glTF scene with its fitted materials and emissive light panels (full
runs; the viewer's own lights stand in for the glb's photometric ones, which it would wash out).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import viser
import viser.transforms as vtf

from psdr_room_core.engine.records import first_artifact
from psdr_room_core.method.artifacts import Camera, Image, Placements, PointCloud, RoomBox, rotation_y
from psdr_room_core.method.gltf import without_lights

MAX_POINTS = 60_000
"""Point-cloud points sent to the browser (a random subset beyond this)."""


def wxyz(rotation: np.ndarray) -> np.ndarray:
    """A rotation matrix as viser's (w, x, y, z) quaternion."""
    return vtf.SO3.from_matrix(np.asarray(rotation, dtype=np.float64)).wxyz


def box_edges(room: RoomBox) -> np.ndarray:
    """The room box's 12 edges as (12, 2, 3) world segments."""
    corners = room.corners()
    pairs = [(i, i | bit) for bit in (1, 2, 4) for i in range(8) if not i & bit]
    return np.array([[corners[a], corners[b]] for a, b in pairs])


class SceneView:
    """Draws a run's artifacts into a viser server, replacing what it drew before."""

    def __init__(self, server: viser.ViserServer) -> None:
        self.server = server
        self.nodes: dict[str, Any] = {}
        self.plane_visible = False
        server.scene.set_up_direction("+y")

    def clear(self) -> None:
        for handle in self.nodes.values():
            handle.remove()
        self.nodes = {}

    def show(self, artifacts: dict[str, Any], scene_dir: Path | None) -> None:
        """Draw ``artifacts`` (a run's, by name); ``scene_dir``: the exported ``scene/`` folder, if the run
        reached ``export_scene``."""
        self.clear()
        image = first_artifact(artifacts, "image", Image)
        camera = first_artifact(artifacts, ("camera_fit", "camera"), Camera)
        room = first_artifact(artifacts, ("room_box_objects", "room_box_fit", "room_box"), RoomBox)
        if image is None or camera is None or room is None:
            return
        c2w = np.asarray(room.camera_to_world, dtype=np.float64)
        scene = self.server.scene

        def frustum(name: str, **extra: Any) -> Any:
            return scene.add_camera_frustum(
                name,
                fov=math.radians(camera.vfov_deg),
                aspect=camera.width / camera.height,
                scale=0.3,
                wxyz=wxyz(c2w[:3, :3]),
                position=c2w[:3, 3],
                color=(240, 120, 20),
                thickness=0.006,
                **extra,
            )

        self.nodes["/photo"] = frustum("/photo")
        self.nodes["/photo_plane"] = frustum("/photo_plane", image=image.to_uint8(), visible=self.plane_visible)
        self.nodes["/room"] = scene.add_line_segments("/room", box_edges(room), colors=(40, 40, 40), thickness=0.015)
        cloud = first_artifact(artifacts, "point_cloud", PointCloud)
        if cloud is not None and len(cloud.points):
            keep = np.random.default_rng(0).permutation(len(cloud.points))[:MAX_POINTS]
            points = cloud.points[keep] @ c2w[:3, :3].T + c2w[:3, 3]
            self.nodes["/cloud"] = scene.add_point_cloud(
                "/cloud", points.astype(np.float32), np.asarray(cloud.colors, np.uint8)[keep], point_size=0.008
            )
        glb = scene_dir / "scene.glb" if scene_dir is not None else None
        if glb is not None and glb.is_file():
            self.show_scene(glb)
        placements = first_artifact(artifacts, ("placements_fit", "placements"), Placements)
        for placement in placements.objects if placements is not None else []:
            name = f"/objects/{placement.segment_id}"
            colors = np.asarray(placement.mesh.colors, dtype=np.float64).reshape(-1, 3)
            red, green, blue = (
                int(c) for c in np.clip(colors.mean(axis=0) if len(colors) else (0.6, 0.6, 0.6), 0, 1) * 255
            )
            self.nodes[name] = scene.add_mesh_simple(
                name,
                placement.world_vertices().astype(np.float32),
                np.asarray(placement.mesh.faces, np.int32),
                color=(red, green, blue),
                flat_shading=True,
            )

    def photo_plane(self, visible: bool) -> None:
        """Show or hide the photo on its camera's image plane."""
        self.plane_visible = visible
        if "/photo_plane" in self.nodes:
            self.nodes["/photo_plane"].visible = visible

    def exported(self, visible: bool) -> None:
        """Show the exported scene (``visible``) or, in its place, the placed objects and the point cloud."""
        if "/scene" not in self.nodes:
            return
        self.nodes["/scene"].visible = visible
        for name, handle in self.nodes.items():
            if name.startswith("/objects/") or name == "/cloud":
                handle.visible = not visible

    def show_scene(self, glb: Path) -> None:
        """Show the exported (or edited) scene ``glb`` as ``/scene``, in place of the one shown."""
        if "/scene" in self.nodes:
            self.nodes.pop("/scene").remove()
        self.nodes["/scene"] = self.server.scene.add_glb("/scene", without_lights(glb.read_bytes()))

    def photo_view(self, client: viser.ClientHandle, artifacts: dict[str, Any]) -> None:
        """Put ``client``'s view at the photo's camera (where a box dragged on the canvas is a box on the photo)."""
        camera = first_artifact(artifacts, ("camera_fit", "camera"), Camera)
        room = first_artifact(artifacts, ("room_box_objects", "room_box_fit", "room_box"), RoomBox)
        if camera is None or room is None:
            return
        c2w = np.asarray(room.camera_to_world, dtype=np.float64)
        with client.atomic():
            client.camera.fov = math.radians(camera.vfov_deg)
            client.camera.wxyz = wxyz(c2w[:3, :3])
            client.camera.position = c2w[:3, 3]
            client.camera.look_at = c2w[:3, 3] + c2w[:3, 2]
            client.camera.up_direction = -c2w[:3, 1]


def overview(client: viser.ClientHandle, artifacts: dict[str, Any]) -> None:
    """Put ``client``'s view inside the room, above and behind the photo's camera, looking down at the placed objects
    (at the room's middle when there are none), wide enough to hold them all: the camera's frustum and the scene it
    became, together."""
    room = first_artifact(artifacts, ("room_box_objects", "room_box_fit", "room_box"), RoomBox)
    if room is None:
        return
    c2w = np.asarray(room.camera_to_world, dtype=np.float64)
    forward = c2w[:3, 2] * np.array([1.0, 0.0, 1.0])
    forward /= max(float(np.linalg.norm(forward)), 1e-9)
    placements = first_artifact(artifacts, ("placements_fit", "placements"), Placements)
    placed = [p.world_vertices() for p in (placements.objects if placements is not None else [])]
    target = np.concatenate(placed).mean(axis=0) if placed else np.asarray(room.center, dtype=np.float64)
    eye = c2w[:3, 3] - 0.8 * forward + np.array([0.0, 0.6, 0.0])
    turn = rotation_y(room.yaw)  # keep the eye inside the box: its walls would hide the scene from outside
    margin = np.minimum(0.1, 0.5 * np.asarray(room.half_size))
    local = np.clip(turn.T @ (eye - room.center), -(room.half_size - margin), room.half_size - margin)
    eye = room.center + turn @ local
    with client.atomic():
        client.camera.position = eye
        client.camera.look_at = target
        client.camera.up_direction = (0.0, 1.0, 0.0)
        client.camera.fov = math.radians(_framing_fov(eye, target, [v.mean(axis=0) for v in placed]))


def _framing_fov(eye: np.ndarray, target: np.ndarray, centres: list[np.ndarray], least: float = 75.0) -> float:
    """A vertical FoV (degrees) from ``eye`` looking at ``target`` that holds every object centre with 5° to
    spare: ``least``, widened for objects off to the side, at most 120°."""
    view = (target - eye) / max(float(np.linalg.norm(target - eye)), 1e-9)
    widest = 0.0
    for centre in centres:
        towards = centre - eye
        cosine = float(towards @ view) / max(float(np.linalg.norm(towards)), 1e-9)
        widest = max(widest, math.degrees(math.acos(min(1.0, max(-1.0, cosine)))))
    return min(120.0, max(least, 2.0 * (widest + 5.0)))


def screen_to_photo(
    client_camera: Any, screen: tuple[float, float], camera: Camera, camera_to_world: np.ndarray
) -> tuple[float, float] | None:
    """Where on the working image the photo is seen at ``screen`` (viser's 0..1 canvas coordinates, OpenCV axes) by a
    browser camera at the photo's centre of projection, in box coordinates (pixel ``i`` spans ``[i, i + 1)``);
    None when that direction is behind the photo's camera."""
    half = math.tan(float(client_camera.fov) / 2.0)
    local = np.array(
        [(screen[0] - 0.5) * 2.0 * half * float(client_camera.aspect), (screen[1] - 0.5) * 2.0 * half, 1.0]
    )
    world = vtf.SO3(np.asarray(client_camera.wxyz, dtype=np.float64)).as_matrix() @ local
    ray = np.asarray(camera_to_world, dtype=np.float64)[:3, :3].T @ world
    if ray[2] <= 1e-9:
        return None
    return camera.fx * ray[0] / ray[2] + camera.cx + 0.5, camera.fy * ray[1] / ray[2] + camera.cy + 0.5
