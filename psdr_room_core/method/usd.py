"""The reconstructed scene as OpenUSD (``scene.usda``, written with ``usd-core``): what Blender, Houdini, Maya
and Omniverse share.

Metres and Y up are declared on the stage. ``/Scene/Camera`` is the photo's camera (a 36 mm wide aperture;
the focal length, the vertical aperture and the aperture offsets carry the photo's intrinsics and aspect).
Each part is a ``/Scene/Parts/<part>`` mesh (flat: no subdivision; double-sided, as the two-sided BSDFs of the
Mitsuba scene) bound to a ``UsdPreviewSurface`` in ``/Scene/Materials``: the fitted base colour and roughness, as
constants or the baked maps of ``textures/`` read through ``st``, and the fitted specular as the dielectric's IOR
(a principled specular s reflects 0.08 s at normal incidence). A flat emitter is a ``UsdLux`` rect light of the
fitted radiance; a lamp's mesh, which is not flat, is a mesh with ``UsdLux.MeshLightAPI``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .artifacts import Camera
from .gltf import emitter_frame
from .rgb_scene import RgbScene
from .shading import SPECULAR_F0

CV_TO_USD = np.diag([1.0, -1.0, -1.0, 1.0])
"""OpenCV camera axes (x right, y down, z forward) → a USD camera's (x right, y up, looking down −z)."""
APERTURE_MM = 36.0
"""The camera's horizontal aperture (USD: tenths of a scene unit, i.e. millimetres here)."""
FLAT = 0.99
"""An emitter whose area-weighted mean normal is at least this long (of 1) is flat: a rect light."""


def specular_ior(specular: float) -> float:
    """The dielectric IOR whose normal-incidence reflectance is a principled BSDF's ``SPECULAR_F0 · specular``."""
    root = math.sqrt(min(max(SPECULAR_F0 * float(specular), 1e-8), 0.99))
    return (1 + root) / (1 - root)


def scene_usda(
    scene: RgbScene, camera: Camera, camera_to_world: np.ndarray, maps: Mapping[str, Mapping[str, str]]
) -> str:
    """``scene.usda`` of ``scene``; ``maps[part][channel]`` (``base_color``, ``roughness``) are the relative paths
    of the parts' baked maps."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

    stage = Usd.Stage.CreateInMemory("scene.usda")
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/Scene")
    stage.SetDefaultPrim(root.GetPrim())
    UsdGeom.Scope.Define(stage, "/Scene/Parts")
    UsdGeom.Scope.Define(stage, "/Scene/Materials")
    UsdGeom.Scope.Define(stage, "/Scene/Lights")

    usd_camera = UsdGeom.Camera.Define(stage, "/Scene/Camera")
    pose = np.asarray(camera_to_world, dtype=np.float64) @ CV_TO_USD
    usd_camera.AddTransformOp().Set(Gf.Matrix4d(pose.T.tolist()))
    millimetres = APERTURE_MM / camera.width  # per pixel
    usd_camera.CreateFocalLengthAttr(float(camera.fx * millimetres))
    usd_camera.CreateHorizontalApertureAttr(APERTURE_MM)
    usd_camera.CreateVerticalApertureAttr(float(camera.height * camera.fx / camera.fy * millimetres))
    usd_camera.CreateHorizontalApertureOffsetAttr(float((camera.width / 2 - camera.cx) * millimetres))
    usd_camera.CreateVerticalApertureOffsetAttr(
        float((camera.cy - camera.height / 2) * camera.fx / camera.fy * millimetres)
    )
    usd_camera.CreateClippingRangeAttr(Gf.Vec2f(0.01, 10000.0))

    def mesh(path: str, vertices: np.ndarray, faces: np.ndarray) -> UsdGeom.Mesh:
        prim = UsdGeom.Mesh.Define(stage, path)
        prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(vertices, np.float32)))
        prim.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, np.int32)))
        prim.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(faces, np.int32).reshape(-1)))
        prim.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        prim.CreateDoubleSidedAttr(True)
        low, high = np.asarray(vertices).min(axis=0), np.asarray(vertices).max(axis=0)
        prim.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, low)), Gf.Vec3f(*map(float, high))]))
        return prim

    def texture(material: UsdShade.Material, part: str, channel: str, reader: UsdShade.Shader) -> UsdShade.Shader:
        shader = UsdShade.Shader.Define(stage, f"{material.GetPath()}/{channel}_map")
        shader.CreateIdAttr("UsdUVTexture")
        shader.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(maps[part][channel])
        shader.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(
            "sRGB" if channel == "base_color" else "raw"
        )
        shader.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("repeat")
        shader.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("repeat")
        shader.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        return shader

    for name, part_mesh in scene.meshes.items():
        surface = scene.surfaces[name]
        prim = mesh(f"/Scene/Parts/{name}", part_mesh.vertices, part_mesh.faces)
        material = UsdShade.Material.Define(stage, f"/Scene/Materials/{name}")
        preview = UsdShade.Shader.Define(stage, f"/Scene/Materials/{name}/surface")
        preview.CreateIdAttr("UsdPreviewSurface")
        preview.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
        preview.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(specular_ior(surface.specular))
        mapped = maps.get(name, {})
        if mapped:
            uv = np.asarray(surface.uv, np.float64)
            st = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
                "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
            )
            st.Set(Vt.Vec2fArray.FromNumpy(np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float32)))
            reader = UsdShade.Shader.Define(stage, f"/Scene/Materials/{name}/st_reader")
            reader.CreateIdAttr("UsdPrimvarReader_float2")
            reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        colour = preview.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
        if "base_color" in mapped:
            colour.ConnectToSource(texture(material, name, "base_color", reader).ConnectableAPI(), "rgb")
        else:
            colour.Set(Gf.Vec3f(*(float(c) for c in np.asarray(surface.base_color).reshape(-1)[:3])))
        roughness = preview.CreateInput("roughness", Sdf.ValueTypeNames.Float)
        if "roughness" in mapped:
            map_shader = texture(material, name, "roughness", reader)
            map_shader.CreateOutput("r", Sdf.ValueTypeNames.Float)
            roughness.ConnectToSource(map_shader.ConnectableAPI(), "r")
        else:
            roughness.Set(float(np.asarray(surface.roughness).reshape(-1)[0]))
        material.CreateSurfaceOutput().ConnectToSource(preview.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(prim.GetPrim()).Bind(material)

    for name, (light_mesh, radiance) in scene.emitters.items():
        vertices, faces = np.asarray(light_mesh.vertices, np.float64), np.asarray(light_mesh.faces)
        strength = max(max(radiance), 1e-9)
        colour = Gf.Vec3f(*(float(c) / strength for c in radiance))
        _, normal, _, flatness = emitter_frame(vertices, faces)
        if flatness >= FLAT:
            light = UsdLux.RectLight.Define(stage, f"/Scene/Lights/{name}")
            frame, width, height = _rectangle(vertices, normal)
            light.AddTransformOp().Set(Gf.Matrix4d(frame.T.tolist()))
            light.CreateWidthAttr(width)
            light.CreateHeightAttr(height)
        else:
            prim = mesh(f"/Scene/Lights/{name}", vertices, faces)
            UsdLux.MeshLightAPI.Apply(prim.GetPrim())
            light = UsdLux.LightAPI(prim.GetPrim())
        light.CreateIntensityAttr(float(strength))
        light.CreateColorAttr(colour)
        light.CreateNormalizeAttr(False)
    return stage.GetRootLayer().ExportToString()


def _rectangle(vertices: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, float, float]:
    """A rect light's frame (emitting along its −z, x along the panel's side that gives the smallest rectangle)
    and the panel's width and height in it."""
    centre = vertices.mean(axis=0)
    best: tuple[np.ndarray, float, float] | None = None
    for vertex in vertices[1:]:
        edge = vertex - vertices[0]
        edge = edge - (edge @ normal) * normal
        if np.linalg.norm(edge) < 1e-9:
            continue
        x = edge / np.linalg.norm(edge)
        z = -normal
        frame = np.eye(4)
        frame[:3, 0], frame[:3, 1], frame[:3, 2] = x, np.cross(z, x), z
        local = (vertices - centre) @ frame[:3, :3]
        width, height = float(np.ptp(local[:, 0])), float(np.ptp(local[:, 1]))
        if best is None or width * height < best[1] * best[2]:
            frame[:3, 3] = (
                centre
                + frame[:3, :3]
                @ np.array([local[:, 0].max() + local[:, 0].min(), local[:, 1].max() + local[:, 1].min(), 0.0])
                / 2
            )
            best = (frame, width, height)
    assert best is not None, "a flat emitter has two distinct vertices"
    return best
