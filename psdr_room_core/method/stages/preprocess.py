"""Preprocess stage (paper §4.1): the photo, camera intrinsics, depth, segmentation, segmented point cloud.

The estimates come from the selected ``fov``, ``depth`` and ``segmentation`` implementations; the user may
correct any of them and feed the artifact back in (``+inject.<artifact>=DIR``), as the paper allows.
"""

from __future__ import annotations

import cv2
import numpy as np

from psdr_room_core.engine.dag import StageContext
from psdr_room_core.engine.errors import PsdrRoomError

from ..artifacts import ROOM_CATEGORIES, Camera, DepthMap, Detections, Image, Panoptic, PointCloud
from ..capabilities import DepthEstimator, Detector, FovEstimator, Segmenter
from ..photo import read_photo, resize_to_working
from .settings import LoadImage as LoadImageSettings
from .settings import PointCloud as PointCloudSettings


def load_image(ctx: StageContext) -> Image:
    """Read the photo (EXIF-oriented, any bit depth; refused over ``max_pixels`` pixels) and shrink it to the
    working resolution, its long side at most ``max_side`` pixels."""
    settings = ctx.settings(LoadImageSettings)
    rgb = read_photo(ctx.photo, settings.max_pixels)
    height, width = rgb.shape[:2]
    return Image(rgb=resize_to_working(rgb, settings.max_side), source=str(ctx.photo), original_size=(width, height))


def estimate_fov(ctx: StageContext, image: Image) -> Camera:
    """Estimate pinhole intrinsics with the ``fov`` capability."""
    return ctx.impl("fov", FovEstimator).estimate(image, ctx.photo)


def detect(ctx: StageContext, image: Image) -> Detections:
    """Find object boxes (prompts for box-driven segmentation) with the ``detector`` capability."""
    return ctx.impl("detector", Detector).detect(image, ctx.photo)


def segment(ctx: StageContext, image: Image, camera: Camera, detections: Detections) -> Panoptic:
    """Segment the photo with the ``segmentation`` capability (given the camera and the box prompts)."""
    panoptic = ctx.impl("segmentation", Segmenter).segment(image, camera, detections, ctx.photo)
    if panoptic.ids.shape != (image.height, image.width):
        raise PsdrRoomError(
            f"segmentation implementation returned {panoptic.ids.shape}, expected {(image.height, image.width)}"
        )
    return panoptic


def estimate_depth(ctx: StageContext, image: Image, camera: Camera, panoptic: Panoptic) -> DepthMap:
    """Estimate depth at the working resolution with the ``depth`` capability (given the segmentation)."""
    depth = ctx.impl("depth", DepthEstimator).estimate(image, camera, panoptic, ctx.photo)
    if depth.depth.shape != (image.height, image.width):
        raise PsdrRoomError(
            f"depth implementation returned {depth.depth.shape}, expected {(image.height, image.width)}"
        )
    return depth


def backproject(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """Camera-frame points (HxWx3) for a z-depth map at the camera's resolution."""
    return (camera.pixel_rays() * depth[..., None]).astype(np.float32)


def _inlier_mask(points: np.ndarray, neighbours: int, std_ratio: float) -> np.ndarray:
    """Statistical outlier removal (open3d): True for points whose neighbour distances are typical."""
    if len(points) <= neighbours:
        return np.ones(len(points), dtype=bool)
    import open3d as o3d  # heavy (1.5 s): imported when a cloud is computed, not for cached runs

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    _, kept = cloud.remove_statistical_outlier(nb_neighbors=neighbours, std_ratio=std_ratio)
    mask = np.zeros(len(points), dtype=bool)
    mask[np.asarray(kept, dtype=np.int64)] = True
    return mask


def point_cloud(ctx: StageContext, image: Image, camera: Camera, depth: DepthMap, panoptic: Panoptic) -> PointCloud:
    """Back-project the depth with the estimated camera into a point cloud segmented per panoptic segment.

    Room surfaces (wall/floor/ceiling) are eroded by ``erode_px`` first (§4.2: their masks bleed into
    objects at the boundaries); each segment keeps at most ``max_points_per_segment`` points (a fixed
    stride) and loses its statistical outliers (``outlier_neighbours``, ``outlier_std_ratio``).
    """
    settings = ctx.settings(PointCloudSettings)
    erode = settings.erode_px
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * erode + 1, 2 * erode + 1)) if erode > 0 else None
    xyz = backproject(depth.depth, camera)
    colors = image.to_uint8()
    points, rgb, seg = [], [], []
    for segment in panoptic.segments:
        mask = (panoptic.ids == segment.id) & depth.valid
        if kernel is not None and segment.category in ROOM_CATEGORIES:
            mask = cv2.erode(mask.astype(np.uint8), kernel).astype(bool)
        index = np.flatnonzero(mask)
        stride = max(1, int(np.ceil(len(index) / settings.max_points_per_segment)))
        index = index[::stride]
        seg_points = xyz.reshape(-1, 3)[index]
        keep = _inlier_mask(seg_points, settings.outlier_neighbours, settings.outlier_std_ratio)
        points.append(seg_points[keep])
        rgb.append(colors.reshape(-1, 3)[index][keep])
        seg.append(np.full(int(keep.sum()), segment.id, dtype=np.int32))
    if not points or sum(len(p) for p in points) == 0:
        raise PsdrRoomError("point_cloud: no segmented pixel has a valid depth; check the depth and segmentation files")
    return PointCloud(
        points=np.concatenate(points),
        colors=np.concatenate(rgb),
        segment=np.concatenate(seg),
        segments=list(panoptic.segments),
    )
