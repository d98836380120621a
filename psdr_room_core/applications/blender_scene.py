"""Runs inside Blender (``blender -b --python blender_scene.py -- ...``, started by ``psdr-room-blender``): builds
an exported scene folder as a Blender scene ready to render, and saves it.

It imports ``scene.glb`` (geometry, named parts, Principled BSDFs with the fitted colour, roughness, specular
and maps; ``import_shading='SMOOTH'``, the path of Blender 3.4's importer that works with Debian's numpy), then
makes what the glb cannot say:

* flat shading, as Mitsuba renders the exported meshes (face normals);
* the photo's camera as the scene camera, at the photo's resolution and principal point;
* each light an area light (a point light for a lamp's non-planar mesh) of the emitter's fitted radiance,
  replacing the glb's spot stand-ins, 1 mm in front of a flat panel; the emissive panel stays visible to the
  camera but lights nothing, so Cycles and EEVEE are lit by the same lights and nothing is counted twice; a
  flat panel still casts shadows, as Mitsuba's black emitter does (a wall's light behind the panel behind the
  camera stays hidden, as it was in the fit);
* Cycles' path length from the scene's Mitsuba ``max_depth``, colour management ``Standard`` (the renders are
  the linear scene in sRGB, as psdr-room's), a black world.

Only Blender's own Python and the standard library are used here: Blender runs its own interpreter.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

import bpy  # type: ignore[import-not-found]
from mathutils import Matrix, Vector  # type: ignore[import-not-found]

AREA_LIGHT_WATTS = 4.0
"""Blender watts of an area light per unit of radiance and square metre. A Lambertian emitter of radiance L and
area A emits pi L A watts, but Cycles' area light of P watts has radiance P / (4 A): measured here, a 1 m^2 light
of 4 W lights a floor 2 m below as an emissive mesh of strength 1 does (pi W gives pi / 4 of it)."""
POINT_LIGHT_WATTS = 4.0 * math.pi
"""Blender watts of a point light per unit of radiant intensity (W/sr): the lamp's mesh, of radiance L and area A,
emits pi L A over the sphere, L A / 4 per steradian."""
PLANAR = 0.99
"""An emitter whose area-weighted mean normal is at least this long (of 1) is flat: an area light."""
LIGHT_OFFSET = 1e-3
"""Metres an area light sits in front of its panel, so that the panel, which casts shadows, does not shadow it."""


def parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="blender_scene.py")
    parser.add_argument("scene", type=Path)
    parser.add_argument("--blend", type=Path, required=True)
    parser.add_argument("--render", type=Path, help="also render the scene camera's view to this PNG")
    parser.add_argument("--engine", choices=("cycles", "eevee"), default="cycles")
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--width", type=int, help="render width (the photo's when absent; the aspect is kept)")
    return parser.parse_args(argv)


def emitter_frame(obj: bpy.types.Object) -> tuple[Vector, Vector, float, list[Vector]]:
    """World centre, emitting direction, area and vertices of an emissive mesh object."""
    world = obj.matrix_world
    vertices = [world @ v.co for v in obj.data.vertices]
    total, centre, normal = 0.0, Vector((0.0, 0.0, 0.0)), Vector((0.0, 0.0, 0.0))
    for polygon in obj.data.polygons:
        corners = [vertices[i] for i in polygon.vertices]
        for k in range(1, len(corners) - 1):
            cross = (corners[k] - corners[0]).cross(corners[k + 1] - corners[0])
            area = cross.length / 2
            total += area
            centre += area * (corners[0] + corners[k] + corners[k + 1]) / 3
            normal += cross / 2
    return centre / max(total, 1e-12), normal / max(total, 1e-12), total, vertices


def add_light(scene: bpy.types.Scene, panel: bpy.types.Object, radiance: list[float]) -> bpy.types.Object:
    """The Blender light standing for an emissive panel of ``radiance`` (linear RGB)."""
    centre, mean_normal, area, vertices = emitter_frame(panel)
    strength = max(max(radiance), 1e-9)
    flat = mean_normal.length >= PLANAR
    if flat:
        normal = mean_normal.normalized()
        rotation, width, height = min(
            (
                _rectangle(vertices, centre, normal, v - vertices[0])
                for v in vertices[1:]
                if (v - vertices[0]).cross(normal).length > 1e-9
            ),
            key=lambda r: r[1] * r[2],
        )
        light = bpy.data.lights.new(f"{panel.name}_light", type="AREA")
        light.shape = "RECTANGLE"
        light.size, light.size_y = max(width, 1e-4), max(height, 1e-4)
        light.energy = AREA_LIGHT_WATTS * strength * area
        matrix = rotation.to_4x4()
        centre = centre + LIGHT_OFFSET * normal
    else:
        light = bpy.data.lights.new(f"{panel.name}_light", type="POINT")
        light.shadow_soft_size = math.sqrt(area / (4 * math.pi))
        light.energy = POINT_LIGHT_WATTS * strength * area / 4
        matrix = Matrix.Identity(4)
    light.color = [c / strength for c in radiance]
    obj = bpy.data.objects.new(light.name, light)
    matrix.translation = centre
    obj.matrix_world = matrix
    scene.collection.objects.link(obj)
    return obj


def _rectangle(vertices: list[Vector], centre: Vector, normal: Vector, edge: Vector) -> tuple[Matrix, float, float]:
    """The light's rotation (local -Z along ``normal``, X along ``edge``) and the panel's extents in that frame."""
    x_axis = (edge - edge.dot(normal) * normal).normalized()
    z_axis = -normal  # an area light emits along its local -Z
    rotation = Matrix((x_axis, z_axis.cross(x_axis), z_axis)).transposed()
    local = [rotation.transposed() @ (v - centre) for v in vertices]
    return (
        rotation,
        max(p.x for p in local) - min(p.x for p in local),
        max(p.y for p in local) - min(p.y for p in local),
    )


def camera_only(panel: bpy.types.Object, flat: bool) -> None:
    """The panel is seen by the camera (a lit window, a lamp's shade) and lights nothing: its light does. A flat
    panel still blocks light behind it, as in Mitsuba; a lamp's shade does not, since its point light is inside."""
    rays = ("visible_diffuse", "visible_glossy", "visible_transmission", "visible_volume_scatter")
    for ray in (*rays, *(() if flat else ("visible_shadow",))):
        setattr(panel, ray, False)
    for slot in panel.material_slots:
        if slot.material is not None and hasattr(slot.material.cycles, "sample_as_light"):
            slot.material.cycles.sample_as_light = False


def setup_camera(scene: bpy.types.Scene, state: dict, width: int | None) -> None:
    """The glb's camera as the scene camera: the photo's vertical FoV, resolution and principal point."""
    camera = next(o for o in scene.objects if o.type == "CAMERA")
    scene.camera = camera
    intrinsics = state["camera"]
    w, h = int(intrinsics["width"]), int(intrinsics["height"])
    scene.render.resolution_x = width or w
    scene.render.resolution_y = round((width or w) * h / w)
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = 1.0
    scene.render.pixel_aspect_y = float(intrinsics["fx"]) / float(intrinsics["fy"])
    data = camera.data
    data.sensor_fit = "VERTICAL"
    data.angle_y = 2 * math.atan(h / (2 * float(intrinsics["fy"])))
    data.shift_x = (w / 2 - float(intrinsics["cx"])) / max(w, h)
    data.shift_y = (float(intrinsics["cy"]) - h / 2) / max(w, h)
    data.clip_start = 0.01


def setup_render(scene: bpy.types.Scene, max_depth: int, spp: int) -> None:
    """Colour management, world, and both engines' settings."""
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.display_settings.display_device = "sRGB"
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bounces = max(max_depth - 2, 0)  # Mitsuba's max_depth counts the camera ray and the emitter hit
    cycles = scene.cycles
    cycles.samples = spp
    cycles.max_bounces = cycles.diffuse_bounces = cycles.glossy_bounces = bounces
    cycles.transparent_max_bounces = cycles.transmission_bounces = bounces
    cycles.use_denoising = False
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    eevee = scene.eevee
    eevee.taa_render_samples = spp
    eevee.use_soft_shadows = True
    eevee.use_gtao = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"


def main() -> None:
    args = parse(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else [])
    state = json.loads((args.scene / "appearance.json").read_text())
    xml = (args.scene / "scene.xml").read_text()
    depth = re.search(r'<default name="max_depth" value="(\d+)"', xml)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(args.scene / "scene.glb"), import_shading="SMOOTH")
    scene = bpy.context.scene
    for obj in list(scene.objects):
        if obj.type == "LIGHT":  # the glb's spot stand-ins
            bpy.data.objects.remove(obj, do_unlink=True)
        elif obj.type == "MESH":
            for polygon in obj.data.polygons:
                polygon.use_smooth = False
    for light in state["lights"]:
        panel = bpy.data.objects[light["name"]]
        lamp = add_light(scene, panel, light["radiance"])
        camera_only(panel, flat=lamp.data.type == "AREA")
    setup_camera(scene, state, args.width)
    setup_render(scene, int(depth.group(1)) if depth else 3, args.spp)
    scene.render.engine = "CYCLES" if args.engine == "cycles" else "BLENDER_EEVEE"
    args.blend.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(args.blend.resolve()))
    if args.render:
        scene.render.filepath = str(args.render.resolve())
        bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    main()
