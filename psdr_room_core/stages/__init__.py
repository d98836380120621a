"""The method's stages, one module per paper section, registered as the built-in ``core`` plugin."""

from __future__ import annotations

from ..hookspecs import hookimpl
from ..plugins import Registry
from . import appearance, export, lighting, materials, objects, preprocess, room
from ..crops import CROPS_SUFFIX


@hookimpl
def register_stages(registry: Registry) -> None:
    """The stages of the paper's pipeline; ``conf/stage/*.yaml`` places them in the DAG."""
    registry.add_stage("load_image", preprocess.load_image, reads_photo=True)
    registry.add_stage("estimate_fov", preprocess.estimate_fov, uses=["fov"])
    registry.add_stage("detect", preprocess.detect, uses=["detector"])
    registry.add_stage("segment", preprocess.segment, uses=["segmentation"], version="2")
    registry.add_stage("estimate_depth", preprocess.estimate_depth, uses=["depth"], version="2")
    registry.add_stage("point_cloud", preprocess.point_cloud)
    registry.add_stage("room_init", room.room_init, version="2")
    registry.add_stage("room_fit", room.room_fit, uses=["renderer", "optimizer"], version="2")
    registry.add_stage("retrieve_objects", objects.retrieve_objects, uses=["retrieval"], version="2")
    registry.add_stage("place_objects", objects.place_objects, uses=["retrieval"], version="2")
    registry.add_stage("fit_objects", objects.fit_objects, uses=["renderer", "optimizer"], version="2")
    registry.add_stage("assign_materials", materials.assign_materials, uses=["renderer", "material_graph", "texture"],
                       sidecars=[CROPS_SUFFIX], version="3")
    registry.add_stage("init_lights", lighting.init_lights, uses=["renderer", "material_graph", "denoiser"], version="3")
    registry.add_stage("fit_appearance", appearance.fit_appearance,
                       uses=["renderer", "optimizer", "material_graph", "texture", "denoiser"], version="4")
    registry.add_stage("export_scene", export.export_scene, uses=["material_graph"], version="4")
