"""Differentiable object poses and eq. 3's loss (paper §4.3, "Refining geometry").

Every object i has three parameters θ_i, all zero at its placed pose (:class:`PoseModel`): a translation
``t_i`` in units of ``u``, the room box's mean half-size (horizontal; along and up its wall for a wall
object), a log scale ``ln k_i`` (its scale is ``s_i = s_i⁰ · k_i``, ``s_i⁰`` the placed one) and a yaw
``ψ_i`` in degrees. Its support holds: a floor object's bottom stays on the floor, a child's on the spot of its
parent's surface it was placed on (that height scales with the parent), and a wall object slides and scales
along its wall, its back on it and its front facing into the room (its yaw is not optimised).

Eq. 3 as :class:`ObjectLoss` computes it, a term per object summed over the objects (right: each term's name
in the fit's log, and what computes it)::

    L_i =   L1_w(M_i^r · D^r, M_i^t · D_i) / d               mask_depth_l1       mask_depth_l1
          + w_blur · Σ_σ L1_w(G_σ(M_i^r), G_σ(M_i^t))         blurred_mask_l1     blurred_mask_l1
          + w_scale · |ln s_i| + w_range · out_i(ln s_i)     size_prior          PoseModel.size_penalty
          + w_room · R_i                                     beyond_room         PoseModel.room_penalty
          + w_collision · C_i                                interpenetration    PoseModel.collision_penalty
          + w_back · B_i                                     back_shown          PoseModel.back_penalty
          + w_wall · W_i                                     wall_gap            PoseModel.wall_penalty

``M_i^r`` is object i's rendered anti-aliased coverage and ``D^r`` the render's depth (its depth over its
coverage), ``M_i^t`` the segment's mask and ``D_i`` the depth of the segment's pixels that have one, both
area-filtered to the render's size (:class:`ObjectTargets`). ``L1_w`` is the mean over the pixels of ``|·|``
weighted by ``w_i``: 0 on the free pixels of a prompted segment (its prompt box outside its mask, where the
object may reach or not), 1 elsewhere. ``d`` is the 98th percentile of the targets' depth (the depth term is
unitless) and ``G_σ`` a Gaussian blur of standard deviation σ pixels (:func:`gaussian_pyramid_blur`).
``out_i`` is how far (log units) a scale lies outside the real sizes of the object's category
(:class:`~psdr_room_core.method.sizes.SizePrior`), ``R_i`` how far (metres) its mesh reaches beyond the room
box, ``C_i`` how deep (metres) it passes through the objects near it, ``B_i`` how far it shows the camera its
back and ``W_i`` how much farther (metres) the wall behind it is than the nearest wall, the last two only for
a piece that stands with its back to a wall (:mod:`~psdr_room_core.method.backs`). The paper's eq. 3 is the
first two terms; the others hold the fit to what a room can be.

Parameters (``fit_objects`` settings, :class:`~psdr_room_core.method.stages.settings.FitObjects`):

============================  ==============================================================  =====================
setting                       meaning                                                         unit
============================  ==============================================================  =====================
``render_width``              width of the renders and of the targets area-filtered to them   pixels
``blur_sigmas``               the σ of ``G_σ``                                                pixels (render)
``blur_weight``               ``w_blur``                                                      1
``size_prior.scale_weight``   ``w_scale``: a model is most likely its own size                per log unit
``size_prior.range_weight``   ``w_range``: a size outside its category's range                per log unit
``room_weight``               ``w_room``                                                      per metre
``collision_weight``          ``w_collision``                                                 per metre
``back_weight``               ``w_back`` (``B_i`` is 1 with the back square on)               1
``wall_weight``               ``w_wall``                                                      per metre
``physical.weak_score``       a prompt scored below it is a weak guess, which yields in C_i   score in [0, 1]
``learning_rates``            the optimizer's steps: ``translation``, ``log_scale``, ``yaw``  ``u``, log, degrees
============================  ==============================================================  =====================

Known limits:

- Masks and depth seen from one side leave a model's front and back (and, for boxy furniture, its side)
  nearly alike: gradient descent on ``ψ_i`` never crosses the ridge between them (the fit tries turns instead:
  :func:`~psdr_room_core.method.stages.objects.fit.try_yaw_turns`).
- The mask terms have gradients only through the render's edges and visibility: an object pushed off its
  segment (out of a collision, or shrunk by its size prior) gets none that bring it back (the fit puts such
  an object back: :func:`~psdr_room_core.method.stages.objects.fit.restore_lost`).
- ``C_i`` pays only for the pairs whose bounding spheres came within 0.25 m at the placed poses, neither
  standing on the other, each solid sampled at 200 to 400 of its voxel centres (all of a smaller one): pairs
  the fit brings together pass through each other freely, and thin parts may slip between the samples.
- A child keeps its own horizontal translation: it rides its parent's height and scale, not its moves.
- Each iteration's render is one estimate (its seed is the iteration): the loss is noisy, the fit keeps its
  best iterate.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import cv2
import numpy as np
import torch

from .artifacts import DepthMap, Panoptic, Placement, Placements, RoomBox, rotation_y, vec3
from .backs import BACKED, back_shown, wall_gap
from .capabilities import GeometryRenderer
from .geometry import TriangleMesh, weld
from .image_boxes import box_iou, mask_box
from .objects import wall_frame
from .sizes import scale_range
from .solids import field_lookup, solid_of


@dataclass(frozen=True)
class ObjectTargets:
    """Eq. 3's targets at render resolution: per-object coverage and the depth-weighted coverage."""

    masks: np.ndarray
    """[P,h,w] area-filtered masks of the objects' segments."""
    masked_depth: np.ndarray
    """[P,h,w] mask × mean depth of the segment's pixels with valid depth."""
    weights: np.ndarray
    """[P,h,w] how much each pixel counts in the object's terms: 0 on the free pixels of a prompted segment
    (its prompt box outside its mask: the object may reach there or not), 1 elsewhere."""
    boxes: np.ndarray
    """[P,4] each segment's prompt box (x0, y0, x1, y1) at render resolution; NaN where it has none."""


def object_targets(placements: Placements, panoptic: Panoptic, depth: DepthMap, size: tuple[int, int]) -> ObjectTargets:
    """:class:`ObjectTargets` of the placed objects' segments at ``size`` (width, height)."""

    def area(x: np.ndarray) -> np.ndarray:
        return cv2.resize(x.astype(np.float32), size, interpolation=cv2.INTER_AREA)

    boxes = {s.id: s.box for s in panoptic.segments}
    masks, masked, weights, prompts = [], [], [], []
    to_render = size[0] / panoptic.ids.shape[1]
    for p in placements.objects:
        mask = panoptic.ids == p.segment_id
        valid = mask & depth.valid
        weight = area(valid)
        mean_depth = np.where(weight > 0, area(np.where(valid, depth.depth, 0.0)) / np.maximum(weight, 1e-6), 0.0)
        coverage = area(mask)
        masks.append(coverage)
        masked.append(coverage * mean_depth)
        free = np.zeros(mask.shape, bool)
        box = boxes.get(p.segment_id)
        if box is not None:
            x0, y0, x1, y1 = (max(0, int(round(v))) for v in box)
            free[y0:y1, x0:x1] = True
        weights.append(1.0 - area(free & ~mask))
        prompts.append(np.full(4, np.nan) if box is None else np.asarray(box, np.float64) * to_render)
    return ObjectTargets(
        masks=np.stack(masks).astype(np.float32),
        masked_depth=np.stack(masked).astype(np.float32),
        weights=np.stack(weights).astype(np.float32),
        boxes=np.stack(prompts),
    )


@dataclass(frozen=True)
class Explained:
    """How well each object's render explains its segment."""

    mask: np.ndarray
    """[P] render IoU with the segment's mask."""
    box: np.ndarray
    """[P] IoU of the render's box with the segment's prompt box (the detector's box reaches the thin legs and
    the floor that a cut mask loses); NaN where the segment has no prompt box or the object is out of view."""


def mask_ious(masks: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """[P] soft IoU of each rendered mask [P,h,w] with its target coverage [P,h,w]."""
    return (masks * targets).sum((1, 2)) / (masks + targets - masks * targets).sum((1, 2)).clamp_min(1e-6)


def explained_by(masks: torch.Tensor, targets: ObjectTargets) -> Explained:
    """:class:`Explained` of rendered ``masks`` [P,h,w] (a pixel over half covered is in a render's box)."""
    ious = mask_ious(masks, torch.from_numpy(targets.masks))
    boxes = np.full(len(masks), np.nan)
    for i, (mask, prompt) in enumerate(zip(masks.numpy() > 0.5, targets.boxes)):
        box = mask_box(mask)
        if box is not None and not np.isnan(prompt).any():
            boxes[i] = box_iou(prompt, box[None])[0]
    return Explained(mask=ious.numpy(), box=boxes)


def gaussian_pyramid_blur(masks: torch.Tensor, sigmas: tuple[float, ...]) -> torch.Tensor:
    """[P,H,W] masks blurred by Gaussians of each sigma (pixels), stacked: [S,P,H,W]."""
    blurred = []
    for sigma in sigmas:
        radius = max(1, int(3 * sigma))
        x = torch.arange(-radius, radius + 1, dtype=torch.float32)
        kernel = torch.exp(-0.5 * (x / sigma) ** 2)
        kernel = kernel / kernel.sum()
        m = masks[:, None]
        m = torch.nn.functional.conv2d(
            torch.nn.functional.pad(m, (radius, radius, 0, 0), mode="replicate"), kernel.view(1, 1, 1, -1)
        )
        m = torch.nn.functional.conv2d(
            torch.nn.functional.pad(m, (0, 0, radius, radius), mode="replicate"), kernel.view(1, 1, -1, 1)
        )
        blurred.append(m[:, 0])
    return torch.stack(blurred)


def mask_depth_l1(
    masks: torch.Tensor, depth: torch.Tensor, masked_depth: torch.Tensor, weights: torch.Tensor
) -> torch.Tensor:
    """[P] eq. 3's first term before its depth scale: ``L1_w(M_i^r · D^r, M_i^t · D_i)`` of rendered ``masks``
    [P,h,w] and ``depth`` [h,w] against the targets' ``masked_depth`` [P,h,w], pixels weighted by ``weights``."""
    return (weights * (masks * depth - masked_depth).abs()).mean(dim=(1, 2))


def blurred_mask_l1(
    masks: torch.Tensor, blurred_targets: torch.Tensor, weights: torch.Tensor, sigmas: tuple[float, ...]
) -> torch.Tensor:
    """[P] eq. 3's second term before its weight: ``Σ_σ L1_w(G_σ(M_i^r), G_σ(M_i^t))`` of rendered ``masks``
    [P,h,w] against ``blurred_targets`` [S,P,h,w] (:func:`gaussian_pyramid_blur` of the targets' masks)."""
    return (weights * (gaussian_pyramid_blur(masks, sigmas) - blurred_targets).abs()).mean(dim=(2, 3)).sum(dim=0)


def _rotation(yaw: torch.Tensor) -> torch.Tensor:
    """R_y(yaw) as a differentiable 3x3 tensor."""
    c, s = torch.cos(yaw), torch.sin(yaw)
    zero, one = torch.zeros_like(c), torch.ones_like(c)
    return torch.stack([torch.stack([c, zero, s]), torch.stack([zero, one, zero]), torch.stack([-s, zero, c])])


def _near(a: Placement, b: Placement, margin: float = 0.25) -> bool:
    """Whether two objects' bounding spheres come within ``margin`` metres (they may touch while fitted)."""

    def sphere(p: Placement) -> tuple[np.ndarray, float]:
        v = p.world_vertices()
        return (v.min(axis=0) + v.max(axis=0)) / 2.0, 0.5 * float(np.linalg.norm(np.ptp(v, axis=0)))

    (ca, ra), (cb, rb) = sphere(a), sphere(b)
    return float(np.linalg.norm(ca - cb)) < ra + rb + margin


class PoseModel:
    """Differentiable object poses with their support constraints (module docstring): scale, horizontal
    translation and yaw per object (:attr:`theta`). :meth:`size_penalty` is the size prior of each object's
    category, :meth:`back_penalty` and :meth:`wall_penalty` what showing the camera its back and backing onto a
    far wall cost a piece that stands with its back to a wall; ``weak``: the segment ids of weak guesses, which
    yield in :meth:`collision_penalty`."""

    def __init__(self, placements: Placements, room: RoomBox, unit: float, weak: Collection[int] = ()) -> None:
        self.placements = placements.objects
        self.room = room
        self.unit = unit
        self.index = {p.segment_id: i for i, p in enumerate(self.placements)}
        self.rest = {
            i: (p.position[1] - self.placements[self.parent(p)].position[1]) / self.placements[self.parent(p)].scale
            for i, p in enumerate(self.placements)
            if p.support == "parent"
        }
        """Child index → its height above its parent's origin, in the parent's model units."""
        self.ranges = [scale_range(p.category, np.ptp(p.mesh.vertices, axis=0)) for p in self.placements]
        self.pairs = [
            (i, j)
            for i, a in enumerate(self.placements)
            for j, b in enumerate(self.placements)
            if i < j and a.anchor != b.segment_id and b.anchor != a.segment_id and _near(a, b)
        ]
        """Pairs of objects that may touch (neither stands on the other): their interpenetration is paid for."""
        self.weak = {i for i, p in enumerate(self.placements) if p.segment_id in weak}
        """The objects of weak guesses (``weak``: their segment ids): they yield to surer ones."""
        self.solids = {i: solid_of(self.placements[i]) for pair in self.pairs for i in pair}
        self.fields = {i: torch.from_numpy(solid.depth)[None, None] for i, solid in self.solids.items()}
        self.samples = {
            i: torch.from_numpy(solid.centres[:: max(1, len(solid.centres) // 200)]) for i, solid in self.solids.items()
        }
        n = len(self.placements)
        self.theta = {
            "translation": torch.zeros(n, 3, requires_grad=True),
            "log_scale": torch.zeros(n, requires_grad=True),
            "yaw": torch.zeros(n, requires_grad=True),
        }
        self.welded = [weld(TriangleMesh(p.mesh.vertices, p.mesh.faces)) for p in self.placements]
        self.backed = [p.category in BACKED and p.support != "wall" for p in self.placements]
        """Per object: it stands with its back to a wall and may turn (wall objects face into the room)."""

    def parent(self, placement: Placement) -> int:
        """The index of the object ``placement`` rests on (its support is ``parent``)."""
        assert placement.anchor is not None
        return self.index[placement.anchor]

    def poses(self) -> list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]]:
        """(position [3], yaw (radians), scale) per object, constraints applied."""
        t, log_s, yaw_deg = self.theta["translation"], self.theta["log_scale"], self.theta["yaw"]
        poses: list[Any] = [None] * len(self.placements)
        order = sorted(range(len(self.placements)), key=lambda i: self.placements[i].support == "parent")
        for i in order:
            p = self.placements[i]
            scale = p.scale * torch.exp(log_s[i])
            position = torch.tensor(p.position, dtype=torch.float32)
            yaw = p.yaw + torch.deg2rad(yaw_deg[i])
            if p.support == "wall":
                assert p.anchor is not None  # a wall support names its side of the box
                frame = wall_frame(self.room, p.anchor)
                inward, tangent = (torch.as_tensor(v, dtype=torch.float32) for v in frame[:2])
                offset = frame[2]
                depth = float(np.ptp(p.mesh.vertices[:, 2]))
                moved = position + self.unit * (t[i, 0] * tangent + t[i, 1] * torch.tensor([0.0, 1.0, 0.0]))
                position = moved + (offset + 0.5 * scale * depth - inward @ moved) * inward
                yaw = torch.tensor(p.yaw, dtype=torch.float32)
            else:
                horizontal = self.unit * torch.stack([t[i, 0], torch.zeros(()), t[i, 2]])
                position = position + horizontal
                if p.support == "parent":
                    parent_position, _, parent_scale = poses[self.parent(p)]
                    top = parent_position[1] + parent_scale * self.rest[i]
                    position = torch.stack([position[0], top, position[2]])
            poses[i] = (position, yaw, scale)
        return poses

    def vertices(self) -> dict[str, torch.Tensor]:
        """World positions of each object's welded mesh."""
        out = {}
        for i, (position, yaw, scale) in enumerate(self.poses()):
            local = torch.as_tensor(self.welded[i].vertices, dtype=torch.float32)
            out[f"object_{self.placements[i].segment_id}"] = (scale * local) @ _rotation(yaw).T + position
        return out

    def meshes(self) -> dict[str, TriangleMesh]:
        """Each object's welded mesh at its current pose, by its name in :meth:`vertices`."""
        vertices = {name: v.detach().numpy() for name, v in self.vertices().items()}
        return {name: TriangleMesh(vertices[name], self.welded[i].faces) for i, name in enumerate(vertices)}

    def size_penalty(self, scale_weight: float, range_weight: float) -> torch.Tensor:
        """[P] each object's size prior (:class:`~psdr_room_core.method.sizes.SizePrior`) at its current scale."""
        log_scale = torch.stack([torch.log(scale) for _, _, scale in self.poses()])
        low = torch.tensor([math.log(lo) if lo > 0 else -math.inf for lo, _ in self.ranges])
        high = torch.tensor([math.log(hi) for _, hi in self.ranges])
        outside = torch.relu(low - log_scale) + torch.relu(log_scale - high)
        return scale_weight * log_scale.abs() + range_weight * outside

    def back_penalty(self) -> torch.Tensor:
        """[P] how far each object that stands with its back to a wall shows the camera its back
        (:func:`~psdr_room_core.method.backs.back_shown`; 0 for the others)."""
        eye = np.asarray(self.room.camera_to_world)[:3, 3]
        shown = [
            back_shown(torch.sin(yaw), torch.cos(yaw), position[0] - float(eye[0]), position[2] - float(eye[2]))
            if backed
            else torch.zeros(())
            for (position, yaw, _), backed in zip(self.poses(), self.backed)
        ]
        return torch.stack(shown)

    def wall_penalty(self) -> torch.Tensor:
        """[P] how much farther (metres) than the nearest wall the wall behind each object that stands with its back
        to one is (:func:`~psdr_room_core.method.backs.wall_gap`; 0 for the others)."""
        centre, half = np.asarray(self.room.center), np.asarray(self.room.half_size)
        turn, sine, cosine = float(self.room.yaw), math.sin(self.room.yaw), math.cos(self.room.yaw)
        gaps = []
        for (position, yaw, _), backed in zip(self.poses(), self.backed):
            if not backed:
                gaps.append(torch.zeros(()))
                continue
            x, z = position[0] - float(centre[0]), position[2] - float(centre[2])  # into the room's frame: R_y(-yaw)
            local_x, local_z = cosine * x - sine * z, sine * x + cosine * z
            gaps.append(
                wall_gap(torch.sin(yaw - turn), torch.cos(yaw - turn), local_x, local_z, float(half[0]), float(half[2]))
            )
        return torch.stack(gaps)

    def collision_penalty(self) -> torch.Tensor:
        """[P] how deep each object passes through the others: for each pair, the mean depth (metres) of each
        one's sampled volume inside the other, both ways, half to each. Between a weak guess and a surer object
        (:attr:`weak`) the surer one's pose is held (no gradient): a guess never pushes what the photo is surer
        of, as in the settling (:func:`~psdr_room_core.method.physical.settle`)."""
        if not self.pairs:
            return torch.zeros(len(self.placements))
        moving = self.poses()
        partners: dict[tuple[int, bool], list[int]] = {}  # (a, a's pose held) → the others
        for i, j in self.pairs:
            for a, b in ((i, j), (j, i)):
                partners.setdefault((a, self.holds(a, b)), []).append(b)
        poses = {  # each solid's pose, and its held copy where a weak guess meets it
            (i, h): tuple(v.detach() for v in moving[i]) if h else moving[i] for i, h in partners
        }
        rotations = {key: _rotation(pose[1]) for key, pose in poses.items()}
        world = {key: pose[2] * self.samples[key[0]] @ rotations[key].T + pose[0] for key, pose in poses.items()}
        depth: dict[tuple[int, int], torch.Tensor] = {}  # (a, b): b's samples' mean depth inside a, metres
        for (a, a_held), others in partners.items():
            position, _, scale = poses[(a, a_held)]
            samples = torch.cat([world[(b, self.holds(b, a))] for b in others])
            inside = scale * field_lookup(
                self.solids[a], self.fields[a], (samples - position) @ rotations[(a, a_held)] / scale
            )
            for b, part in zip(others, torch.split(inside, [len(self.samples[b]) for b in others])):
                depth[(a, b)] = part.mean()
        shares: list[list[torch.Tensor]] = [[] for _ in self.placements]
        for i, j in self.pairs:
            half = 0.5 * (depth[(i, j)] + depth[(j, i)])
            shares[i].append(half)
            shares[j].append(half)
        return torch.stack([torch.stack(s).sum() if s else torch.zeros(()) for s in shares])

    def holds(self, a: int, b: int) -> bool:
        """Whether object ``a`` holds its pose against ``b``: ``b`` is a weak guess and ``a`` is not."""
        return a not in self.weak and b in self.weak

    def room_penalty(self, vertices: dict[str, torch.Tensor]) -> torch.Tensor:
        """[P] how far (metres) each object's mesh reaches beyond the room box, at its farthest vertex."""
        rotation = torch.as_tensor(rotation_y(self.room.yaw), dtype=torch.float32)
        centre = torch.as_tensor(np.asarray(self.room.center), dtype=torch.float32)
        half = torch.as_tensor(np.asarray(self.room.half_size), dtype=torch.float32)
        return torch.stack([torch.relu(((v - centre) @ rotation).abs() - half).max() for v in vertices.values()])

    def placements_now(self) -> list[Placement]:
        """The objects at their current poses."""
        return [
            replace(p, position=vec3(position.detach()), yaw=float(yaw.detach()), scale=float(scale.detach()))
            for p, (position, yaw, scale) in zip(self.placements, self.poses())
        ]


class ObjectTerms(NamedTuple):
    """Eq. 3 of one render."""

    per_object: torch.Tensor
    """[P] each object's term ``L_i``."""
    masks: torch.Tensor
    """[P,h,w] the rendered masks (detached)."""
    logged: dict[str, float]
    """Each term summed over the objects, weighted (the blurred-mask term before ``blur_weight``), by its name in
    the module docstring; and the mean render IoU (``mean_iou``)."""


class ObjectLoss:
    """Eq. 3 of ``model``'s current poses (module docstring), rendered by ``renderer`` (a geometry renderer of
    :meth:`PoseModel.meshes`) and compared with ``targets``; the weights are the settings of the same names."""

    def __init__(
        self,
        model: PoseModel,
        renderer: GeometryRenderer,
        targets: ObjectTargets,
        *,
        blur_sigmas: tuple[float, ...],
        blur_weight: float,
        scale_weight: float,
        range_weight: float,
        room_weight: float,
        collision_weight: float,
        back_weight: float,
        wall_weight: float,
    ) -> None:
        self.model, self.renderer = model, renderer
        self.blur_sigmas, self.blur_weight = blur_sigmas, blur_weight
        self.scale_weight, self.range_weight = scale_weight, range_weight
        self.room_weight, self.collision_weight = room_weight, collision_weight
        self.back_weight, self.wall_weight = back_weight, wall_weight
        self.target_masks = torch.from_numpy(targets.masks)
        self.target_masked_depth = torch.from_numpy(targets.masked_depth)
        self.pixel_weights = torch.from_numpy(targets.weights)
        covered = targets.masks > 0.5
        valid = targets.masked_depth[covered] / np.maximum(targets.masks[covered], 1e-6)
        self.depth_scale = float(np.percentile(valid, 98)) if valid.size else 1.0
        """``d``: the 98th percentile of the targets' depth (metres)."""
        self.target_blur = gaussian_pyramid_blur(self.target_masks, blur_sigmas)

    def __call__(self, iteration: int) -> ObjectTerms:
        """The terms of the render of ``iteration`` (its seed)."""
        model = self.model
        vertices = model.vertices()
        masks, weighted_depth, alpha = self.renderer.render(vertices, iteration)
        rendered_depth = weighted_depth / alpha.clamp_min(1e-3)
        depth_term = (
            mask_depth_l1(masks, rendered_depth, self.target_masked_depth, self.pixel_weights) / self.depth_scale
        )
        blur_term = blurred_mask_l1(masks, self.target_blur, self.pixel_weights, self.blur_sigmas)
        size_term = model.size_penalty(self.scale_weight, self.range_weight)
        room_term = self.room_weight * model.room_penalty(vertices)
        collision_term = self.collision_weight * model.collision_penalty()
        back_term = self.back_weight * model.back_penalty()
        wall_term = self.wall_weight * model.wall_penalty()
        ious = mask_ious(masks, self.target_masks)
        logged = {
            "mask_depth_l1": depth_term.sum().item(),
            "blurred_mask_l1": blur_term.sum().item(),
            "size_prior": size_term.sum().item(),
            "beyond_room": room_term.sum().item(),
            "interpenetration": collision_term.sum().item(),
            "back_shown": back_term.sum().item(),
            "wall_gap": wall_term.sum().item(),
            "mean_iou": ious.mean().item(),
        }
        per_object = (
            depth_term + self.blur_weight * blur_term + size_term + room_term + collision_term + back_term + wall_term
        )
        return ObjectTerms(per_object, masks.detach(), logged)
