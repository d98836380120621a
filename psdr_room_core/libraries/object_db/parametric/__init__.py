"""Parametric furniture: one generator per kind of object, each with style parameters and separate material groups.

Each generator is a plain function of keyword parameters (sizes in metres) returning a canonical
:class:`~psdr_room_core.method.artifacts.ObjectMesh` (+Y up, front +Z, bottom at y = 0), built from the closed primitives of
:mod:`..primitives`. The material groups are the parts a material stage would texture separately (§4.4):
a sofa's ``frame``, ``cushion`` and ``legs``; a table's ``top``, ``legs`` and ``frame``; and so on. The
generators live by family (:mod:`.seating`, :mod:`.tables`, :mod:`.beds`, :mod:`.storage`, :mod:`.lighting`,
:mod:`.textiles`, :mod:`.decor`, :mod:`.electronics`, :mod:`.appliances`).

:func:`~.catalogue.catalogue` lists the variants the built-in library ships: for each series a fixed number
of parameter sets, chosen deterministically (:class:`~.catalogue.Dice` hashes the series, index and
parameter name), so that ``parametric/<series>_<NNN>`` ids name the same model on every machine and run.
"""

from .appliances import microwave, oven, refrigerator, washer
from .beds import bed
from .catalogue import GENERATORS, SERIES, Dice, Series, Variant, catalogue
from .decor import frame, plant
from .electronics import monitor, tv
from .lighting import lamp
from .seating import chair, ottoman, sofa
from .storage import cabinet, container, kitchen_unit, shelf
from .tables import desk, table
from .textiles import pillow, rug

__all__ = [
    "GENERATORS",
    "SERIES",
    "Dice",
    "Series",
    "Variant",
    "bed",
    "cabinet",
    "catalogue",
    "chair",
    "container",
    "desk",
    "frame",
    "kitchen_unit",
    "lamp",
    "microwave",
    "monitor",
    "ottoman",
    "oven",
    "pillow",
    "plant",
    "refrigerator",
    "rug",
    "shelf",
    "sofa",
    "table",
    "tv",
    "washer",
]
