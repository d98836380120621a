"""The method's stages, one module per paper section, registered as the built-in ``core`` plugin."""

from __future__ import annotations

from ..hookspecs import hookimpl
from ..plugins import Registry
from . import appearance, export, lighting, materials, objects, preprocess, room, settings
from ..crops import CROPS_SUFFIX
from ..room_box import RoomInitParams
from ..settings import NoSettings


@hookimpl
def register_stages(registry: Registry) -> None:
    """The stages of the paper's pipeline; ``conf/stage/*.yaml`` places them in the DAG."""
    registry.add_stage("load_image", preprocess.load_image, reads_photo=True, params=settings.LoadImage)
    registry.add_stage("estimate_fov", preprocess.estimate_fov, uses=["fov"], params=NoSettings)
    registry.add_stage("detect", preprocess.detect, uses=["detector"], params=NoSettings)
    registry.add_stage("segment", preprocess.segment, uses=["segmentation"], version="2", params=NoSettings)
    registry.add_stage("estimate_depth", preprocess.estimate_depth, uses=["depth"], version="2", params=NoSettings)
    registry.add_stage("point_cloud", preprocess.point_cloud, params=settings.PointCloud)
    registry.add_stage("room_init", room.room_init, version="2", params=RoomInitParams)
    registry.add_stage("room_fit", room.room_fit, uses=["renderer", "optimizer"], version="2",
                       params=settings.RoomFit)
    registry.add_stage("retrieve_objects", objects.retrieve_objects, uses=["retrieval"], version="2",
                       params=settings.RetrieveObjects)
    registry.add_stage("place_objects", objects.place_objects, uses=["retrieval"], version="2",
                       params=settings.PlaceObjects)
    registry.add_stage("fit_objects", objects.fit_objects, uses=["renderer", "optimizer"], version="2",
                       params=settings.FitObjects)
    registry.add_stage("assign_materials", materials.assign_materials, uses=["renderer", "material_graph", "texture"],
                       sidecars=[CROPS_SUFFIX], version="3", params=settings.AssignMaterials)
    registry.add_stage("init_lights", lighting.init_lights, uses=["renderer", "material_graph", "denoiser"], version="3",
                       params=settings.InitLights)
    registry.add_stage("fit_appearance", appearance.fit_appearance,
                       uses=["renderer", "optimizer", "material_graph", "texture", "denoiser"], version="5",
                       params=settings.FitAppearance)
    registry.add_stage("export_scene", export.export_scene, uses=["material_graph"], version="4",
                       params=settings.ExportScene)
