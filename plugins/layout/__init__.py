"""Offline room layout (no learned model): ``segmentation=layout`` and ``depth=layout``.

A box room is fitted in the Manhattan frame of the photo's vanishing points, scored against a line-segment
orientation map (Lee et al. 2009; hypotheses in the spirit of Hedau et al. 2009) and, for depth, against
the segmentation's wall/floor/ceiling labels. Objects come from box prompts (``detector``) refined with
GrabCut, and get depth from where their mask meets the floor.
"""

from __future__ import annotations

from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.registry import Registry

from .settings import LayoutDepthSettings, LayoutSegmentationSettings


@hookimpl
def register_implementations(registry: Registry) -> None:
    """By reference: scipy (the vanishing points' code) loads when one is constructed."""
    registry.add_implementation(
        "segmentation",
        "layout",
        "psdr_room_plugins.layout.segmentation:LayoutSegmentation",
        version="3",
        params=LayoutSegmentationSettings,
        reads_files=False,
        description="walls/floor/ceiling of a box layout fitted to the photo's lines; objects discovered among "
        "detector boxes and what the room cannot explain, cut out by GrabCut",
    )
    registry.add_implementation(
        "depth",
        "layout",
        "psdr_room_plugins.layout.depth:LayoutDepth",
        version="2",
        params=LayoutDepthSettings,
        reads_files=False,
        description="depth of a box room fitted to the segmentation, objects standing on its floor (camera height assumed)",
    )
