"""Real sizes, solids and a physically possible scene (§4.3 after the fits): sizes.py, solids.py, physical.py."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from psdr_room_core.engine import shipped
from psdr_room_core.libraries.object_db import ObjectDatabase, builtin_database
from psdr_room_core.method.artifacts import Camera, ObjectMesh, Placement, RoomBox
from psdr_room_core.method.geometry import box_mesh
from psdr_room_core.method.physical import PhysicalParams, interpenetrations, room_excess, settle, support_top
from psdr_room_core.method.silhouette import silhouette
from psdr_room_core.method.sizes import CATEGORY_SIZES, SizePrior, dimensions, scale_range
from psdr_room_core.method.solids import overlap, voxel_solid

C2W = np.eye(4)
C2W[:3, :3] = np.diag([-1.0, -1.0, 1.0])  # OpenCV camera looking along world +Z, Y up
C2W[:3, 3] = [0.0, 1.5, -2.5]
ROOM = RoomBox(camera_to_world=C2W, center=np.array([0.0, 1.5, 1.0]), half_size=np.array([3.0, 1.5, 3.5]), yaw=0.0)
CAMERA = Camera.from_vfov(160, 120, 60.0)
PARAMS = shipped.settings(PhysicalParams, "priors.physical")


@pytest.fixture(scope="module")
def db() -> ObjectDatabase:
    return builtin_database()


def placed(
    db: ObjectDatabase,
    model_id: str,
    segment_id: int,
    position: tuple[float, float, float],
    yaw_deg: float = 0.0,
    scale: float = 1.0,
    explained: float = 0.8,
) -> Placement:
    """A database model standing on the floor."""
    record = db.record(model_id)
    return Placement(
        segment_id,
        record.category,
        model_id,
        db.mesh(model_id),
        position,
        math.radians(yaw_deg),
        scale,
        "floor",
        None,
        record.category,
        explained,
    )


def cube_mesh() -> ObjectMesh:
    """A 1 m cube standing on y = 0, one group."""
    cube = box_mesh(np.array([0.0, 0.5, 0.0]), np.array([0.5, 0.5, 0.5]))
    return ObjectMesh(
        vertices=cube.vertices,
        faces=cube.faces,
        face_group=np.zeros(len(cube.faces), np.int64),
        groups=("body",),
        colors=np.array([[0.5, 0.5, 0.5]]),
    )


# --------------------------------------------------------------------------------------------- sizes
def test_every_built_in_model_is_inside_its_categorys_real_sizes(db: ObjectDatabase) -> None:
    """The ranges are what furniture measures: each of the 226 models at its own size lies inside its
    category's (so a prior centred on real size never pushes a right model away)."""
    for record in db.records:
        low, high = scale_range(record.category, record.extent)
        assert low <= 1.0 <= high, (record.id, record.extent, CATEGORY_SIZES[record.category])
    assert set(db.categories()) <= set(CATEGORY_SIZES)


def test_a_double_sized_bed_is_far_outside_the_bed_range_and_pays_for_it(db: ObjectDatabase) -> None:
    record = db.record("kenney/bedSingle")
    height, length, width = dimensions(record.extent, 2.07)
    assert length == pytest.approx(4.66, abs=0.01) and length > CATEGORY_SIZES["bed"].length[1]
    prior = SizePrior.of("bed", record.extent, scale_weight=0.3, range_weight=5.0)
    assert prior.low < 1.0 < prior.high and prior.outside(1.0) == 0.0
    assert prior.outside(2.07) == pytest.approx(math.log(2.07 / prior.high))
    assert prior.penalty(2.07) > 1.0 > prior.penalty(1.05) and prior.clamp(2.07) == prior.high


# --------------------------------------------------------------------------------------------- solids
def test_two_boxes_interpenetrate_by_their_overlap() -> None:
    a = Placement(1, "box", "test/cube", cube_mesh(), (0.0, 0.0, 1.0), 0.0, 1.0)
    for gap, expected in ((0.1, 0.1), (0.3, 0.3)):
        b = replace(a, segment_id=2, position=(1.0 - gap, 0.0, 1.0))
        found = overlap(a, b)
        assert found.thickness == pytest.approx(expected, abs=0.03)
        assert found.shared == pytest.approx(gap, abs=0.04)
    apart = replace(a, segment_id=3, position=(1.2, 0.0, 1.0))
    assert overlap(a, apart).thickness == 0.0
    twin = replace(a, segment_id=4, model_id="test/cube-twin")
    assert overlap(a, twin).shared == pytest.approx(1.0, abs=0.02)


def test_the_space_under_a_table_is_empty_and_a_cabinet_without_a_bottom_is_solid(db: ObjectDatabase) -> None:
    table = voxel_solid(db.mesh("kenney/table").vertices, db.mesh("kenney/table").faces)
    middle = table.inside[:, table.inside.shape[1] // 2, :]
    top = table.inside[:, -4, :]
    assert middle.mean() < 0.15 and top.mean() > 0.8
    mesh = db.mesh("parametric/cabinet_011")
    cabinet = voxel_solid(mesh.vertices, mesh.faces)
    assert cabinet.inside[:, cabinet.inside.shape[1] // 2, :].mean() > 0.6


def test_a_pillow_rests_on_the_bed_surface_not_on_its_headboard(db: ObjectDatabase) -> None:
    bed = placed(db, "kenney/bedDouble", 1, (0.0, 0.0, 2.0), yaw_deg=180.0)
    mattress = support_top(bed, np.array([0.0, 2.0]))
    headboard = bed.position[1] + float(bed.mesh.vertices[:, 1].max())
    assert 0.3 < mattress < headboard - 0.1


# --------------------------------------------------------------------------------------------- settle
def test_an_object_that_needs_twice_its_real_size_is_dropped_with_the_reason(db: ObjectDatabase) -> None:
    bed = placed(db, "kenney/bedSingle", 5, (0.0, 0.0, 2.0), yaw_deg=90.0, scale=2.07)
    settled = settle([bed], room=ROOM, camera=CAMERA, drawn=set(), pixels={5: 4000}, params=PARAMS)
    assert settled.placements == [] and len(settled.dropped) == 1
    assert settled.dropped[0].startswith("5:bed (bedSingle): needs 2.07x its size") and "bed's" in settled.dropped[0]
    # a person drew it: scaled in
    drawn = settle([bed], room=ROOM, camera=CAMERA, drawn={5}, pixels={5: 4000}, params=PARAMS)
    (kept,) = drawn.placements
    assert kept.scale == pytest.approx(scale_range("bed", db.record("kenney/bedSingle").extent)[1])
    slightly = settle(
        [replace(bed, scale=1.15)], room=ROOM, camera=CAMERA, drawn=set(), pixels={5: 4000}, params=PARAMS
    )
    assert len(slightly.placements) == 1 and slightly.placements[0].scale < 1.12  # 2.59 m long, 4% over: scaled in


def test_a_mirror_duplicate_is_removed(db: ObjectDatabase) -> None:
    """A bed found twice (in the photo and in its mirror image): two beds posed in nearly the same space. The
    one that explains less of its segment goes."""
    bed = placed(db, "kenney/bedDouble", 5, (0.0, 0.0, 2.0), yaw_deg=180.0, explained=0.8)
    mirrored = placed(db, "parametric/bed_003", 9, (0.15, 0.0, 2.1), yaw_deg=175.0, explained=0.5)
    settled = settle([bed, mirrored], room=ROOM, camera=CAMERA, drawn=set(), pixels={5: 5000, 9: 5000}, params=PARAMS)
    assert [p.segment_id for p in settled.placements] == [5]
    assert settled.dropped[0].startswith("9:bed (bed_003): occupies the space of 5:bed (bedDouble)")


def _shown(front: Placement, behind: Placement) -> tuple[np.ndarray, dict[int, int]]:
    """(id map, pixel counts) of a photo that shows ``behind`` whole and ``front`` around it, as a segmentation
    gives them: the object behind is seen on every pixel of its silhouette."""
    ids = np.zeros((CAMERA.height, CAMERA.width), np.int32)
    ids[silhouette(CAMERA, C2W, front.world_vertices(), front.mesh.faces)] = front.segment_id
    ids[silhouette(CAMERA, C2W, behind.world_vertices(), behind.mesh.faces)] = behind.segment_id
    return ids, {k: int((ids == k).sum()) for k in (front.segment_id, behind.segment_id)}


def test_an_object_of_no_named_kind_in_front_of_what_the_photo_shows_is_dropped(db: ObjectDatabase) -> None:
    """A clutter blob (label `object`) posed as a panel standing in front of a chair the photo shows: the panel
    cannot move back behind the chair within a frame's sizes and its silhouette, nor the chair forward in front
    of it within a chair's; the blob yields to the chair a label names (a panel labelled `frame` stays: between
    two named objects the photo does not say whose depth is wrong)."""
    panel = replace(
        placed(db, "parametric/frame_003", 1, (0.0, 0.0, 0.5), yaw_deg=180.0, explained=0.9), label="object"
    )
    chair = placed(db, "parametric/chair_005", 2, (0.1, 0.0, 2.5), yaw_deg=180.0, explained=0.9)
    ids, pixels = _shown(panel, chair)
    assert pixels[1] > 5 * pixels[2]  # the panel explains far more pixels than the chair
    settled = settle([panel, chair], room=ROOM, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS, ids=ids)
    assert [p.segment_id for p in settled.placements] == [2] and settled.placements[0] == chair
    assert settled.dropped == [
        "1:object (frame_003): hides 2:chair (chair_005), which the photo shows there; it cannot move back, and "
        "its label names no kind"
    ]
    named = settle(
        [replace(panel, label="frame"), chair],
        room=ROOM,
        camera=CAMERA,
        drawn=set(),
        pixels=pixels,
        params=PARAMS,
        ids=ids,
    )
    assert len(named.placements) == 2 and not named.dropped  # which named one's depth is wrong the photo does not say
    unchecked = settle([panel, chair], room=ROOM, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS)
    assert len(unchecked.placements) == 2  # without the segmentation nothing says the chair is seen


def test_a_blob_is_not_dropped_where_that_would_not_show_what_it_hides(db: ObjectDatabase) -> None:
    """The blob in front of the chair is not all that hides it: a cabinet stands between them. Dropping the blob
    would leave the chair hidden, so it stays (which of the named two is wrong the photo does not say)."""
    panel = replace(
        placed(db, "parametric/frame_003", 1, (0.0, 0.0, 0.5), yaw_deg=180.0, explained=0.9), label="object"
    )
    chair = placed(db, "parametric/chair_005", 2, (0.1, 0.0, 2.5), yaw_deg=180.0, explained=0.9)
    cabinet = placed(db, "parametric/cabinet_002", 3, (0.1, 0.0, 1.6), yaw_deg=180.0, explained=0.9)
    ids, pixels = _shown(panel, chair)
    settled = settle(
        [panel, chair, cabinet], room=ROOM, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS, ids=ids
    )
    assert len(settled.placements) == 3 and not settled.dropped


def test_an_object_in_front_of_what_the_photo_shows_moves_back_behind_it(db: ObjectDatabase) -> None:
    """A free-hanging blob (label `object`) posed as a panel too near, in front of a chair the photo shows, moves
    back along its camera ray (keeping its silhouette) until the chair is in sight, as a panel of a frame's size."""
    panel = replace(
        placed(db, "parametric/frame_003", 1, (0.0, 0.5, 0.5), yaw_deg=180.0, scale=0.6, explained=0.9),
        support="free",
        label="object",
    )
    chair = placed(db, "parametric/chair_005", 2, (0.1, 0.0, 1.2), yaw_deg=180.0, explained=0.9)
    ids, pixels = _shown(panel, chair)
    settled = settle([panel, chair], room=ROOM, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS, ids=ids)
    assert not settled.dropped and settled.placements[1] == chair
    moved = settled.placements[0]
    assert moved.scale > panel.scale and moved.position[2] > 1.2 + 0.4  # behind the chair
    assert settled.changed[0].startswith("1:object (frame_003): moved back along its ray (scale 0.60 -> ")
    before = silhouette(CAMERA, C2W, panel.world_vertices(), panel.mesh.faces)
    after = silhouette(CAMERA, C2W, moved.world_vertices(), moved.mesh.faces)
    assert (before & after).sum() / (before | after).sum() > 0.9


def test_two_objects_passing_through_each_other_are_moved_apart(db: ObjectDatabase) -> None:
    """A nightstand sunk 15 cm into the bed beside it moves out (the weaker of the two), by a step that keeps its
    silhouette best (here mostly away from the camera)."""
    bed = placed(db, "kenney/bedDouble", 5, (0.0, 0.0, 2.0), yaw_deg=180.0, explained=0.8)
    half = 0.5 * float(np.ptp(bed.mesh.vertices[:, 0]))
    stand = placed(db, "parametric/cabinet_011", 6, (half + 0.2 - 0.15, 0.0, 3.0), yaw_deg=180.0, explained=0.9)
    assert interpenetrations([bed, stand], 0.05)
    settled = settle([bed, stand], room=ROOM, camera=CAMERA, drawn=set(), pixels={5: 6000, 6: 800}, params=PARAMS)
    assert [p.segment_id for p in settled.placements] == [5, 6] and not settled.dropped
    assert interpenetrations(settled.placements, PARAMS.penetration) == []
    moved = settled.placements[1]
    assert settled.placements[0] == bed and 0.1 < np.linalg.norm(np.subtract(moved.position, stand.position)) <= 0.5


def test_what_made_room_for_a_dropped_object_goes_back(db: ObjectDatabase) -> None:
    """A weak desk wedged between a wall and a stronger desk cannot be parted from it and is dropped; the box
    in front of it, a weak guess, had first stepped out of it (that pair passing deeper), and goes back where it
    was."""

    def cube(segment_id: int, category: str, x: float, z: float, scale: float, explained: float) -> Placement:
        return Placement(segment_id, category, f"cube_{segment_id}", cube_mesh(), (x, 0.0, z), 0.0, scale,
                         "floor", None, category, explained)  # fmt: skip

    side = 0.8  # the desks' smallest real size is 0.8 * e^-0.15: shrinking frees at most 5.6 cm
    weak = cube(1, "desk", -side / 2, 2.0, side, explained=0.3)  # from the left wall ...
    strong = cube(2, "desk", side / 2 - 0.15, 2.0, side, explained=0.9)  # ... 15 cm into this one, to the right wall
    box = cube(3, "box", -side / 2, 2.0 - side / 2 - 0.2 + 0.25, 0.4, explained=0.8)  # 25 cm into the weak desk
    room = RoomBox(
        camera_to_world=C2W,
        center=np.array([-0.075, 1.5, 1.0]),
        half_size=np.array([side - 0.075, 1.5, 3.5]),
        yaw=0.0,
    )
    pixels = {1: 3000, 2: 3000, 3: 1500}
    settled = settle(
        [weak, strong, box], room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS, scores={3: 0.2}
    )
    assert [p.segment_id for p in settled.placements] == [2, 3]
    assert settled.dropped[0].startswith("1:desk (cube_1): passes")
    assert any(c.startswith("3:box (cube_3): moved") for c in settled.changed)
    assert settled.changed[-1] == "3:box (cube_3): back as it was before it made room for 1:desk (cube_1), dropped"
    assert settled.placements[1] == box


def test_a_weak_guess_never_makes_a_surer_object_change() -> None:
    """A sure dresser and a weak guess against the wall beside it, 21 cm into it: the guess can neither step out
    nor shrink and keep its silhouette, while the dresser could step aside, but a guess does not reshape what the
    segmentation was sure of. Before the final settling the pair is left to the joint fit; in it, the guess is
    dropped. Were the guess as sure as the dresser, the dresser would step aside."""

    def cube(segment_id: int, x: float, scale: float, explained: float) -> Placement:
        return Placement(segment_id, "cabinet", f"cube_{segment_id}", cube_mesh(), (x, 0.0, 3.0), 0.0, scale,
                         "floor", None, "cabinet", explained)  # fmt: skip

    room = RoomBox(camera_to_world=C2W, center=np.array([0.0, 1.5, 3.0]), half_size=np.array([1.2, 1.5, 0.6]), yaw=0.0)
    dresser = cube(1, -0.05, 0.9, explained=0.6)  # x from -0.5 to 0.4
    guess = cube(2, 0.69, 1.0, explained=0.9)  # x from 0.19 to the wall
    assert interpenetrations([dresser, guess], 0.15)
    pixels = {1: 3000, 2: 3000}  # the guess explains more pixels: by that alone it is the stronger
    placed_only = settle(
        [dresser, guess],
        room=room,
        camera=CAMERA,
        drawn=set(),
        pixels=pixels,
        params=PARAMS,
        final=False,
        scores={2: 0.2},
    )
    assert placed_only.placements == [dresser, guess] and not placed_only.changed
    final = settle(
        [dresser, guess], room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS, scores={2: 0.2}
    )
    assert final.placements == [dresser] and final.dropped[0].startswith("2:cabinet (cube_2): passes")
    as_sure = settle([dresser, guess], room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS)
    assert as_sure.placements[0].position[0] < dresser.position[0] - 0.2 and as_sure.placements[1] == guess


def test_of_two_sure_objects_that_cannot_part_the_one_the_detector_is_surer_of_stays() -> None:
    """Two desks wedged wall to wall, 15 cm into each other, neither able to step or shrink out: the final
    settling drops the one with the weaker evidence, the pixels it is expected to explain (IoU x pixels x prompt
    score). The first explains a little more of its segment, but the detector was much less sure of it."""

    def desk(segment_id: int, x: float, explained: float) -> Placement:
        return Placement(segment_id, "desk", f"cube_{segment_id}", cube_mesh(), (x, 0.0, 2.0), 0.0, 0.8,
                         "floor", None, "desk", explained)  # fmt: skip

    room = RoomBox(
        camera_to_world=C2W, center=np.array([-0.075, 1.5, 1.0]), half_size=np.array([0.725, 1.5, 3.5]), yaw=0.0
    )
    first, second = desk(1, -0.4, explained=0.9), desk(2, 0.25, explained=0.8)
    pixels = {1: 3000, 2: 3000}
    unscored = settle([first, second], room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS)
    assert unscored.placements == [first] and unscored.dropped[0].startswith("2:desk (cube_2): passes")
    scored = settle(
        [first, second], room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS, scores={1: 0.55, 2: 0.8}
    )
    assert scored.placements == [second] and scored.dropped[0].startswith("1:desk (cube_1): passes")


def test_an_object_does_not_step_out_in_front_of_another() -> None:
    """A tall box standing in a bed's foot, its lower part hidden behind the foot: stepping 41 cm towards the
    camera would free it and keep most of its own silhouette, but it would then stand in front of the bed, and
    what the picture shows of it would change (its seen silhouette keeps under half). The bed, between the walls,
    cannot move: the pair is left to the joint fit, and in the final settling the box is dropped."""

    def block(segment_id: int, category: str, size: tuple[float, float, float], z: float, x: float) -> Placement:
        cube = cube_mesh()
        mesh = replace(cube, vertices=cube.vertices * np.array(size))
        return Placement(segment_id, category, f"block_{segment_id}", mesh, (x, 0.0, z), 0.0, 1.0, "floor", None,
                         category, 0.8)  # fmt: skip

    room = RoomBox(
        camera_to_world=C2W, center=np.array([0.0, 1.5, 0.7]), half_size=np.array([0.81, 1.5, 3.31]), yaw=0.0
    )
    bed = block(1, "bed", (1.6, 0.8, 2.0), 3.0, 0.0)  # wall to wall, against the back wall
    box = block(2, "cabinet", (0.4, 1.2, 0.4), 2.22, 0.5)  # its front 2 cm behind the bed's foot
    pixels = {1: 8000, 2: 3000}
    placed_only = settle([bed, box], room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS, final=False)
    assert placed_only.placements == [bed, box] and not placed_only.changed
    final = settle([bed, box], room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS)
    assert final.placements == [bed] and final.dropped[0].startswith("2:cabinet (block_2): passes")


def test_a_chair_in_a_crowded_row_steps_out_of_its_desk() -> None:
    """A chair 12 cm into the desk against the wall behind it, and 5 cm into each chair beside it: no step frees
    it of all three, but one frees it of the desk, passing no deeper through its neighbours, who then step aside.
    Nothing is dropped, nothing passes through anything."""

    def cube(segment_id: int, category: str, x: float, z: float, scale: float, explained: float) -> Placement:
        return Placement(segment_id, category, f"cube_{segment_id}", cube_mesh(), (x, 0.0, z), 0.0, scale,
                         "floor", None, category, explained)  # fmt: skip

    room = RoomBox(camera_to_world=C2W, center=np.array([0.0, 1.5, 1.0]), half_size=np.array([3.0, 1.5, 2.01]), yaw=0.0)
    desk = cube(1, "desk", 0.0, 2.6, 0.8, explained=0.9)  # z from 2.2 to the wall
    chair = cube(2, "chair", 0.0, 2.2 - 0.225 + 0.12, 0.45, explained=0.6)
    beside = [cube(k, "chair", x, 2.2 - 0.235, 0.45, explained=0.6) for k, x in ((3, 0.4), (4, -0.4))]
    objects = [desk, chair, *beside]
    assert {(a, b) for a, b, _ in interpenetrations(objects, PARAMS.penetration)} == {(1, 2), (2, 3), (2, 4)}
    pixels = {1: 6000, 2: 1500, 3: 1500, 4: 1500}
    settled = settle(objects, room=room, camera=CAMERA, drawn=set(), pixels=pixels, params=PARAMS)
    assert not settled.dropped and settled.placements[0] == desk
    assert interpenetrations(settled.placements, PARAMS.penetration) == []
    assert settled.changed[0].startswith("2:chair (cube_2): moved ")


def test_an_object_beyond_the_room_is_brought_in_or_the_room_grows(db: ObjectDatabase) -> None:
    chair = placed(db, "parametric/chair_004", 3, (0.0, 0.0, 4.45))  # its back 10 cm through the far wall
    assert room_excess(chair, ROOM)[2] > 0.05
    settled = settle([chair], room=ROOM, camera=CAMERA, drawn=set(), pixels={3: 500}, params=PARAMS)
    (inside,) = settled.placements
    assert not np.any(room_excess(inside, settled.room)) and settled.room is ROOM
    assert "brought inside the room" in settled.changed[0]
    far = replace(chair, position=(0.0, 0.0, 6.0))  # 1.7 m beyond: no change keeps its silhouette
    drawn = settle([far], room=ROOM, camera=CAMERA, drawn={3}, pixels={3: 500}, params=replace(PARAMS, keep_iou=1.0))
    assert drawn.placements == [far] and not np.any(room_excess(far, drawn.room))  # a person drew it: the room grows
    assert drawn.room.half_size[2] > ROOM.half_size[2] and drawn.room.half_size[0] == ROOM.half_size[0]
    assert drawn.room.center[1] - drawn.room.half_size[1] == pytest.approx(0.0)  # the floor stays
    guessed = settle(
        [far], room=ROOM, camera=CAMERA, drawn=set(), pixels={3: 500}, params=replace(PARAMS, keep_iou=1.0)
    )
    assert guessed.placements == [] and "beyond the room box" in guessed.dropped[0]  # more than max_growth out
    near = settle(
        [replace(far, position=(0.0, 0.0, 5.0))],
        room=ROOM,
        camera=CAMERA,
        drawn=set(),
        pixels={3: 500},
        params=replace(PARAMS, keep_iou=1.0),
    )
    assert len(near.placements) == 1 and near.room.half_size[2] > ROOM.half_size[2]  # 0.7 m out: the room grows
    kept = settle([far], room=ROOM, camera=CAMERA, drawn=set(), pixels={3: 500}, params=PARAMS, final=False)
    assert kept.room is ROOM and len(kept.placements) == 1  # place_objects leaves it to fit_objects


def test_eq3_pays_for_interpenetration_and_its_gradient_parts_the_objects() -> None:
    """PoseModel.collision_penalty: two 1 m cubes overlapping by 0.3 m cost the mean depth of each one's volume
    inside the other (a third of it, at up to 0.15 m), its gradient moves them apart, and cubes apart cost nothing."""
    import torch

    from psdr_room_core.method.artifacts import Placements
    from psdr_room_core.method.pose_model import PoseModel

    a = Placement(1, "box", "test/cube", cube_mesh(), (0.0, 0.0, 1.0), 0.0, 1.0, "floor")
    b = replace(a, segment_id=2, position=(0.7, 0.0, 1.0))
    model = PoseModel(Placements(objects=[a, b]), ROOM, unit=1.0)
    penalty = model.collision_penalty()
    first, second = penalty.detach().tolist()
    assert first == pytest.approx(second) and 0.01 < first < 0.06, penalty
    penalty.sum().backward()
    grad = model.theta["translation"].grad
    assert grad is not None and grad[0, 0] > 0 > grad[1, 0]  # descent moves a to -x, b to +x
    apart = PoseModel(Placements(objects=[a, replace(b, position=(1.2, 0.0, 1.0))]), ROOM, unit=1.0)
    assert torch.all(apart.collision_penalty() == 0)


def test_in_eq3_a_weak_guess_through_a_surer_object_alone_moves_out() -> None:
    """PoseModel.collision_penalty with ``weak``: where a weak guess passes through a surer object, the penalty is
    the same but only the guess gets its gradient (a guess never pushes what the photo is surer of); two guesses,
    or two sure objects, both move apart as before."""
    import torch

    from psdr_room_core.method.artifacts import Placements
    from psdr_room_core.method.pose_model import PoseModel

    a = Placement(1, "bed", "test/cube", cube_mesh(), (0.0, 0.0, 1.0), 0.0, 1.0, "floor")
    b = replace(a, segment_id=2, label="oven", position=(0.7, 0.0, 1.0))
    sure = PoseModel(Placements(objects=[a, b]), ROOM, unit=1.0)
    guess = PoseModel(Placements(objects=[a, b]), ROOM, unit=1.0, weak={2})
    assert torch.allclose(guess.collision_penalty(), sure.collision_penalty())
    guess.collision_penalty().sum().backward()
    for name, values in guess.theta.items():
        assert values.grad is not None and torch.all(values.grad[0] == 0), name  # the bed holds
    grad = guess.theta["translation"].grad
    assert grad is not None and grad[1, 0] < 0  # descent moves the guess to +x, out of the bed
    both = PoseModel(Placements(objects=[a, b]), ROOM, unit=1.0, weak={1, 2})
    both.collision_penalty().sum().backward()
    grad = both.theta["translation"].grad
    assert grad is not None and grad[0, 0] > 0 > grad[1, 0]


def test_a_named_object_the_networks_boxes_put_behind_what_it_hides_moves_back(db: ObjectDatabase) -> None:
    """A free-hanging frame posed too near, in front of a chair the photo shows: between two named objects the photo
    does not say whose depth is wrong, but where the network's 3D boxes put the chair nearer, the frame moves back
    along its ray behind it; where they put the frame nearer, or the rule is off, nothing changes. A named object
    that cannot move back is not dropped."""
    frame = replace(
        placed(db, "parametric/frame_003", 1, (0.0, 0.5, 0.5), yaw_deg=180.0, scale=0.6, explained=0.9),
        support="free",
    )
    chair = placed(db, "parametric/chair_005", 2, (0.1, 0.0, 1.2), yaw_deg=180.0, explained=0.9)
    ids, pixels = _shown(frame, chair)
    common = {"room": ROOM, "camera": CAMERA, "drawn": set(), "pixels": pixels, "ids": ids}
    settled = settle([frame, chair], params=PARAMS, seen_depths={1: 4.0, 2: 3.0}, **common)
    assert not settled.dropped and settled.placements[1] == chair
    assert settled.placements[0].position[2] > 1.2 + 0.4  # behind the chair
    assert settled.changed[0].startswith("1:frame (frame_003): moved back along its ray")
    for seen_depths, params in (({1: 2.9, 2: 3.0}, PARAMS), ({1: 4.0, 2: 3.0}, replace(PARAMS, seen_order=0.0))):
        kept = settle([frame, chair], params=params, seen_depths=seen_depths, **common)
        assert kept.placements == [frame, chair] and not kept.changed
    standing = replace(frame, support="wall", anchor=0)
    held = settle([standing, chair], params=PARAMS, seen_depths={1: 4.0, 2: 3.0}, **common)
    assert len(held.placements) == 2 and not held.dropped
