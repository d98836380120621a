"""The method's artifacts: what its stages pass to each other, each saved as ordinary files a user can open.

Every artifact is a dataclass with a ``kind`` (its name in cache manifests), a ``marker`` file, ``save(directory)``
writing standard formats (PNG, NPY, JSON, PLY, XML) and ``load(directory)`` reading them back (the engine's
:class:`~psdr_room_core.engine.artifacts.Artifact` protocol). An artifact's identity in the cache is the digest of
the files it saves, so two equal artifacts have equal digests. Grouped by what they describe:

* :mod:`.image`: the working image and the camera;
* :mod:`.segmentation`: depth, object boxes, panoptic segments;
* :mod:`.geometry`: point cloud, room box, retrieved candidates, object meshes, placements;
* :mod:`.appearance`: materials, lights, the fitted appearance, the exported scene files;
* :mod:`.logs`: optimisation logs; :mod:`.io`: the file formats.

Coordinate conventions used throughout:

* image pixels: x right, y down, origin at the top-left corner of the top-left pixel;
* camera frame: OpenCV (x right, y down, z forward), in the units of the depth;
* world frame: Y up, the floor is ``y = 0``, the camera centre is at ``(0, h, 0)``, and world +Z is the
  optical axis projected on the floor.
"""

from __future__ import annotations

from .appearance import (
    Light,
    Lights,
    MaterialAssignment,
    PartAppearance,
    PartMaterial,
    Rect,
    SceneAppearance,
    SceneFiles,
    appearance_fields,
)
from .geometry import (
    SUPPORTS,
    Candidate,
    ObjectCandidates,
    ObjectMesh,
    Placement,
    Placements,
    PointCloud,
    RoomBox,
    rotation_y,
    vec3,
)
from .image import Camera, Image
from .io import write_png
from .logs import OptimizationLog
from .segmentation import (
    CATEGORIES,
    ROOM_CATEGORIES,
    DepthMap,
    Detection,
    Detections,
    Panoptic,
    SeenBox,
    Segment,
    box4,
    panoptic_ids,
    write_coco_panoptic,
)

TYPES = (
    Image,
    Camera,
    DepthMap,
    Detections,
    Panoptic,
    PointCloud,
    RoomBox,
    ObjectCandidates,
    Placements,
    MaterialAssignment,
    Lights,
    SceneAppearance,
    SceneFiles,
    OptimizationLog,
)
"""The artifact types the method registers with the engine (``register_artifacts``)."""

__all__ = [
    "CATEGORIES",
    "ROOM_CATEGORIES",
    "SUPPORTS",
    "TYPES",
    "Camera",
    "Candidate",
    "DepthMap",
    "Detection",
    "Detections",
    "Image",
    "Light",
    "Lights",
    "MaterialAssignment",
    "ObjectCandidates",
    "ObjectMesh",
    "OptimizationLog",
    "PartAppearance",
    "PartMaterial",
    "Placement",
    "Placements",
    "PointCloud",
    "Panoptic",
    "Rect",
    "RoomBox",
    "SceneAppearance",
    "SceneFiles",
    "SeenBox",
    "Segment",
    "appearance_fields",
    "panoptic_ids",
    "rotation_y",
    "vec3",
    "box4",
    "write_coco_panoptic",
    "write_png",
]
