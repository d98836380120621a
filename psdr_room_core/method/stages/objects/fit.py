"""The joint refinement of all object poses (paper §4.3, "Refining geometry", eq. 3): differentiable rendering of
their masks and depth (:mod:`~psdr_room_core.method.pose_model`), then the scene made physically possible."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import asdict, replace
from functools import partial
from typing import Any

import numpy as np
import torch

from psdr_room_core.engine.dag import StageContext

from ...artifacts import Camera, DepthMap, Image, OptimizationLog, Panoptic, Placement, Placements, RoomBox
from ...capabilities import Optimizer, Renderer
from ...convergence import BestIterate, untimed
from ...physical import Settled, interpenetrations, prompt_scores, settle_logged, weak_guesses
from ...pose_model import Explained, ObjectLoss, ObjectTargets, PoseModel, explained_by, object_targets
from ...sizes import size_excess
from ...solids import overlap
from ...visualize import object_fit_pictures
from ..settings import FitObjects

log = logging.getLogger("psdr_room")


def fit_objects(
    ctx: StageContext,
    placements: Placements,
    camera: Camera,
    room: RoomBox,
    depth: DepthMap,
    panoptic: Panoptic,
    image: Image,
) -> dict[str, Any]:
    """Refine all object poses jointly (§4.3, eq. 3: :mod:`~psdr_room_core.method.pose_model`) by differentiable
    rendering of their masks and depth, with the ``renderer`` and the ``optimizer``.

    The fit runs until the yaw test (or a plateau of the loss before it), then, where an object turned
    (:func:`try_yaw_turns`) or the loss had not flattened, on to ``iterations`` (or a plateau); each phase leaves
    its best iterate. An object the fit lost goes back to its placed pose (:func:`restore_lost`) unless that
    costs the settling an object (:func:`settle_restored`). The fitted scene is then made physically possible
    (:func:`~psdr_room_core.method.physical.settle`): real sizes, inside the room (which grows where an object
    the photo shows cannot be brought inside it: the room box after the objects, ``room``), no interpenetration
    beyond ``physical.penetration``, duplicates dropped; what remains passing through something is reported."""
    if not placements.objects:
        empty = OptimizationLog(history=[], images={}, summary={"objects": 0})
        return {"placements": placements, "log": empty, "room": room}
    settings = ctx.settings(FitObjects)
    # set up: eq. 3's targets at the render's size, the pose model and its loss
    cam = camera.resized(min(settings.render_width, camera.width))
    targets = object_targets(placements, panoptic, depth, (cam.width, cam.height))
    weak = weak_guesses(prompt_scores(panoptic), settings.physical.weak_score)
    model = PoseModel(placements, room, unit=float(np.mean(room.half_size)), weak=weak)
    object_loss = _object_loss(ctx, model, targets, camera=cam, room=room, settings=settings)
    # optimise eq. 3, the yaw test between its two phases
    with torch.no_grad():
        explained_placed = explained_by(object_loss(0).masks, targets)
    history, best, turned = _minimise(ctx, model, object_loss=object_loss, settings=settings)
    # decide: what the fit lost back in its placed pose, then the scene made physically possible
    settled, kept = _settled_with_restores(
        model,
        object_loss,
        targets=targets,
        explained_placed=explained_placed,
        iteration=len(history),
        settle_scene=partial(
            settle_logged,
            room=room,
            camera=cam,
            panoptic=panoptic,
            physical=settings.physical,
            stage="fit_objects",
            final=True,
        ),
        settings=settings,
    )
    # report
    through = interpenetrations(settled.placements, settings.physical.penetration)
    history = untimed(history, ctx.timings)
    result = Placements(
        objects=settled.placements,
        extra={
            "interpenetrations": through,
            "turned": turned,
            "kept_placed": kept,
            "final": history[best.iteration],
            "dropped": settled.dropped,
            "settled": settled.changed,
        },
    )
    record = _fit_log(
        history,
        best.iteration,
        image=image,
        camera=camera,
        room=room,
        panoptic=panoptic,
        before=placements,
        after=result,
    )
    return {"placements": result, "log": record, "room": settled.room}


def _object_loss(
    ctx: StageContext, model: PoseModel, targets: ObjectTargets, *, camera: Camera, room: RoomBox, settings: FitObjects
) -> ObjectLoss:
    """Eq. 3 of ``model``'s poses against ``targets``, rendered by the ``renderer`` in ``camera`` (the fit's),
    weighted as ``settings`` say."""
    meshes = model.meshes()
    parts = {name: i for i, name in enumerate(meshes)}
    renderer = ctx.impl("renderer", Renderer).geometry(camera, np.asarray(room.camera_to_world), meshes, parts)
    return ObjectLoss(
        model,
        renderer,
        targets,
        blur_sigmas=tuple(settings.blur_sigmas),
        blur_weight=settings.blur_weight,
        scale_weight=settings.size_prior.scale_weight,
        range_weight=settings.size_prior.range_weight,
        room_weight=settings.room_weight,
        collision_weight=settings.collision_weight,
        back_weight=settings.back_weight,
        wall_weight=settings.wall_weight,
    )


def _minimise(
    ctx: StageContext, model: PoseModel, *, object_loss: ObjectLoss, settings: FitObjects
) -> tuple[list[dict[str, float]], BestIterate, dict[int, float]]:
    """Eq. 3 minimised by the ``optimizer`` until the yaw test (or a plateau of the loss before it) and, where an
    object turned or the loss had not flattened, on to ``iterations`` (or a plateau), each phase leaving its best
    iterate in ``model`` (turned poses are a new start: the best is theirs). Returns the per-iteration log, the
    best iterate and the turns (segment id → degrees)."""
    best = BestIterate(model.theta)

    def loss(iteration: int) -> tuple[torch.Tensor, dict[str, float]]:
        terms = object_loss(iteration)
        total = terms.per_object.sum()
        best.observe(float(total.detach()), iteration)
        return total, terms.logged

    iterations, plateau = settings.iterations, settings.convergence
    optimizer, rates = ctx.impl("optimizer", Optimizer), asdict(settings.learning_rates)
    phase = round(iterations * settings.yaw_test.at)
    history = optimizer.minimize(model.theta, rates, loss, phase, lambda it: ctx.progress(it, total=phase), plateau)
    first = len(history)
    best.restore()
    turned = try_yaw_turns(
        model,
        lambda: object_loss(first).per_object,
        angles=settings.yaw_test.angles,
        min_gain=settings.yaw_test.min_gain,
    )
    if turned or first == phase:  # turned poses are a new start (the best is theirs); or not converged yet
        if turned:
            best = BestIterate(model.theta)
        history += optimizer.minimize(
            model.theta,
            rates,
            lambda it: loss(first + it),
            iterations - first,
            lambda it: ctx.progress(it, total=iterations - first),
            plateau,
        )
        best.restore()
    return history, best, turned


def try_yaw_turns(
    model: PoseModel, evaluate: Callable[[], torch.Tensor], *, angles: list[float], min_gain: float
) -> dict[int, float]:
    """Turn each free-standing object by each of ``angles`` (degrees) in turn and keep a turn that lowers both
    its own loss term by at least ``min_gain`` (a share of it) and the joint loss; ``evaluate`` gives every
    object's term [P] (one fixed-seed render). Returns segment id → degrees turned.

    Masks and depth seen from one side leave a model's front and back (and, for boxy furniture, its side)
    nearly alike; gradient descent on yaw never crosses the ridge between them. A near-symmetric model's turn
    changes its term by less than the render's noise: ``min_gain`` keeps it as it is. Wall objects keep their
    orientation (they face into the room)."""
    turned: dict[int, float] = {}
    with torch.no_grad():
        best = evaluate()
        yaw = model.theta["yaw"]
        for i, p in enumerate(model.placements):
            if p.support == "wall":
                continue
            start = float(yaw[i])
            for angle in angles:
                yaw[i] = start + angle
                value = evaluate()
                if value[i] < (1.0 - min_gain) * best[i] and value.sum() < best.sum():
                    best, turned[p.segment_id] = value, angle
            yaw[i] = start + turned.get(p.segment_id, 0.0)
    return turned


def restore_lost(
    model: PoseModel,
    explained_placed: Explained,
    explained_fitted: Explained,
    *,
    share: float,
    same_box: float,
    size_tolerance: float,
) -> list[int]:
    """The objects the fit lost, put back in their placed pose (their fit parameters zeroed), by what their
    renders explain placed and fitted: those it left explaining less than ``share`` of what their render
    explained of their segment when placed, those whose render's box matched their prompt box (box IoU
    ``same_box`` or more: the one object there) when placed and no longer does, and those it took outside their
    category's real sizes (by more than ``size_tolerance``, log scale, which the settling drops) from a size
    inside them. The joint fit can push an object off its segment (out of a collision with a neighbour the
    photo shows in front of it, or shrunk by its size prior) where no gradient brings it back, it fits a cut
    mask that lost the thin legs or the base of a chair by a smaller chair farther away, whose box no longer
    reaches the floor where the detector's did, and it halves a chair the frame cuts to match a depth that may
    be off: eq. 3 must not lose what the placement found. Returns their indices."""

    def excess(p: Placement) -> float:
        return size_excess(p.category, np.ptp(p.mesh.vertices, axis=0), p.scale)

    now = model.placements_now()
    lost = [
        i
        for i in range(len(explained_placed.mask))
        if explained_fitted.mask[i] < share * explained_placed.mask[i]
        or (explained_placed.box[i] >= same_box and not explained_fitted.box[i] >= same_box)
        or excess(now[i]) > size_tolerance >= excess(model.placements[i])
    ]
    with torch.no_grad():
        for values in model.theta.values():
            values[lost] = 0.0
    return lost


def settle_restored(
    posed: list[Placement],
    fitted: list[Placement],
    restored: list[int],
    *,
    settle_scene: Callable[[list[Placement]], Settled],
    penetration: float,
) -> tuple[Settled, list[int]]:
    """Settle ``posed`` (``settle_scene``), in which the objects ``restored`` (indices) stand in their placed pose;
    where the settling drops a restored object, or one that passes through a restored object by more than
    ``penetration`` metres, those restores are undone (their ``fitted`` pose back) and the scene settled again.
    A placed pose the fit left was collision-free among the placed poses, not among the fitted ones: restoring it
    beside a neighbour the fit moved must not cost the scene that neighbour or itself. Returns the settled scene
    and the indices of the restores undone."""
    settled = settle_scene(posed)
    left = {p.segment_id for p in settled.placements}
    gone = [p for p in posed if p.segment_id not in left]
    undone = [
        i
        for i in restored
        if posed[i].segment_id not in left
        or any(overlap(posed[i], g).thickness > penetration for g in gone if g.segment_id != posed[i].segment_id)
    ]
    if not undone:
        return settled, []
    return settle_scene([fitted[i] if i in undone else p for i, p in enumerate(posed)]), undone


def _settled_with_restores(
    model: PoseModel,
    object_loss: ObjectLoss,
    *,
    targets: ObjectTargets,
    explained_placed: Explained,
    iteration: int,
    settle_scene: Callable[[list[Placement]], Settled],
    settings: FitObjects,
) -> tuple[Settled, list[str]]:
    """The fitted scene (its render ``iteration``'s seed) with the objects the fit lost back in their placed pose
    (:func:`restore_lost`), settled by ``settle_scene`` (:func:`settle_restored`); and the restores kept,
    described."""
    with torch.no_grad():
        explained_fitted = explained_by(object_loss(iteration).masks, targets)
        fitted = [replace(p, explained=float(iou)) for p, iou in zip(model.placements_now(), explained_fitted.mask)]
        restored = restore_lost(
            model,
            explained_placed,
            explained_fitted,
            share=settings.keep_share,
            same_box=settings.same_box,
            size_tolerance=settings.physical.size_tolerance,
        )
        ious = explained_by(object_loss(iteration).masks, targets).mask if restored else explained_fitted.mask
        posed = [replace(p, explained=float(iou)) for p, iou in zip(model.placements_now(), ious)]
    settled, undone = settle_restored(
        posed,
        fitted,
        restored,
        settle_scene=settle_scene,
        penetration=settings.physical.penetration,
    )
    kept = _restores_kept(
        model,
        restored,
        undone=undone,
        explained_placed=explained_placed,
        explained_fitted=explained_fitted,
        fitted_poses=fitted,
    )
    return settled, kept


def _restores_kept(
    model: PoseModel,
    restored: list[int],
    *,
    undone: list[int],
    explained_placed: Explained,
    explained_fitted: Explained,
    fitted_poses: list[Placement],
) -> list[str]:
    """The restores kept (``restored`` less ``undone``), each described by what its render explains placed and
    fitted and by its scales, and logged; the undone ones logged as such."""
    kept = []
    for i in restored:
        p = model.placements[i]
        why = (
            f"{p.segment_id}:{p.label} ({p.model_id.split('/')[-1]}): the fit left it explaining "
            f"{explained_fitted.mask[i]:.2f} of its segment ({explained_placed.mask[i]:.2f} placed), its box "
            f"{explained_fitted.box[i]:.2f} of its prompt box ({explained_placed.box[i]:.2f} placed), at scale "
            f"{fitted_poses[i].scale:.2f} ({p.scale:.2f} placed)"
        )
        if i in undone:
            log.info("fit_objects: kept the fitted pose of %s, as its placed pose cost the settling an object", why)
        else:
            kept.append(why)
            log.info("fit_objects: kept the placed pose of %s", why)
    return kept


def _fit_log(
    history: list[dict[str, float]],
    best_iteration: int,
    *,
    image: Image,
    camera: Camera,
    room: RoomBox,
    panoptic: Panoptic,
    before: Placements,
    after: Placements,
) -> OptimizationLog:
    """The fit's log: the per-iteration ``history``, its pictures (:func:`~..visualize.object_fit_pictures`) and
    a summary of the fitted scene ``after`` (its ``extra``) and its best iterate."""
    pictures = object_fit_pictures(
        image.to_uint8(), panoptic, camera, room, before=before, after=after, history=history
    )
    return OptimizationLog(
        history=history,
        images=pictures,
        summary={
            "objects": len(after.objects),
            "iterations": len(history),
            "initial": history[0],
            "interpenetrations": after.extra["interpenetrations"],
            "supports": {p.segment_id: p.support for p in after.objects},
            "turned": after.extra["turned"],
            "kept_placed": after.extra["kept_placed"],
            "final": after.extra["final"],
            "best_iteration": best_iteration,
            "dropped": after.extra["dropped"],
        },
    )
