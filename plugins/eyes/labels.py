"""The eyes network's classes: what its surface and category outputs mean (fixed by the trained weights; the
data engine :mod:`psdr_room_core.applications.synth_data` labels its renders with them)."""

SURFACES = ("none", "wall", "floor", "ceiling", "window", "door", "object")
"""Surface classes (index = value of a ``surface`` label or output channel)."""
OBJECT = SURFACES.index("object")
CATEGORIES = (
    "chair",
    "table",
    "sofa",
    "bed",
    "cabinet",
    "shelf",
    "desk",
    "lamp",
    "rug",
    "pillow",
    "plant",
    "tv",
    "ottoman",
    "refrigerator",
    "appliance",
    "frame",
    "box",
    "other",
)
"""Furniture categories (output channel k; a ``category`` label stores k + 1, 0 = none): the object
database's :data:`~psdr_room_core.libraries.object_db.database.CATEGORIES` when the network was made."""
