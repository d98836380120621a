"""One object per thing (paper §4.3, before the model search): guessed segments that are parts of one object
merged."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

import numpy as np

from psdr_room_core.engine.dag import StageContext

from ...artifacts import Camera, DepthMap, Image, Panoptic, PointCloud, RoomBox
from ...capabilities import ObjectRetriever
from ...grouping import Part, group_segments
from ...objects import ObjectQuery, square_crop
from ..settings import GroupObjects

log = logging.getLogger("psdr_room")


def group_objects(
    ctx: StageContext,
    image: Image,
    panoptic: Panoptic,
    cloud: PointCloud,
    camera: Camera,
    room: RoomBox,
    depth: DepthMap,
) -> dict[str, Any]:
    """One object per thing: merge the guessed segments that are parts of one object, by their geometry in the
    fitted room (:func:`~psdr_room_core.method.grouping.group_segments`: stacked parts of a bed or a sofa,
    segments occupying the same space) where the ``retrieval`` capability's best model of the whole's category
    explains the two together as well as apart, before the model search (§4.3). Each pair judged is logged;
    ``enabled: false`` passes the segmentation through."""
    group = ctx.settings(GroupObjects)
    if not group.enabled:
        return {"panoptic": panoptic, "cloud": cloud}
    retriever = ctx.impl("retrieval", ObjectRetriever)
    c2w = np.asarray(room.camera_to_world)
    rgb8 = image.to_uint8()
    scene = cloud.points.astype(np.float64) @ c2w[:3, :3].T + c2w[:3, 3]

    def judge(whole: str, union: Part, parts: Sequence[Part]) -> tuple[float, list[float]]:
        def best(part: Part) -> float:
            query = ObjectQuery(
                part.segment.id,
                part.segment.label,
                (whole,),
                part.mask,
                part.points,
                square_crop(rgb8, part.mask),
                scene,
                part.segment.box,
                room=room,
                photo=image.rgb,
            )
            ranked = retriever.rank(query, camera, c2w, 1)
            return ranked[0].score if ranked else 0.0

        return best(union), [best(p) for p in parts]

    grouped, regrouped, notes = group_segments(
        panoptic, cloud, camera, room, metric=depth.metric, params=group, judge=judge, unplaced=set(depth.unplaced)
    )
    for note in notes:
        log.info("group_objects: %s", note)
    return {"panoptic": grouped, "cloud": regrouped}
