"""The ADE20K-150 classes (SceneParsing benchmark, ``objectInfo150``) and their psdr-room categories.

Index ``k`` is the network's class ``k`` (SegFormer logits channel, Mask2Former class index; the
"no object" class of mask-classification models is index 150). Each class is a comma-separated list of
synonyms as in ``objectInfo150.csv``; the first one is the label kept on the segment, and the whole list
goes through :func:`~psdr_room_plugins.sidecar_segmentation.category_of`, so ``windowpane, window`` is a
window, ``blind, screen`` a window, ``screen door, screen`` a door and ``rug, carpet, carpeting`` floor.
"""

from __future__ import annotations

from ..sidecar_segmentation import category_of

ADE20K_150: tuple[str, ...] = (
    "wall", "building, edifice", "sky", "floor, flooring", "tree", "ceiling", "road, route", "bed",
    "windowpane, window", "grass", "cabinet", "sidewalk, pavement",
    "person, individual, someone, somebody, mortal, soul", "earth, ground", "door, double door", "table",
    "mountain, mount", "plant, flora, plant life", "curtain, drape, drapery, mantle, pall", "chair",
    "car, auto, automobile, machine, motorcar", "water", "painting, picture", "sofa, couch, lounge", "shelf",
    "house", "sea", "mirror", "rug, carpet, carpeting", "field", "armchair", "seat", "fence, fencing", "desk",
    "rock, stone", "wardrobe, closet, press", "lamp", "bathtub, bathing tub, bath, tub", "railing, rail",
    "cushion", "base, pedestal, stand", "box", "column, pillar", "signboard, sign",
    "chest of drawers, chest, bureau, dresser", "counter", "sand", "sink", "skyscraper",
    "fireplace, hearth, open fireplace", "refrigerator, icebox", "grandstand, covered stand", "path",
    "stairs, steps", "runway", "case, display case, showcase, vitrine",
    "pool table, billiard table, snooker table", "pillow", "screen door, screen", "stairway, staircase",
    "river", "bridge, span", "bookcase", "blind, screen", "coffee table, cocktail table",
    "toilet, can, commode, crapper, pot, potty, stool, throne", "flower", "book", "hill", "bench", "countertop",
    "stove, kitchen stove, range, kitchen range, cooking stove", "palm, palm tree", "kitchen island",
    "computer, computing machine, computing device, data processor, electronic computer, "
    "information processing system",
    "swivel chair", "boat", "bar", "arcade machine", "hovel, hut, hutch, shack, shanty",
    "bus, autobus, coach, charabanc, double-decker, jitney, motorbus, motorcoach, omnibus, passenger vehicle",
    "towel", "light, light source", "truck, motortruck", "tower", "chandelier, pendant, pendent",
    "awning, sunshade, sunblind", "streetlight, street lamp", "booth, cubicle, stall, kiosk",
    "television receiver, television, television set, tv, tv set, idiot box, boob tube, telly, goggle box",
    "airplane, aeroplane, plane", "dirt track", "apparel, wearing apparel, dress, clothes", "pole",
    "land, ground, soil", "bannister, banister, balustrade, balusters, handrail",
    "escalator, moving staircase, moving stairway", "ottoman, pouf, pouffe, puff, hassock", "bottle",
    "buffet, counter, sideboard", "poster, posting, placard, notice, bill, card", "stage", "van", "ship",
    "fountain", "conveyer belt, conveyor belt, conveyer, conveyor, transporter", "canopy",
    "washer, automatic washer, washing machine", "plaything, toy", "swimming pool, swimming bath, natatorium",
    "stool", "barrel, cask", "basket, handbasket", "waterfall, falls", "tent, collapsible shelter", "bag",
    "minibike, motorbike", "cradle", "oven", "ball", "food, solid food", "step, stair",
    "tank, storage tank", "trade name, brand name, brand, marque", "microwave, microwave oven",
    "pot, flowerpot", "animal, animate being, beast, brute, creature, fauna", "bicycle, bike, wheel, cycle",
    "lake", "dishwasher, dish washer, dishwashing machine", "screen, silver screen, projection screen",
    "blanket, cover", "sculpture", "hood, exhaust hood", "sconce", "vase",
    "traffic light, traffic signal, stoplight", "tray",
    "ashcan, trash can, garbage can, wastebin, ash bin, ash-bin, ashbin, dustbin, trash barrel, trash bin",
    "fan", "pier, wharf, wharfage, dock", "crt screen", "plate", "monitor, monitoring device",
    "bulletin board, notice board", "shower", "radiator", "glass, drinking glass", "clock", "flag",
)
assert len(ADE20K_150) == 150

LABELS: tuple[str, ...] = tuple(name.split(",")[0].strip() for name in ADE20K_150)
"""The label kept on each segment: the first synonym (``windowpane``, ``chest of drawers``)."""

CATEGORIES: tuple[str, ...] = tuple(category_of(name) for name in ADE20K_150)
"""The psdr-room category of each class."""

_AMORPHOUS = frozenset({
    "building", "sky", "tree", "road", "grass", "sidewalk", "earth", "mountain", "plant", "water", "sea", "field",
    "sand", "river", "hill", "path", "runway", "dirt track", "land", "lake", "waterfall",
})
STUFF: frozenset[int] = frozenset(
    k for k, (label, category) in enumerate(zip(LABELS, CATEGORIES))
    if category in ("wall", "floor", "ceiling") or label in _AMORPHOUS
)
"""Classes that are regions rather than countable objects: one segment per class present. Every other
class is split into connected components, one segment each (two chairs are two segments)."""
