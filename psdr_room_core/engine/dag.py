"""The stage graph's public names, for plugin authors: import them from here, not from the modules that hold them.

A stage function takes a :class:`StageContext` and its input artifacts; a program that embeds the engine builds
a :class:`Pipeline` from the composed config and runs a :class:`Selection` of it with a :class:`Runner`. The
engine itself imports from the modules that hold these names, one concern each:

- :mod:`.stage_config`: stage nodes read from the composed config (the ``_stage_`` node format), typed settings;
- :mod:`.graph`: the pipeline sorted by its artifacts, checked against the stage functions, sliced;
- :mod:`.context`: what a stage function gets besides its inputs;
- :mod:`.choice`: the implementation of each capability a stage uses (``auto`` included);
- :mod:`.runner`: the selection run through the cache, announced by the run-event hooks.
"""

from __future__ import annotations

from .choice import AUTO, with_settings
from .context import StageContext
from .graph import Pipeline, Selection, check_stage_inputs
from .runner import Runner
from .stage_config import StageNode, typed_settings

__all__ = [
    "AUTO",
    "Pipeline",
    "Runner",
    "Selection",
    "StageContext",
    "StageNode",
    "check_stage_inputs",
    "typed_settings",
    "with_settings",
]
