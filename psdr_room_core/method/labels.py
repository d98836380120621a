"""What a segment's label says about the object (§4.3 model search): the database categories to search.

A label restricts the model search to its own categories: a ``bed`` is searched among beds, and a desk is
never a bed's answer. Automatic labels mislead in known ways (the COCO detector has no desk, dresser or
nightstand: it calls desks "bed" and dressers "oven" or "tv"), so such a label also names **alternates**:
for a guessed segment they are searched too, and one is taken only where its shape explains the object clearly
better (``retrieve_objects`` logs the decision either way), unless a second opinion (the eyes network's
instance in the box) names the label's own category (:func:`alternates`). A label a person gave is never
second-guessed.

:data:`LABELS` covers every class the bundled detector (COCO's 80), the ADE20K segmenters and the NYU-40 /
SUN RGB-D annotations can emit, and the common LabelMe names; a free-form label is looked up whole, then by
its comma-separated synonyms, then by its last word ("storage box" is a box, "wire rack" a rack). A label
mapped to ``None`` names something the database does not hold (people, vehicles, books, cups): its segment is
not retrieved. A label found nowhere searches every category.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class LabelMeaning:
    """The database categories a label names."""

    categories: tuple[str, ...]
    """Searched for the segment, the most likely first (empty: every category)."""
    alternates: tuple[str, ...] = ()
    """What an automatic label of this name may also be: searched too for a guessed segment, taken only where
    the shape says so."""

    @property
    def primary(self) -> str:
        """The most likely category (``object``: any)."""
        return self.categories[0] if self.categories else "object"


ANY = LabelMeaning(())
"""An unknown label: every category is searched."""


def _m(*categories: str, alt: tuple[str, ...] = ()) -> LabelMeaning:
    return LabelMeaning(tuple(categories), alt)


LABELS: dict[str, LabelMeaning | None] = {
    # --- furniture and room objects the database holds (COCO, ADE20K, NYU-40 / SUN RGB-D, LabelMe names)
    "chair": _m("chair"),
    "armchair": _m("chair", "sofa"),
    "swivel chair": _m("chair"),
    "seat": _m("chair", "sofa"),
    "stool": _m("chair", "ottoman"),
    "sofa chair": _m("chair", "sofa"),
    "sofa": _m("sofa"),
    "couch": _m("sofa", alt=("chair",)),
    "bench": _m("sofa", "ottoman", alt=("table",)),
    "ottoman": _m("ottoman"),
    "pouf": _m("ottoman"),
    "footstool": _m("ottoman"),
    "bed": _m("bed", alt=("desk", "table")),
    "cradle": _m("bed"),
    "bunk bed": _m("bed"),
    "table": _m("table", alt=("desk",)),
    "dining table": _m("table", alt=("desk",)),
    "coffee table": _m("table"),
    "side table": _m("table", "cabinet"),
    "end table": _m("table", "cabinet"),
    "pool table": _m("table"),
    "base": _m("table", "cabinet"),
    "bar": _m("table", "cabinet"),
    "desk": _m("desk"),
    "cabinet": _m("cabinet"),
    "wardrobe": _m("cabinet"),
    "closet": _m("cabinet"),
    "chest of drawers": _m("cabinet"),
    "dresser": _m("cabinet"),
    "night stand": _m("cabinet", "table"),
    "nightstand": _m("cabinet", "table"),
    "sideboard": _m("cabinet"),
    "buffet": _m("cabinet"),
    "counter": _m("cabinet"),
    "countertop": _m("cabinet", "table"),
    "kitchen cabinet": _m("cabinet"),
    "kitchen island": _m("cabinet", "table"),
    "case": _m("cabinet", "shelf"),
    "arcade machine": _m("cabinet"),
    "sink": _m("cabinet", alt=("table",)),
    "bookcase": _m("shelf", "cabinet"),
    "bookshelf": _m("shelf", "cabinet"),
    "shelf": _m("shelf"),
    "shelves": _m("shelf", "cabinet"),
    "rack": _m("shelf"),
    "refrigerator": _m("refrigerator", alt=("cabinet", "shelf")),
    "refridgerator": _m("refrigerator"),
    "fridge": _m("refrigerator"),
    "appliance": _m("appliance"),
    "washer": _m("appliance"),
    "washing machine": _m("appliance"),
    "dryer": _m("appliance"),
    "dishwasher": _m("appliance"),
    "stove": _m("appliance"),
    "range": _m("appliance"),
    "oven": _m("appliance", alt=("cabinet",)),
    "microwave": _m("appliance", alt=("box", "cabinet")),
    "toaster": _m("appliance"),
    "lamp": _m("lamp"),
    "floor lamp": _m("lamp"),
    "table lamp": _m("lamp"),
    "light": _m("lamp"),
    "chandelier": _m("lamp"),
    "sconce": _m("lamp"),
    "rug": _m("rug"),
    "carpet": _m("rug"),
    "mat": _m("rug"),
    "floor mat": _m("rug"),
    "pillow": _m("pillow"),
    "cushion": _m("pillow"),
    "teddy bear": _m("pillow"),
    "television": _m("tv"),
    "television receiver": _m("tv"),
    "monitor": _m("tv"),
    "screen": _m("tv"),
    "crt screen": _m("tv"),
    "computer": _m("tv", "box"),
    "tv": _m("tv", alt=("frame", "cabinet")),
    "tvmonitor": _m("tv", alt=("frame", "cabinet")),
    "laptop": _m("tv", alt=("box",)),
    "picture": _m("frame"),
    "painting": _m("frame"),
    "poster": _m("frame"),
    "mirror": _m("frame"),
    "whiteboard": _m("frame"),
    "board": _m("frame"),
    "bulletin board": _m("frame"),
    "clock": _m("frame"),
    "frame": _m("frame"),
    "box": _m("box"),
    "bin": _m("box"),
    "basket": _m("box"),
    "crate": _m("box"),
    "container": _m("box"),
    "ashcan": _m("box"),
    "barrel": _m("box"),
    "bag": _m("box"),
    "backpack": _m("box"),
    "handbag": _m("box"),
    "suitcase": _m("box"),
    "plant": _m("plant"),
    "potted plant": _m("plant", alt=("box",)),
    "pottedplant": _m("plant", alt=("box",)),
    "flower": _m("plant"),
    "flower pot": _m("plant"),
    "pot": _m("plant"),
    "vase": _m("plant", alt=("lamp", "box")),
    # --- labels of every category, of unknown class: any model
    "object": ANY,
    "otherfurniture": ANY,
    "other furniture": ANY,
    "furniture": ANY,
    "thing": ANY,
    # --- things the database does not hold: not retrieved
    **{
        name: None
        for name in (
            # people, animals, vehicles, outdoor things
            "person",
            "people",
            "animal",
            "bird",
            "cat",
            "dog",
            "horse",
            "sheep",
            "cow",
            "elephant",
            "bear",
            "zebra",
            "giraffe",
            "bicycle",
            "car",
            "motorcycle",
            "minibike",
            "airplane",
            "bus",
            "train",
            "truck",
            "van",
            "boat",
            "ship",
            "traffic light",
            "fire hydrant",
            "stop sign",
            "parking meter",
            "streetlight",
            "house",
            "building",
            "skyscraper",
            "tower",
            "hovel",
            "bridge",
            "pier",
            "fence",
            "railing",
            "bannister",
            "column",
            "pole",
            "signboard",
            "trade name",
            "flag",
            "awning",
            "canopy",
            "tent",
            "booth",
            "grandstand",
            "stage",
            "fountain",
            "swimming pool",
            "escalator",
            "conveyer belt",
            "stairs",
            "stairway",
            "step",
            "rock",
            "palm",
            "tank",
            # small things, clothes and fixtures no database model stands for
            "book",
            "books",
            "paper",
            "bottle",
            "wine glass",
            "glass",
            "cup",
            "fork",
            "knife",
            "spoon",
            "bowl",
            "plate",
            "tray",
            "food",
            "banana",
            "apple",
            "sandwich",
            "orange",
            "broccoli",
            "carrot",
            "hot dog",
            "pizza",
            "donut",
            "cake",
            "umbrella",
            "tie",
            "frisbee",
            "skis",
            "snowboard",
            "sports ball",
            "ball",
            "kite",
            "baseball bat",
            "baseball glove",
            "skateboard",
            "surfboard",
            "tennis racket",
            "mouse",
            "remote",
            "keyboard",
            "cell phone",
            "scissors",
            "hair drier",
            "toothbrush",
            "plaything",
            "toy",
            "sculpture",
            "fan",
            "hood",
            "radiator",
            "clothes",
            "apparel",
            "towel",
            "blanket",
            "curtain",
            "shower curtain",
            "blinds",
            "shower",
            "bathtub",
            "toilet",
            "fireplace",
            "otherprop",
            "otherstructure",
        )
    },
}
"""Label (lower case, words separated by single spaces) → what it names; ``None``: not in the database."""


def _normal(label: str) -> str:
    return " ".join(re.sub(r"[_\-]+", " ", str(label).lower()).split())


def _forms(name: str) -> list[str]:
    """``name`` and its singulars ("boxes" → "boxe", "box"; "libraries" → "library")."""
    forms = [name]
    if name.endswith("ies"):
        forms.append(name[:-3] + "y")
    if name.endswith("es"):
        forms.append(name[:-2])
    if name.endswith("s"):
        forms.append(name[:-1])
    return forms


def meaning(label: str, category: str = "object") -> LabelMeaning | None:
    """What ``label`` names (``category``: the segment's, a ``lamp`` segment of unknown label is a lamp): its
    entry in :data:`LABELS`, else the first of its comma-separated synonyms that has one, else its last word's
    (singular too); :data:`ANY` for a label found nowhere, None for a thing the database does not hold."""
    synonyms = [_normal(s) for s in str(label).split(",") if _normal(s)]
    tries = [form for name in synonyms for form in _forms(name)]
    tries += [form for name in synonyms for form in _forms(name.split(" ")[-1])]
    for name in tries:
        if name in LABELS:
            return LABELS[name]
    return LabelMeaning(("lamp",)) if category == "lamp" else ANY


def alternates(named: LabelMeaning, second_opinion: str | None = None) -> tuple[str, ...]:
    """What else a guessed segment of label meaning ``named`` may be: its alternates, unless a
    ``second_opinion`` (a network's, a person's) names one of its own categories: the label is confirmed. A
    second opinion naming another category adds nothing: searched too, the eyes network's shelf on a chair
    NanoDet called a dining table won on the shared photos."""
    confirmed = second_opinion is not None and primary_category(second_opinion) in named.categories
    return () if confirmed else named.alternates


def primary_category(label: str, category: str = "object") -> str | None:
    """The label's most likely database category (``object``: unknown), None for a thing not in the database."""
    found = meaning(label, category)
    return None if found is None else found.primary
