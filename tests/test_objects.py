"""Object stage (§4.3) on constructed cases: initial pose, yaw sweep, support rules, overlaps, artifacts."""

from __future__ import annotations

import math
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest
import torch

from psdr_room_core.engine import shipped
from psdr_room_core.engine.dag import StageContext
from psdr_room_core.method import silhouette as silhouette_module
from psdr_room_core.method.artifacts import (
    Camera,
    DepthMap,
    Image,
    ObjectMesh,
    Panoptic,
    Placement,
    Placements,
    RoomBox,
    Segment,
)
from psdr_room_core.method.backs import back_shown, wall_gap
from psdr_room_core.method.geometry import TriangleMesh, box_mesh, weld
from psdr_room_core.method.objects import (
    ObjectQuery,
    SupportParams,
    best_yaw,
    initial_pose,
    mesh_radius,
    pose_matrix,
    support_relations,
    transform,
    wall_frame,
)
from psdr_room_core.method.physical import Settled
from psdr_room_core.method.pose_model import Explained, ObjectTargets, PoseModel, explained_by, object_targets
from psdr_room_core.method.silhouette import MeshCaster, camera_rays, depth_map, silhouette
from psdr_room_core.method.stages.objects.fit import fit_objects, restore_lost, settle_restored, try_yaw_turns
from psdr_room_core.method.view_search import SearchParams, ViewTarget, fit_view
from psdr_room_plugins.eyes import labels
from psdr_room_plugins.mitsuba_renderer.session import MitsubaRenderer
from psdr_room_plugins.optimizer_adam import Adam
from psdr_room_plugins.retrieval_silhouette import SilhouetteRetrieval, SilhouetteSettings

C2W = np.eye(4)
C2W[:3, :3] = np.diag([-1.0, -1.0, 1.0])  # OpenCV camera looking along world +Z, Y up
C2W[:3, 3] = [0.0, 1.5, -2.5]
ROOM = RoomBox(camera_to_world=C2W, center=np.array([0.0, 1.5, 0.0]), half_size=np.array([3.0, 1.5, 3.0]), yaw=0.0)
CAMERA = Camera.from_vfov(160, 120, 60.0)
SEARCH = shipped.settings(SearchParams, "place_objects.search")
SUPPORT = shipped.settings(SupportParams, "place_objects.support")


def _silhouette(**changes: object) -> SilhouetteRetrieval:
    """The shipped ``retrieval=silhouette``, with ``changes`` to its settings."""
    return SilhouetteRetrieval(**{**shipped.arguments(SilhouetteSettings, "retrieval.silhouette"), **changes})


def plain_box(half_x: float, half_y: float, half_z: float) -> ObjectMesh:
    """A box of these half sizes standing on y = 0, centred on the vertical axis, one group."""
    shape = box_mesh(np.array([0.0, half_y, 0.0]), np.array([half_x, half_y, half_z]))
    return ObjectMesh(
        vertices=shape.vertices,
        faces=shape.faces,
        face_group=np.zeros(12, int),
        groups=("frame",),
        colors=np.array([[0.5, 0.5, 0.5]]),
    )


def l_shape() -> ObjectMesh:
    """An L-shaped sofa-like mesh (canonical frame: bottom at 0, centred, front +Z), two groups."""
    seat = box_mesh(np.array([0.0, 0.2, 0.0]), np.array([1.0, 0.2, 0.4]))
    arm = box_mesh(np.array([0.8, 0.4, 0.6]), np.array([0.2, 0.4, 0.3]))
    vertices = np.vstack([seat.vertices, arm.vertices])
    vertices -= [
        (vertices[:, 0].min() + vertices[:, 0].max()) / 2,
        0.0,
        (vertices[:, 2].min() + vertices[:, 2].max()) / 2,
    ]
    faces = np.vstack([seat.faces, arm.faces + 8])
    return ObjectMesh(
        vertices=vertices,
        faces=faces,
        face_group=np.repeat([0, 1], 12),
        groups=("frame", "arm"),
        colors=np.array([[0.6, 0.3, 0.2], [0.2, 0.2, 0.2]]),
    )


def test_initial_pose_centres_on_the_median_at_half_the_radius() -> None:
    rng = np.random.default_rng(0)
    points = rng.normal(size=(4000, 3)) * [0.5, 0.3, 0.4] + [1.0, 0.6, 2.0]
    mesh = l_shape()
    position, scale = initial_pose(points, mesh.vertices, radius_factor=0.5)
    centre = np.median(points, axis=0)
    radius = np.median(np.linalg.norm(points - centre, axis=1))
    assert scale == pytest.approx(0.5 * radius / mesh_radius(mesh.vertices))
    world = transform(mesh.vertices, pose_matrix(position, 0.3, scale))
    assert (world.min(axis=0) + world.max(axis=0))[1] / 2 == pytest.approx(centre[1])  # box centre on the median
    assert position[[0, 2]] == pytest.approx(centre[[0, 2]])


def test_yaw_sweep_finds_the_rotation_of_the_target_silhouette() -> None:
    mesh = l_shape()
    position, scale = np.array([0.3, 0.0, 1.5]), 1.0
    target = silhouette(
        CAMERA, C2W, transform(mesh.vertices, pose_matrix(position, math.radians(90), scale)), mesh.faces
    )
    yaw, error = best_yaw(CAMERA, C2W, mesh.vertices, mesh.faces, position, scale, target, n_yaw=12)
    assert math.degrees(yaw) == pytest.approx(90.0) and error == 0.0


def test_depth_map_is_the_nearest_surface() -> None:
    box = box_mesh(np.array([0.0, 1.5, 2.0]), np.array([0.5, 0.5, 0.5]))  # front face at z = 1.5: 4 from the camera
    depth = depth_map(CAMERA, C2W, box.vertices, box.faces)
    assert np.array_equal(depth > 0, silhouette(CAMERA, C2W, box.vertices, box.faces))
    assert np.allclose(depth[depth > 0], 4.0, atol=1e-5)  # ray cast: exact, not a per-face mean
    assert (depth > 0).sum() == pytest.approx((CAMERA.fx / 4.0) ** 2, rel=0.08)  # 1 unit wide at depth 4


def test_a_posed_cast_is_the_cast_of_the_transformed_mesh() -> None:
    mesh = l_shape()
    to_world = pose_matrix(np.array([0.3, 0.0, 1.5]), math.radians(35), 1.4)
    caster = MeshCaster(mesh.vertices, mesh.faces)
    whole = depth_map(CAMERA, C2W, transform(mesh.vertices, to_world), mesh.faces)
    assert np.allclose(caster.depth(CAMERA, C2W, to_world), whole, atol=1e-4)
    assert np.allclose(caster.depth(CAMERA, C2W, to_world, window=(40, 30, 120, 100)), whole[30:100, 40:120], atol=1e-4)


def test_the_batched_cast_equals_one_cast_per_pose() -> None:
    """MeshCaster.depth_many casts K poses in one call; each map is exactly the single cast of its pose, over
    the whole image and over a window (the retrieval's union windows)."""
    mesh = l_shape()
    caster = MeshCaster(mesh.vertices, mesh.faces)
    poses = [
        pose_matrix(np.array([x, 0.0, z]), math.radians(yaw), s)
        for x, z, yaw, s in (
            (0.3, 1.5, 35.0, 1.4),
            (-0.5, 2.5, 200.0, 0.8),
            (0.0, 1.0, 90.0, 1.0),
            (2.0, 1.0, 0.0, 1.0),
        )
    ]
    for window in (None, (40, 30, 120, 100)):
        batch = caster.depth_many(CAMERA, C2W, poses, window)
        assert batch.shape[0] == len(poses) and (batch > 0).any(axis=(1, 2)).sum() >= 3
        for k, pose in enumerate(poses):
            assert np.array_equal(batch[k], caster.depth(CAMERA, C2W, pose, window))


def test_casters_share_one_copy_of_a_cameras_rays() -> None:
    """A retrieval casts hundreds of models under each object's camera: the pixel rays are one shared, read-only
    copy per camera (a copy per caster held 1.7 GB at 640 px), kept for the last few cameras only."""
    mesh = l_shape()
    first, second = MeshCaster(mesh.vertices, mesh.faces), MeshCaster(mesh.vertices, mesh.faces)
    assert np.array_equal(first.depth(CAMERA, C2W), second.depth(CAMERA, C2W))
    rays = camera_rays(CAMERA)
    assert rays is camera_rays(replace(CAMERA)) and not rays.flags.writeable
    assert np.array_equal(rays, CAMERA.pixel_rays())
    for width in range(40, 40 + 2 * silhouette_module._RAYS_KEPT):
        camera_rays(CAMERA.resized(width))
    assert len(silhouette_module._RAYS) == silhouette_module._RAYS_KEPT
    assert camera_rays(CAMERA) is not rays  # dropped, built again


def test_batched_scores_equal_single_ones_and_the_sweep_is_the_best_start() -> None:
    """A pose's score does not depend on the poses scored with it (the union window holds each one's own), and
    ViewSearch's start is its best moment-matched rotation, finished into fit_view's pose."""
    from psdr_room_core.method.view_search import ViewSearch, _Scorer

    mesh = l_shape()
    truth = pose_matrix(np.array([0.4, 0.0, 1.8]), math.radians(50.0), 1.3)
    mask, points = _seen_points(mesh, truth)
    target = ViewTarget.build(CAMERA, C2W, mask, points, points, 160)
    scorer = _Scorer(target, mesh.vertices, mesh.faces, SEARCH)
    poses = [truth, pose_matrix(np.array([-0.4, 0.0, 2.5]), 1.0, 0.9), pose_matrix(np.array([0.4, 0.0, 1.8]), 2.0, 1.3)]
    assert scorer.score_many(poses) == [scorer.score(p) for p in poses]
    assert scorer.score(truth)[1] > 0.95 and scorer.score(truth)[0] < min(scorer.score(p)[0] for p in poses[1:])
    search = ViewSearch(target, mesh.vertices, mesh.faces, SEARCH, support_height=0.0)
    assert len(search.hypotheses) == 12 and search.start == min(search.hypotheses, key=lambda h: h[0])
    view = search.finish()
    assert view.error <= search.start[0] and view.iou > 0.95


def test_the_shortlist_refines_only_the_best_starts() -> None:
    """retrieval=silhouette refines the `shortlist` models whose sweep scores best (or the `shortlist_share` of
    them): the true model is still ranked first, and a shortlist of every model gives the same ranking as none."""

    model_id = "parametric/chair_004"
    full = _silhouette(shortlist=0)
    mesh = full.mesh(model_id)
    truth = pose_matrix(np.array([0.2, 0.0, 2.0 + mesh.extent[2]]), math.radians(40.0), 1.0)
    mask, points = _seen_points(mesh, truth)
    query = ObjectQuery(1, "chair", ("chair",), mask, points, np.zeros((4, 4, 3), np.uint8), points)
    everything = full.rank(query, CAMERA, C2W, 5)
    assert _silhouette(shortlist=1, shortlist_share=1.0).rank(query, CAMERA, C2W, 5) == everything
    short = _silhouette(shortlist=6, shortlist_share=0.0).rank(query, CAMERA, C2W, 5)
    assert short[0].model_id == model_id and len(short) == 5
    for candidate in short:  # the score's terms, as the studio lists them, make the score
        terms = dict(candidate.terms)
        assert set(terms) == {"iou", "silhouette", "depth", "size"} and 0 <= terms.pop("iou") <= 1  # no box, no room
        assert candidate.score == pytest.approx(1 / (1 + sum(terms.values())), rel=1e-9)
    assert short[0].terms["iou"] > 0.8 > short[-1].terms["iou"]
    assert {c.model_id for c in short} <= {c.model_id for c in full.rank(query, CAMERA, C2W, 26)}


@pytest.fixture(scope="module")
def eyes_network(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shipped eyes network's weights with seeded 3D heads, exported (no catalogue beside it yet)."""
    from psdr_room_plugins.eyes.network import EyesNet, export_onnx
    from psdr_room_plugins.eyes.perception import SHIPPED

    torch.manual_seed(0)
    net = EyesNet()
    net.load_onnx(SHIPPED)
    return export_onnx(net, tmp_path_factory.mktemp("eyes") / "eyes.onnx")


def test_retrieval_eyes_ranks_first_the_model_whose_embedding_the_network_sees(eyes_network: Path) -> None:
    """retrieval=eyes ranks first the model whose catalogue embedding is what the network sees on the object's
    mask, searches the category the network votes for beside the label's, and scores each posed model by its
    cosine, its category's probability and its silhouette; without a catalogue beside the network it is
    unavailable, saying why."""
    from psdr_room_plugins.eyes.box3d import CATALOGUE
    from psdr_room_plugins.eyes.plugin import EyesSettings
    from psdr_room_plugins.eyes.retrieval import EyesRetrieval

    model_id = "parametric/chair_004"
    eyes = EyesRetrieval(
        network=replace(shipped.settings(EyesSettings, "segmentation.eyes"), path=str(eyes_network)),
        silhouette=replace(shipped.settings(SilhouetteSettings, "retrieval.silhouette"), shortlist=0),
        shortlist=4,
        category_weight=0.5,
        silhouette_weight=0.5,
    )
    assert "no eyes_models.npz beside" in (eyes.unavailable(eyes_network) or "")
    mesh = eyes.mesh(model_id)
    truth = pose_matrix(np.array([0.2, 0.0, 2.0 + mesh.extent[2]]), math.radians(40.0), 1.0)
    mask, points = _seen_points(mesh, truth)
    photo = np.full((*mask.shape, 3), 0.8, np.float32)
    photo[mask] = (0.5, 0.3, 0.2)
    query = ObjectQuery(1, "chair", ("chair",), mask, points, np.zeros((4, 4, 3), np.uint8), points, photo=photo)
    seen, votes = eyes.seen(query)
    records = eyes.silhouette.database.records
    others = np.random.default_rng(0).normal(size=(len(records), len(seen)))
    others -= np.outer(others @ seen, seen)  # orthogonal to what the network sees: cosine 0
    embeddings = np.where([[r.id == model_id] for r in records], seen, others)
    np.savez(
        eyes_network.with_name(CATALOGUE),
        model_ids=np.array([r.id for r in records]),
        embeddings=(embeddings / np.linalg.norm(embeddings, axis=1, keepdims=True)).astype(np.float32),
    )
    assert eyes.unavailable(eyes_network) is None
    appearance = eyes.appearance(query)
    assert max(appearance, key=lambda m: appearance[m][0]) == model_id
    assert appearance[model_id][0] == pytest.approx(1.0, abs=1e-5)
    voted = labels.CATEGORIES[int(votes.argmax())]
    assert {eyes.category(m) for m in appearance} == {"chair", voted}
    ranked = eyes.rank(query, CAMERA, C2W, 3)
    assert ranked[0].model_id == model_id and len(ranked) == 3
    for candidate in ranked:
        terms = candidate.terms
        assert candidate.score == pytest.approx(terms["cosine"] + 0.5 * terms["category_p"] + 0.5 * terms["silhouette"])
    assert ranked[0].terms["iou"] > 0.8


def _seen(
    meshes: list[tuple[ObjectMesh | TriangleMesh, np.ndarray]], camera: Camera = CAMERA
) -> tuple[np.ndarray, np.ndarray]:
    """(index of the nearest mesh per pixel, -1 for none; its world points, as depth would give) of posed meshes."""
    depths = np.stack([depth_map(camera, C2W, transform(m.vertices, to_world), m.faces) for m, to_world in meshes])
    depths[depths == 0] = np.inf
    nearest = np.where(np.isfinite(depths.min(axis=0)), depths.argmin(axis=0), -1)
    v, u = np.nonzero(nearest >= 0)
    z = depths.min(axis=0)[v, u]
    local = np.stack([(u + 0.5 - camera.cx) * z / camera.fx, (v + 0.5 - camera.cy) * z / camera.fy, z], axis=1)
    points = np.full((*nearest.shape, 3), np.nan)
    points[v, u] = local @ C2W[:3, :3].T + C2W[:3, 3]
    return nearest, points


def _seen_points(mesh: ObjectMesh, to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mask, world points of the visible surface) of a posed mesh, as segmentation and depth would give."""
    nearest, points = _seen([(mesh, to_world)])
    return nearest == 0, points[nearest == 0]


@pytest.mark.parametrize("yaw_deg", [30.0, 150.0, 240.0])
def test_fit_view_recovers_the_pose_from_mask_and_points(yaw_deg: float) -> None:
    mesh = l_shape()
    truth = pose_matrix(np.array([0.4, 0.0, 1.8]), math.radians(yaw_deg), 1.3)
    mask, points = _seen_points(mesh, truth)
    view = fit_view(
        ViewTarget.build(CAMERA, C2W, mask, points, points, 160), mesh.vertices, mesh.faces, SEARCH, support_height=0.0
    )
    error = (math.degrees(view.yaw) - yaw_deg + 180.0) % 360.0 - 180.0
    assert abs(error) < 3.0  # the sweep's best rotation, polished
    assert view.scale == pytest.approx(1.3, rel=0.03) and view.iou > 0.95
    assert np.linalg.norm(view.position - truth[:3, 3]) < 0.03 and view.position[1] == 0.0


def test_an_object_hidden_behind_another_keeps_its_size() -> None:
    """A tall cabinet behind a low wide box shows only its top: hidden pixels are not wrong, so the search
    poses the whole cabinet standing on the floor behind the box, not a small one floating in the strip."""
    cabinet = box_mesh(np.array([0.0, 0.9, 0.0]), np.array([0.4, 0.9, 0.25]))  # canonical: bottom at 0
    front = box_mesh(np.array([0.0, 0.6, 0.8]), np.array([1.2, 0.6, 0.3]))
    truth = pose_matrix(np.array([0.1, 0.0, 2.2]), math.radians(20), 1.0)
    nearest, points = _seen([(cabinet, truth), (front, np.eye(4))])
    mask = nearest == 0
    assert 0.1 < mask.sum() / silhouette(CAMERA, C2W, transform(cabinet.vertices, truth), cabinet.faces).sum() < 0.6
    target = ViewTarget.build(CAMERA, C2W, mask, points[mask], points[nearest >= 0], 160)
    view = fit_view(target, cabinet.vertices, cabinet.faces, SEARCH, support_height=0.0)
    assert view.scale == pytest.approx(1.0, rel=0.05)
    assert np.linalg.norm(view.position - truth[:3, 3]) < 0.08
    # the rules' other reading: the cabinet on the box
    on_the_box = fit_view(target, cabinet.vertices, cabinet.faces, SEARCH, support_height=1.2)
    assert view.error < 0.5 * on_the_box.error


def test_an_object_cut_by_the_image_border_is_not_shrunk_into_it() -> None:
    mesh = l_shape()
    truth = pose_matrix(np.array([1.3, 0.0, 1.2]), math.radians(60), 1.2)  # its left part is out of the frame
    mask, points = _seen_points(mesh, truth)
    assert mask[:, 0].any()
    view = fit_view(
        ViewTarget.build(CAMERA, C2W, mask, points, points, 160), mesh.vertices, mesh.faces, SEARCH, support_height=0.0
    )
    assert view.scale == pytest.approx(1.2, rel=0.05)
    assert np.linalg.norm(view.position - truth[:3, 3]) < 0.08


def test_a_box_prompted_mask_without_the_legs_is_not_shrunk_into_the_seat() -> None:
    """A box-prompted cut of a table loses the thin legs: the mask is the top only. Pixels of the prompt box
    outside the mask are free, so the search poses the whole table on the floor at its size; without the box
    the legs count as wrong and the table shrinks into its top."""
    from psdr_room_core.libraries.object_db.parametric import table

    mesh = table(width=1.2, depth=0.7, height=0.75, leg_style="metal", apron=False)
    truth = pose_matrix(np.array([0.1, 0.0, 2.6]), math.radians(25), 1.0)
    full, points = _seen_points(mesh, truth)
    rows = np.flatnonzero(full.any(axis=1))
    ys, xs = np.nonzero(full)
    box = (float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1))
    tops = points[:, 1] > 0.6  # the table top's pixels only, as GrabCut leaves them
    mask = np.zeros_like(full)
    mask[ys[tops], xs[tops]] = True
    assert mask.sum() < 0.9 * full.sum() and rows[-1] > np.flatnonzero(mask.any(axis=1))[-1] + 10
    with_box = fit_view(
        ViewTarget.build(CAMERA, C2W, mask, points[tops], points, 160, box=box),
        mesh.vertices,
        mesh.faces,
        SEARCH,
        support_height=0.0,
    )
    without = fit_view(
        ViewTarget.build(CAMERA, C2W, mask, points[tops], points, 160),
        mesh.vertices,
        mesh.faces,
        SEARCH,
        support_height=0.0,
    )
    assert with_box.scale == pytest.approx(1.0, rel=0.05) and with_box.iou > 0.9
    assert abs(without.scale - 1.0) > abs(with_box.scale - 1.0)


def _query(
    segment_id: int,
    points: np.ndarray,
    rows: slice,
    cols: slice,
    shape: tuple[int, int] = (120, 160),
    category: str | None = None,
) -> ObjectQuery:
    mask = np.zeros(shape, dtype=bool)
    mask[rows, cols] = True
    return ObjectQuery(
        segment_id, "thing", (category,) if category else (), mask, points, np.zeros((4, 4, 3), np.uint8), points
    )


def _cloud(centre: list[float], half: list[float], n: int = 500) -> np.ndarray:
    return np.random.default_rng(1).uniform(-1, 1, size=(n, 3)) * half + centre


def test_support_rules_floor_parent_wall_free() -> None:
    floor = np.zeros((120, 160), dtype=bool)
    floor[90:, :] = True
    queries = [
        _query(1, _cloud([0.0, 0.4, 1.0], [0.6, 0.4, 0.4]), slice(60, 88), slice(40, 100)),  # table: on the floor
        _query(2, _cloud([0.0, 1.0, 1.0], [0.15, 0.2, 0.15]), slice(45, 58), slice(60, 75)),  # vase: on the table
        _query(
            3, _cloud([2.95, 1.6, 1.5], [0.03, 0.3, 0.4]), slice(20, 40), slice(130, 150)
        ),  # picture: on the +x wall
        _query(4, _cloud([-1.0, 2.0, 0.5], [0.2, 0.1, 0.2]), slice(5, 15), slice(10, 30)),  # floating: free
        _query(
            5, _cloud([1.5, 0.5, 1.0], [0.3, 0.3, 0.3]), slice(60, 70), slice(120, 128)
        ),  # low but far from the floor mask
    ]
    relations = support_relations(queries, floor, ROOM, SUPPORT)
    assert relations[1] == [("floor", None)]
    assert relations[2] == [("parent", 1)]
    assert relations[3] == [("wall", 1)]
    assert relations[4] == [("free", None)]
    assert relations[5][0][0] == "free"
    strict = support_relations(queries, floor, ROOM, replace(SUPPORT, edge_px=1.0))
    assert strict[1] == [("free", None)]  # the mask edge threshold is a config value


def test_a_parent_must_hold_its_child_and_hidden_bottoms_of_furniture_stand_on_the_floor() -> None:
    floor = np.zeros((120, 160), dtype=bool)
    floor[90:, :] = True
    front = _query(1, _cloud([0.0, 0.4, 1.0], [0.6, 0.4, 0.4]), slice(60, 88), slice(40, 100))
    # a sofa behind the table: its mask touches the table's from above, its bottom is hidden, its points
    # are 1.5 behind the table's: not on the table; a grounded category, so on the floor
    behind = _cloud([0.0, 0.7, 2.5], [0.8, 0.2, 0.3])
    relations = support_relations(
        [front, _query(2, behind, slice(45, 59), slice(30, 110), category="sofa")], floor, ROOM, SUPPORT
    )
    assert relations[2] == [("floor", None)]
    unknown = support_relations([front, _query(2, behind, slice(45, 59), slice(30, 110))], floor, ROOM, SUPPORT)
    assert unknown[2] == [("free", None)]
    # a cabinet whose points stand right on the table's top: on it, or on the floor behind it; a vase: on it
    above = _cloud([0.0, 1.05, 1.1], [0.3, 0.25, 0.2])
    both = support_relations(
        [front, _query(2, above, slice(45, 59), slice(50, 90), category="cabinet")], floor, ROOM, SUPPORT
    )
    assert both[2] == [("parent", 1), ("floor", None)]
    vase = support_relations(
        [front, _query(2, above, slice(45, 59), slice(50, 90), category="lamp")], floor, ROOM, SUPPORT
    )
    assert vase[2] == [("parent", 1)]


def test_wall_frame_faces_into_the_room() -> None:
    for index in range(4):
        inward, tangent, offset = wall_frame(ROOM, index)
        inside = inward @ ROOM.center - offset
        assert inside == pytest.approx(3.0) and abs(inward @ tangent) < 1e-12 and tangent[1] == 0


def test_placements_round_trip_with_meshes(tmp_path: Path) -> None:
    mesh = l_shape()
    placements = Placements(
        objects=[
            Placement(7, "couch", "parametric/sofa_003", mesh, (0.1, 0.0, 2.0), 0.5, 0.8, "parent", 3, "sofa", 0.83)
        ],
        extra={"dropped": []},
    )
    placements.save(tmp_path)
    loaded = Placements.load(tmp_path)
    p = loaded.objects[0]
    assert (p.segment_id, p.model_id, p.support, p.anchor) == (7, "parametric/sofa_003", "parent", 3)
    assert (p.category, p.explained) == ("sofa", 0.83)
    assert np.allclose(p.world_vertices(), placements.objects[0].world_vertices(), atol=1e-5)
    assert p.mesh.groups == ("frame", "arm") and np.array_equal(p.mesh.face_group, mesh.face_group)
    assert np.allclose(p.mesh.colors, mesh.colors, atol=1e-4)
    assert (tmp_path / "meshes" / "7.obj").read_text().count("usemtl") == 2


def _scene(truth: list[Placement], camera: Camera) -> tuple[Panoptic, DepthMap]:
    """Exact-ish targets: the renderer's own masks and depth of the true poses at the photo's resolution."""
    meshes = {f"object_{p.segment_id}": weld(TriangleMesh(p.world_vertices(), p.mesh.faces)) for p in truth}
    renderer = MitsubaRenderer(spp=16, spp_boundary=4).geometry(
        camera, C2W, meshes, {n: i for i, n in enumerate(meshes)}
    )
    masks, weighted, alpha = (t.numpy() for t in renderer.render())
    ids = np.where(masks.max(axis=0) > 0.5, np.argmax(masks, axis=0) + 1, 0)
    segments = [Segment(i + 1, "object", p.label) for i, p in enumerate(truth)]
    covered = alpha > 0.5
    return (
        Panoptic(
            ids=np.array([0, *[p.segment_id for p in truth]])[ids].astype(np.int32),
            segments=[Segment(p.segment_id, s.category, s.label) for p, s in zip(truth, segments)],
        ),
        DepthMap(depth=np.where(covered, weighted / np.maximum(alpha, 1e-6), 0).astype(np.float32), valid=covered),
    )


def test_fit_objects_recovers_perturbed_poses(tmp_path: Path) -> None:
    mesh = l_shape()
    truth = [
        Placement(1, "sofa", "m", mesh, (-0.6, 0.0, 1.2), math.radians(20), 0.9, "floor"),
        Placement(2, "sofa", "m", mesh, (1.0, 0.0, 2.2), math.radians(-30), 0.8, "floor"),
    ]
    camera = Camera.from_vfov(96, 72, 60.0)
    panoptic, depth = _scene(truth, camera)
    start = Placements(
        objects=[
            replace(truth[0], position=(-0.4, 0.0, 1.4), yaw=math.radians(30), scale=0.8),
            replace(truth[1], position=(1.2, 0.0, 2.0), yaw=math.radians(-22), scale=0.7),
        ]
    )
    params = {
        **shipped.node("fit_objects"),
        "iterations": 60,
        "render_width": 96,
        "blur_sigmas": [2.0, 4.0],
        "convergence": {"window": 0, "tolerance": 0.01, "min_iterations": 0},
    }  # all 60 iterations
    ctx = StageContext(
        stage="fit_objects",
        params=params,
        seed=0,
        photo=tmp_path / "photo.png",
        implementations={"renderer": MitsubaRenderer(spp=4, spp_boundary=16), "optimizer": Adam()},
    )
    image = Image(rgb=np.full((72, 96, 3), 0.5, np.float32))
    out = fit_objects(ctx, placements=start, camera=camera, room=ROOM, depth=depth, panoptic=panoptic, image=image)

    def error(ps: Placements) -> float:
        return float(np.mean([np.linalg.norm(np.subtract(p.position, t.position)) for p, t in zip(ps.objects, truth)]))

    fitted, log = out["placements"], out["log"]
    assert error(fitted) < 0.5 * error(start), (error(start), error(fitted))
    assert all(p.position[1] == 0.0 and p.support == "floor" for p in fitted.objects)  # kept on the floor
    assert log.history[-1]["mean_iou"] > log.history[0]["mean_iou"]
    assert set(log.images) == {"before", "after", "loss"} and log.summary["interpenetrations"] == []
    assert out["room"] is ROOM and log.summary["dropped"] == []  # nothing crossed the room or another object
    assert log.summary["turned"] == {} and len(log.history) == 60  # nothing was the wrong way round
    assert log.summary["kept_placed"] == []  # and the fit lost nothing
    losses = [h["loss"] for h in log.history]  # the poses left are the best iterate's
    assert log.summary["best_iteration"] == losses.index(min(losses))
    assert log.summary["final"]["loss"] == min(losses) == fitted.extra["final"]["loss"]


def test_yaw_test_turns_an_object_placed_back_to_front() -> None:
    mesh = l_shape()
    truth = [
        Placement(1, "sofa", "m", mesh, (-0.6, 0.0, 1.2), math.radians(20), 0.9, "floor"),
        Placement(2, "sofa", "m", mesh, (1.0, 0.0, 2.2), math.radians(-30), 0.8, "floor"),
    ]
    camera = Camera.from_vfov(96, 72, 60.0)
    panoptic, depth = _scene(truth, camera)
    start = Placements(objects=[truth[0], replace(truth[1], yaw=math.radians(150))])  # the second faces away
    targets = object_targets(start, panoptic, depth, (camera.width, camera.height))
    model = PoseModel(start, ROOM, unit=3.0)
    meshes = {
        k: TriangleMesh(v.detach().numpy(), model.welded[i].faces) for i, (k, v) in enumerate(model.vertices().items())
    }
    renderer = MitsubaRenderer(spp=4).geometry(camera, C2W, meshes, {k: i for i, k in enumerate(meshes)})
    t_masks = torch.from_numpy(targets.masks)

    def mismatch() -> torch.Tensor:
        masks, _, _ = renderer.render(model.vertices(), 0)
        return (masks - t_masks).abs().sum(dim=(1, 2))

    assert try_yaw_turns(model, mismatch, angles=[180.0, 90.0, -90.0], min_gain=1.0) == {}  # nothing gains it all
    assert model.theta["yaw"].detach().tolist() == [0.0, 0.0]
    assert try_yaw_turns(model, mismatch, angles=[180.0, 90.0, -90.0], min_gain=0.1) == {2: 180.0}
    assert model.theta["yaw"].detach().tolist() == [0.0, 180.0]


def test_back_shown_is_how_square_on_a_pose_turns_its_back_to_the_camera() -> None:
    towards = (0.0, 3.0)  # the camera looks along +Z at the model
    assert back_shown(math.sin(0.0), math.cos(0.0), *towards) == pytest.approx(1.0)  # front (+Z) away: back square on
    assert back_shown(math.sin(math.pi), math.cos(math.pi), *towards) == 0.0  # front to the camera
    assert back_shown(math.sin(math.pi / 2), math.cos(math.pi / 2), *towards) == pytest.approx(0.0, abs=1e-9)  # side
    assert back_shown(math.sin(math.pi / 4), math.cos(math.pi / 4), *towards) == pytest.approx(math.sqrt(0.5))


def test_the_wall_a_model_backs_onto_is_the_nearest() -> None:
    """wall_gap: in a 6 m room, an object 1 m from the +Z wall backing onto it pays nothing, backing onto a side
    wall 3 m away 2 m, onto the far wall 5 m away 4 m; on floats, arrays and tensors, with a gradient that turns
    it towards the near wall."""
    gaps = [wall_gap(math.sin(math.radians(d)), math.cos(math.radians(d)), 0.0, 2.0, 3.0, 3.0) for d in (180, 90, 0)]
    assert gaps == pytest.approx([0.0, 2.0, 4.0])
    yaws = np.radians([180.0, 270.0])
    assert wall_gap(np.sin(yaws), np.cos(yaws), np.zeros(2), np.full(2, 2.0), 3.0, 3.0) == pytest.approx([0.0, 2.0])
    assert wall_gap(0.0, -1.0, 5.0, 2.0, 3.0, 3.0) == pytest.approx(1.0)  # outside: taken at the side wall
    yaw = torch.tensor(math.radians(150.0), requires_grad=True)
    gap = wall_gap(torch.sin(yaw), torch.cos(yaw), torch.tensor(0.0), torch.tensor(2.0), 3.0, 3.0)
    gap.backward()
    assert gap.item() > 0.0 and yaw.grad is not None and yaw.grad.item() < 0.0  # descent turns it to 180°


def test_a_box_the_mask_cannot_orient_is_posed_with_its_back_to_the_nearest_wall() -> None:
    """A cabinet with a square footprint looks the same turned a quarter turn, and shows the camera its side or
    its front at two of those turns alike, so neither its mask nor ``back_weight`` can say which wall it stands
    against. It stands 0.5 m from the room's far wall and 2 m from its side wall: the search poses it backing onto
    the far wall (without the wall term it takes the first of the turns that tie), and lists what the wall cost;
    with no room box there is no wall term."""
    cabinet = box_mesh(np.array([0.0, 0.4, 0.0]), np.array([0.4, 0.4, 0.4]))  # canonical: bottom at 0
    truth = pose_matrix(np.array([-1.0, 0.0, 2.5]), math.radians(180), 1.0)  # front to the camera, back to +Z
    nearest, points = _seen([(cabinet, truth)])
    mask, seen = nearest == 0, points[nearest == 0]
    params = SEARCH  # back_weight 0.5, wall_weight 0.1
    target = ViewTarget.build(CAMERA, C2W, mask, seen, seen, 160, room=ROOM)
    view = fit_view(target, cabinet.vertices, cabinet.faces, params, support_height=0.0, backed=True)
    turn = (math.degrees(view.yaw) - 180.0 + 180.0) % 360.0 - 180.0
    assert abs(turn) < 3.0 and view.iou > 0.95, (math.degrees(view.yaw), view.iou)
    assert view.terms["wall"] < 0.01 and np.linalg.norm(view.position - truth[:3, 3]) < 0.05
    plain = fit_view(target, cabinet.vertices, cabinet.faces, replace(params, wall_weight=0.0), 0.0, backed=True)
    assert "wall" not in plain.terms and abs(plain.error - view.error) < 0.01  # the wall decides, nothing else
    no_room = ViewTarget.build(CAMERA, C2W, mask, seen, seen, 160)
    assert "wall" not in fit_view(no_room, cabinet.vertices, cabinet.faces, params, support_height=0.0).terms


def test_eq3_pays_for_a_backed_object_backing_onto_a_far_wall() -> None:
    """PoseModel.wall_penalty: a cabinet 0.5 m from the -X wall backing onto it pays nothing, turned to back
    onto the far +Z wall the difference of the two distances; a sofa nothing; the yaw gets the gradient."""
    box = plain_box(0.4, 0.3, 0.4)
    placements = Placements(
        objects=[
            Placement(1, "cabinet", "m", box, (-2.5, 0.0, 1.0), math.radians(90), 1.0, "floor", category="cabinet"),
            Placement(2, "cabinet", "m", box, (-2.5, 0.0, 1.0), math.radians(170), 1.0, "floor", category="cabinet"),
            Placement(3, "sofa", "m", box, (-2.5, 0.0, 1.0), math.radians(170), 1.0, "floor", category="sofa"),
        ]
    )
    model = PoseModel(placements, ROOM, unit=3.0)
    penalty = model.wall_penalty()
    assert penalty[0].item() == pytest.approx(0.0, abs=1e-6) and penalty[2].item() == 0.0
    assert penalty[1].item() == pytest.approx(2.0 / math.cos(math.radians(10.0)) - 0.5, abs=1e-4)
    penalty.sum().backward()
    assert model.theta["yaw"].grad[1].item() != 0.0


def test_a_bed_the_mask_cannot_orient_is_posed_with_its_back_away_from_the_camera() -> None:
    """A plain box looks the same turned 180°: its mask and depth cannot say which end is the headboard. A bed
    stands with its back to a wall, so the search poses it showing the camera its front (the truth's 180° twin),
    and lists what the back cost; a sofa (not backed) is free to come out either way."""
    bed = box_mesh(np.array([0.0, 0.3, 0.0]), np.array([0.8, 0.3, 1.05]))  # canonical: bottom at 0
    truth = pose_matrix(np.array([0.3, 0.0, 2.6]), math.radians(15), 1.0)  # its front (+Z) away from the camera
    nearest, points = _seen([(bed, truth)])
    target = ViewTarget.build(CAMERA, C2W, nearest == 0, points[nearest == 0], points[nearest == 0], 160)
    params = replace(SEARCH, wall_weight=0.0)  # back_weight 0.5
    view = fit_view(target, bed.vertices, bed.faces, params, support_height=0.0, backed=True)
    turn = (math.degrees(view.yaw) - 195.0 + 180.0) % 360.0 - 180.0
    assert abs(turn) < 3.0 and view.iou > 0.95, (math.degrees(view.yaw), view.iou)
    assert view.terms["back"] < 0.01 and np.linalg.norm(view.position - truth[:3, 3]) < 0.05
    assert "back" not in fit_view(target, bed.vertices, bed.faces, params, support_height=0.0).terms


def test_eq3_pays_for_a_backed_object_showing_its_back() -> None:
    """PoseModel.back_penalty: a bed facing away from the camera pays about 1, turned round 0; a sofa and a wall
    cabinet (which faces into the room whatever) nothing; and the yaw gets the gradient that turns the bed."""
    box = plain_box(0.8, 0.3, 1.0)
    placements = Placements(
        objects=[
            Placement(1, "bed", "m", box, (0.0, 0.0, 2.0), math.radians(10), 1.0, "floor", category="bed"),
            Placement(2, "bed", "m", box, (1.5, 0.0, 1.0), math.radians(190), 1.0, "floor", category="bed"),
            Placement(3, "sofa", "m", box, (-1.5, 0.0, 1.0), 0.0, 1.0, "floor", category="sofa"),
            Placement(4, "cabinet", "m", box, (0.0, 1.0, 2.9), math.pi, 0.3, "wall", anchor=3, category="cabinet"),
        ]
    )
    model = PoseModel(placements, ROOM, unit=3.0)
    penalty = model.back_penalty()
    assert penalty[0].item() > 0.95 and penalty[1].item() == 0.0 and penalty[2:].tolist() == [0.0, 0.0]
    penalty.sum().backward()
    assert model.theta["yaw"].grad[0].item() != 0.0


def test_eq3_terms_add_up_to_each_objects_loss_and_are_the_documented_ones() -> None:
    """ObjectLoss: each object's term is the sum of the weighted terms the log names (the blurred-mask term times
    ``blur_weight``), the log names the terms of pose_model's eq. 3, and each weight it takes is a ``fit_objects``
    setting its parameter table lists."""
    from psdr_room_core.method import pose_model
    from psdr_room_core.method.pose_model import ObjectLoss
    from psdr_room_core.method.stages.settings import FitObjects

    box = plain_box(0.4, 0.3, 0.4)
    placements = Placements(
        objects=[
            Placement(1, "cabinet", "m", box, (-2.4, 0.0, 1.0), math.radians(10), 3.0, "floor", category="cabinet"),
            Placement(2, "chair", "m", box, (-2.0, 0.0, 1.0), 0.0, 1.0, "floor", category="chair"),
        ]
    )
    model = PoseModel(placements, ROOM, unit=3.0)

    class Square:
        """Every object rendered as the same square at 2 m."""

        def render(self, vertices: object, iteration: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
            masks = torch.zeros(2, 20, 20)
            masks[:, 5:15, 5:15] = 1.0
            return masks, 2.0 * masks[0], masks[0]

    target = np.zeros((2, 20, 20), np.float32)
    target[:, 8:18, 6:16] = 1.0
    targets = ObjectTargets(
        masks=target, masked_depth=2.5 * target, weights=np.ones_like(target), boxes=np.full((2, 4), np.nan)
    )
    weights = {"scale_weight": 0.1, "range_weight": 0.2, "room_weight": 0.3, "collision_weight": 2.0}
    weights.update(back_weight=0.5, wall_weight=0.01)
    loss = ObjectLoss(model, Square(), targets, blur_sigmas=(2.0, 4.0), blur_weight=0.5, **weights)
    terms = loss(0)
    logged = dict(terms.logged)
    assert 0.0 < logged.pop("mean_iou") < 1.0 and all(v > 0.0 for v in logged.values()), logged  # each term counts
    logged["blurred_mask_l1"] *= 0.5
    assert terms.per_object.sum().item() == pytest.approx(sum(logged.values()), rel=1e-6)
    documented = pose_model.__doc__ or ""
    assert all(f" {name} " in documented for name in logged)
    settings = {f.name for f in fields(FitObjects)}
    for name in ("blur_sigmas", "blur_weight", *weights):
        setting = name if name in settings else f"size_prior.{name}"
        assert setting.split(".")[0] in settings and f"``{setting}``" in documented, setting


def test_an_object_the_fit_pushed_off_its_segment_goes_back_to_its_placed_pose() -> None:
    """restore_lost: of two objects the fit moved, the one left explaining a tenth of what it explained when placed
    gets its placed pose back (every fit parameter zeroed); the one still explaining most of it keeps its fit."""
    mesh = l_shape()
    start = Placements(
        objects=[
            Placement(1, "sofa", "m", mesh, (-0.6, 0.0, 1.2), 0.3, 0.9, "floor"),
            Placement(2, "sofa", "m", mesh, (1.0, 0.0, 2.2), -0.5, 0.8, "floor"),
        ]
    )
    model = PoseModel(start, ROOM, unit=3.0)
    with torch.no_grad():
        for values in model.theta.values():
            values += 0.5
    no_box = np.full(2, np.nan)
    placed, fitted = Explained(np.array([0.9, 0.8]), no_box), Explained(np.array([0.09, 0.7]), no_box)
    assert restore_lost(model, placed, fitted, share=0.5, same_box=0.5, size_tolerance=0.15) == [0]
    assert model.theta["log_scale"].tolist() == [0.0, 0.5] and model.theta["yaw"].tolist() == [0.0, 0.5]
    assert model.theta["translation"][0].tolist() == [0.0, 0.0, 0.0]
    with torch.no_grad():
        first, second = model.placements_now()
    assert first.position == pytest.approx(start.objects[0].position) and first.scale == pytest.approx(0.9)
    assert second.position != pytest.approx(start.objects[1].position)


def test_an_object_the_fit_took_off_its_prompt_box_goes_back_to_its_placed_pose() -> None:
    """A cut that lost a chair's thin legs is fitted by a smaller chair farther away: its render still explains
    the cut (no loss of render IoU), but its box, which matched the detector's box reaching the floor when
    placed, no longer does. It gets its placed pose back; an object whose box never matched its prompt box, and
    one with no prompt box, keep their fit."""
    mesh = l_shape()
    start = Placements(
        objects=[
            Placement(i, "chair", "m", mesh, (x, 0.0, 2.0), 0.0, 0.8, "floor")
            for i, x in ((1, -1.0), (2, 0.0), (3, 1.0))
        ]
    )
    model = PoseModel(start, ROOM, unit=3.0)
    with torch.no_grad():
        for values in model.theta.values():
            values += 0.5
    placed = Explained(np.array([0.5, 0.5, 0.5]), np.array([0.8, 0.4, np.nan]))
    fitted = Explained(np.array([0.7, 0.7, 0.7]), np.array([0.4, 0.3, np.nan]))
    assert restore_lost(model, placed, fitted, share=0.5, same_box=0.5, size_tolerance=0.15) == [0]
    assert model.theta["log_scale"].tolist() == [0.0, 0.5, 0.5]


def test_an_object_the_fit_took_outside_its_real_sizes_goes_back_to_its_placed_pose() -> None:
    """A chair the frame cuts, halved by the fit to match a depth that may be off, would be dropped by the
    settling as no chair's size: it gets its placed pose back. One placed outside its sizes already, and one the
    fit shrank within them, keep their fit."""
    block = box_mesh(np.array([0.0, 0.45, 0.0]), np.array([0.25, 0.45, 0.25]))  # a real chair's size at scale 1
    chair = ObjectMesh(block.vertices, block.faces, np.zeros(12, int), ("frame",), np.array([[0.5, 0.5, 0.5]]))
    start = Placements(
        objects=[
            Placement(i, "chair", "m", chair, (x, 0.0, 2.5), 0.0, scale, "floor", category="chair")
            for i, x, scale in ((1, -1.0, 1.0), (2, 0.0, 0.4), (3, 1.0, 1.0))
        ]
    )
    model = PoseModel(start, ROOM, unit=3.0)
    with torch.no_grad():
        model.theta["log_scale"][:] = torch.tensor([math.log(0.3), math.log(0.9), math.log(0.9)])
    same = Explained(np.full(3, 0.6), np.full(3, np.nan))
    assert restore_lost(model, same, same, share=0.5, same_box=0.5, size_tolerance=0.15) == [0]
    assert model.placements_now()[0].scale == pytest.approx(1.0)
    assert [p.scale for p in model.placements_now()[1:]] == pytest.approx([0.36, 0.9])


def test_a_restore_that_costs_the_settling_an_object_is_undone() -> None:
    """settle_restored: chair 1 restored to its placed pose passes through table 2, which the fit moved beside it,
    and the settling drops the table: chair 1 gets its fitted pose back and the scene is settled again. Chair 3,
    restored far from anything dropped, keeps its placed pose; and where the settling drops nothing, nothing is
    undone and the scene is settled once."""
    mesh = l_shape()

    def at(segment: int, x: float) -> Placement:
        return Placement(segment, "chair", "m", mesh, (x, 0.0, 2.0), 0.0, 1.0, "floor")

    posed = [at(1, 0.0), at(2, 0.3), at(3, 3.0)]
    fitted = [at(1, -1.5), posed[1], at(3, 3.5)]
    seen: list[list[float]] = []

    def settle_dropping_2(objects: list[Placement]) -> Settled:
        seen.append([p.position[0] for p in objects])
        left = objects if len(seen) > 1 else [p for p in objects if p.segment_id != 2]
        return Settled(left, ROOM, dropped=["2:chair (m): passes through 1"] * (len(seen) == 1))

    settled, undone = settle_restored(posed, fitted, [0, 2], settle_scene=settle_dropping_2, penetration=0.03)
    assert undone == [0] and seen == [[0.0, 0.3, 3.0], [-1.5, 0.3, 3.0]]
    assert [p.segment_id for p in settled.placements] == [1, 2, 3]

    seen.clear()
    seen.append([])  # a settling that drops nothing
    settled, undone = settle_restored(posed, fitted, [0, 2], settle_scene=settle_dropping_2, penetration=0.03)
    assert undone == [] and len(seen) == 2 and settled.placements == posed


def test_what_a_render_explains_of_its_segment_and_prompt_box() -> None:
    """Render IoU with the segment's mask, and box IoU of the render (pixels over half covered) with the prompt
    box; NaN without a prompt box or where nothing is rendered."""
    target = np.zeros((3, 20, 20), np.float32)
    target[:, 5:10, 5:15] = 1.0  # a cut that stops at the seat
    boxes = np.array([[5.0, 5.0, 15.0, 15.0], [5.0, 5.0, 15.0, 15.0], [np.nan] * 4])
    targets = ObjectTargets(masks=target, masked_depth=target, weights=np.ones_like(target), boxes=boxes)
    rendered = torch.zeros(3, 20, 20)
    rendered[:, 5:15, 5:15] = 1.0  # the whole chair, down to the floor
    rendered[1] = 0.0
    out = explained_by(rendered, targets)
    assert out.mask.tolist() == pytest.approx([0.5, 0.0, 0.5])
    assert out.box[0] == pytest.approx(1.0) and np.isnan(out.box[1]) and np.isnan(out.box[2])


@pytest.mark.parametrize(
    "model_id, yaw_deg",
    [
        ("parametric/chair_004", 40.0),
        ("kenney/loungeSofaCorner", 200.0),
        ("parametric/cabinet_005", 170.0),
        ("parametric/desk_005", 125.0),
    ],
)
def test_silhouette_retrieval_ranks_the_true_model_first(model_id: str, yaw_deg: float) -> None:
    """A rendered view (mask and depth) of a database model, away from the sweep's rotations: among every
    model of its category, none explains it better than that model (a near twin may tie: within 0.1%). The cabinet
    shows its front: it stands with its back to a wall."""

    retriever = _silhouette()
    mesh = retriever.mesh(model_id)
    category = retriever.database.record(model_id).category
    truth = pose_matrix(np.array([0.2, 0.0, 2.0 + mesh.extent[2]]), math.radians(yaw_deg), 1.0)
    mask, points = _seen_points(mesh, truth)
    query = ObjectQuery(1, category, (category,), mask, points, np.zeros((4, 4, 3), np.uint8), points)
    ranked = retriever.rank(query, CAMERA, C2W, 5)
    true = next((c for c in ranked if c.model_id == model_id), None)
    assert true is not None and true.score >= 0.999 * ranked[0].score, [(c.model_id, round(c.score, 4)) for c in ranked]
    assert len(retriever.database.category(category)) >= 10 and ranked[0].score > ranked[2].score


def test_guessed_objects_no_model_explains_are_dropped_drawn_ones_kept(tmp_path: Path) -> None:
    """place_objects.prune: a segment the layout segmentation guessed (it has a score) that no posed model
    explains (a flat patch of floor) is dropped; the same patch drawn by a person (no score) is kept, and a
    guessed chair the chair model explains stays."""
    from psdr_room_core.method.artifacts import Candidate, ObjectCandidates, PointCloud
    from psdr_room_core.method.stages.objects.place import place_objects

    chair_id = "parametric/chair_004"
    retriever = _silhouette()
    chair = retriever.mesh(chair_id)
    chair_mask, chair_points = _seen_points(chair, pose_matrix(np.array([-0.6, 0.0, 1.0]), math.radians(30), 1.0))
    rays = CAMERA.pixel_rays() @ C2W[:3, :3].T  # world directions, camera at C2W's origin
    floor_points = C2W[:3, 3] + rays * (-C2W[1, 3] / rays[..., 1:2])
    ids = np.ones((CAMERA.height, CAMERA.width), np.int32)  # 1: floor (and the wall above the horizon)
    ids[chair_mask] = 5
    ids[100:106, 90:130] = 6  # a thin strip of floor the layout guessed an object
    ids[108:114, 90:130] = 7  # the same, drawn by a person
    segments = [
        Segment(1, "floor", "floor"),
        Segment(5, "object", "chair", 0.6, (0.0, 0.0, 160.0, 120.0)),
        Segment(6, "object", "chair", 0.2),
        Segment(7, "object", "chair"),
    ]
    points = np.where(ids[..., None] == 5, 0.0, floor_points)
    points[chair_mask] = chair_points
    below = floor_points[..., 1] < 1e-6
    keep = (ids > 1) | below
    camera_points = (points[keep] - C2W[:3, 3]) @ C2W[:3, :3]
    cloud = PointCloud(
        points=camera_points.astype(np.float32),
        colors=np.zeros((keep.sum(), 3), np.uint8),
        segment=ids[keep],
        segments=segments,
    )
    candidates = ObjectCandidates(
        ranked={k: [Candidate(chair_id, 1.0)] for k in (5, 6, 7)}, labels={k: "chair" for k in (5, 6, 7)}
    )
    quick = {"n_yaw": 8, "refine": 2, "coarse": 1, "polish": 1, "halvings": 1, "turns": [], "wall_weight": 0.0}
    params = {
        **shipped.node("place_objects"),
        "search": {**shipped.node("place_objects.search"), **quick},
        "min_pixels": 100,
        "support": {**shipped.node("place_objects.support"), "grounded": ["chair"], "floor_only": ["chair"]},
    }
    ctx = StageContext(
        stage="place_objects",
        params=params,
        seed=0,
        photo=tmp_path / "photo.png",
        implementations={"retrieval": retriever},
    )
    out = place_objects(
        ctx,
        candidates,
        Image(rgb=np.full((120, 160, 3), 0.5, np.float32)),
        Panoptic(ids=ids, segments=segments),
        cloud,
        CAMERA,
        ROOM,
    )
    assert sorted(p.segment_id for p in out.objects) == [5, 7]
    assert len(out.extra["pruned"]) == 1 and out.extra["pruned"][0].startswith("6:chair"), out.extra["pruned"]
