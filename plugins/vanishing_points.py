"""Camera field of view from Manhattan vanishing points (offline, no learned model).

Pipeline:

1. detect line segments (LSD) on a downscaled grey image, after cropping a uniform
   frame (e.g. the white border of NYU frames); drop short segments and segments
   hugging the frame, merge collinear pieces;
2. propose vanishing-point (VP) candidates from length-weighted random pairs of
   segments, polish each on its inliers and keep a diverse set;
3. pair candidates over a grid of focal lengths, keeping pairs that are orthogonal
   for that focal, and complete each pair to a full Manhattan frame (rotation R and
   focal f, so the three VPs are K R e_k); score frames by length-weighted segment
   consistency with the three VPs;
4. refine the best frames by robust least squares over (log f, R), with a weak
   Gaussian prior on the vertical FoV that only matters when the lines do not
   determine the focal (e.g. both horizontal VPs near infinity);
5. fall back to ``fallback_vfov_deg`` when the photo has too few lines or no
   frame with at least two supported VPs.

Conventions: square pixels, principal point at the image centre, image y pointing
down. Internally image points use centred coordinates scaled by half the long side
of the working image, so K = diag(f, f, 1) with f in those units.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation


@dataclass(frozen=True)
class VanishingPointParams:
    """Tuning knobs of :func:`estimate_camera` (pixel values refer to the working image)."""

    max_side: int = 640
    """Lines are detected on an image resized so its long side is at most this."""
    min_segment_frac: float = 0.03
    """Drop segments shorter than this fraction of the image diagonal."""
    min_piece_frac: float = 0.01
    """LSD pieces shorter than this fraction of the diagonal are discarded before merging."""
    max_segments: int = 300
    """Keep at most this many segments (the longest) after merging."""
    frame_std: float = 4.0
    """Edge rows/columns whose grey-level std (0..255) is below this are a uniform frame and cropped."""
    max_frame_frac: float = 0.05
    """Never crop more than this fraction of the width/height per side as a frame."""
    border_margin_px: float = 4.0
    """Segments within this distance of the crop border and parallel to it are dropped."""
    merge_angle_deg: float = 1.5
    """Collinear pieces are merged when their directions differ by less than this ..."""
    merge_offset_px: float = 1.5
    """... their endpoints lie within this distance of the other's line ..."""
    merge_gap_frac: float = 0.02
    """... and the gap between them is below this fraction of the image diagonal."""
    length_power: float = 1.0
    """A segment's evidence weight is its length to this power (long edges are mostly structure)."""
    inlier_px: float = 1.5
    """Endpoint distance to the midpoint-VP line below which a segment supports a VP."""
    line_noise_px: float = 1.0
    """Assumed endpoint noise; scales the data residuals of the refinement."""
    n_vp_samples: int = 1500
    """Random segment pairs intersected to propose VP candidates."""
    n_vp_candidates: int = 20
    """Distinct VP candidates kept after non-maximum suppression."""
    candidate_overlap: float = 0.5
    """A candidate is a duplicate if this fraction of its support belongs to a kept one."""
    min_vfov_deg: float = 20.0
    """Smallest vertical FoV considered."""
    max_vfov_deg: float = 110.0
    """Largest vertical FoV considered."""
    vfov_step_deg: float = 2.0
    """Step of the focal grid used to pair VP candidates."""
    orthogonality_tol_deg: float = 6.0
    """Two candidates may form a frame at a grid focal if their directions are this close to 90 degrees."""
    max_tilt_deg: float = 45.0
    """One Manhattan axis must lie within this angle of the image's vertical axis (limited pitch/roll)."""
    n_refine: int = 6
    """Best distinct frames refined by least squares."""
    n_bootstrap: int = 200
    """Segment resamplings used to measure how ambiguous the choice between refined frames is."""
    refine_rounds: int = 3
    """Inlier reassignment rounds of the refinement."""
    min_segments: int = 12
    """Fewer usable segments than this gives the fallback."""
    min_vp_support: int = 4
    """A VP counts as observed when at least this many segments support it."""
    prior_sigma_deg: float = 20.0
    """Std of the Gaussian prior on the vertical FoV (centred on ``fallback_vfov_deg``)."""
    fallback_vfov_deg: float = 55.0
    """Used when the photo has too few lines for an estimate; also the prior's centre."""
    seed: int = 0
    """Seed of the random generator used to sample segment pairs."""


@dataclass(frozen=True)
class VanishingPointResult:
    """Estimated pinhole camera of the input image."""

    vfov_deg: float
    """Vertical field of view in degrees."""
    focal_px: float
    """Focal length in pixels of the input image."""
    cx: float
    """Principal point x (image centre) in input pixels."""
    cy: float
    """Principal point y (image centre) in input pixels."""
    method: str
    """"orthogonal_triplet", "orthogonal_pair" or "fallback"."""
    confidence: float
    """0..1; 0 for the fallback."""
    vanishing_points: list[tuple[float, float, float]]
    """Homogeneous VPs (x, y, w) in input pixels, unit norm; w = 0 is a VP at infinity."""
    n_segments: int
    """Number of line segments used."""


@dataclass(frozen=True)
class _Segments:
    """Line segments in centred, scaled coordinates."""

    p1: np.ndarray  # (N, 3) homogeneous endpoints
    p2: np.ndarray  # (N, 3)
    mid: np.ndarray  # (N, 3) homogeneous midpoints
    lines: np.ndarray  # (N, 3) unit-normal lines l with l . p = 0
    length: np.ndarray  # (N,) lengths in working pixels
    weight: np.ndarray  # (N,) evidence weight of each segment
    scale: float  # working pixels per unit of the centred coordinates


def estimate_camera(
    rgb: np.ndarray, params: VanishingPointParams = VanishingPointParams()
) -> VanishingPointResult:
    """Estimate vertical FoV and focal length of ``rgb`` (float HxWx3 sRGB in [0, 1])."""
    height, width = rgb.shape[:2]
    grey, zoom = _working_grey(rgb, params.max_side)
    seg_xy = _detect_segments(grey, params)
    centre = np.array([(grey.shape[1] - 1) / 2.0, (grey.shape[0] - 1) / 2.0])
    segs = _to_centred(seg_xy, centre, max(grey.shape) / 2.0, params.length_power)
    n_segments = len(segs.length)
    fallback = _fallback_result(width, height, n_segments, params)
    if n_segments < params.min_segments:
        return fallback

    rng = np.random.default_rng(params.seed)
    tau = params.inlier_px
    candidates = _vp_candidates(segs, rng, params)
    h_units = grey.shape[0] / segs.scale  # working image height in centred units
    frames = _best_grid_frames(segs, candidates, h_units, params)
    if not frames:
        return fallback
    refined = [_refine_frame(segs, f, rot, h_units, params) for f, rot in frames]
    contrib = np.stack([_segment_support(segs, _frame_vps(f, rot), tau) for f, rot, _ in refined])
    best = int(np.argmax(contrib.sum(axis=1)))
    focal, rot, fit_std = refined[best]
    vfovs = np.array([_vfov_deg(f, h_units) for f, _, _ in refined])
    bagged, ambiguity = _bootstrap_vfov(contrib, vfovs, rng, params.n_bootstrap)

    vps = _frame_vps(focal, rot)
    n_observed = int(np.sum(_vp_support(segs, vps, tau) >= params.min_vp_support))
    if n_observed < 2:
        return fallback
    vfov, vfov_std = _shrink_to_prior(bagged, float(np.hypot(fit_std, ambiguity)), params)
    explained = contrib[best].sum() / segs.weight.sum()
    confidence = float(np.clip(explained, 0, 1) * n_observed / 3.0 * np.exp(-vfov_std / 5.0))

    focal_px = height / (2.0 * np.tan(np.radians(vfov) / 2.0))
    return VanishingPointResult(
        vfov_deg=float(vfov),
        focal_px=float(focal_px),
        cx=(width - 1) / 2.0,
        cy=(height - 1) / 2.0,
        method="orthogonal_triplet" if n_observed == 3 else "orthogonal_pair",
        confidence=confidence,
        vanishing_points=_vps_to_input_pixels(vps, segs.scale / zoom, width, height),
        n_segments=n_segments,
    )


# --------------------------------------------------------------------------- lines


def _working_grey(rgb: np.ndarray, max_side: int) -> tuple[np.ndarray, float]:
    """uint8 grey image resized so its long side is at most ``max_side``; returns (grey, zoom)."""
    rgb8 = (np.clip(rgb[..., :3], 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    grey = cv2.cvtColor(rgb8, cv2.COLOR_RGB2GRAY)
    zoom = min(1.0, max_side / max(grey.shape))
    if zoom < 1.0:
        size = (round(grey.shape[1] * zoom), round(grey.shape[0] * zoom))
        grey = cv2.resize(grey, size, interpolation=cv2.INTER_AREA)
        zoom = grey.shape[1] / rgb.shape[1]
    return grey, zoom


def _content_box(grey: np.ndarray, params: VanishingPointParams) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the image without a uniform frame along its edges."""
    h, w = grey.shape
    row_std, col_std = grey.std(axis=1), grey.std(axis=0)

    def trim(std: np.ndarray, limit: int) -> int:
        n = 0
        while n < limit and std[n] < params.frame_std:
            n += 1
        return n

    max_y, max_x = int(h * params.max_frame_frac), int(w * params.max_frame_frac)
    top, bottom = trim(row_std, max_y), trim(row_std[::-1], max_y)
    left, right = trim(col_std, max_x), trim(col_std[::-1], max_x)
    return left, top, w - right, h - bottom


def _detect_segments(grey: np.ndarray, params: VanishingPointParams) -> np.ndarray:
    """(N, 4) segments x1, y1, x2, y2 in working pixels, filtered and merged."""
    x0, y0, x1, y1 = _content_box(grey, params)
    lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_STD)
    found = lsd.detect(np.ascontiguousarray(grey[y0:y1, x0:x1]))[0]
    if found is None:
        return np.zeros((0, 4))
    segs = found.reshape(-1, 4).astype(np.float64) + [x0, y0, x0, y0]
    segs = _drop_frame_segments(segs, (x0, y0, x1, y1), params.border_margin_px)
    diag = float(np.hypot(*grey.shape))
    segs = segs[np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]) >= params.min_piece_frac * diag]
    segs = _merge_collinear(segs, params, diag)
    length = np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1])
    keep = np.argsort(-length)[: params.max_segments]
    keep = keep[length[keep] >= params.min_segment_frac * diag]
    return segs[keep]


def _drop_frame_segments(segs: np.ndarray, box: tuple[int, int, int, int], margin: float) -> np.ndarray:
    """Remove segments running along the border of ``box`` (crop or frame edges)."""
    x0, y0, x1, y1 = box
    xs, ys = segs[:, [0, 2]], segs[:, [1, 3]]
    near_left = np.all(xs < x0 + margin, axis=1)
    near_right = np.all(xs > x1 - 1 - margin, axis=1)
    near_top = np.all(ys < y0 + margin, axis=1)
    near_bottom = np.all(ys > y1 - 1 - margin, axis=1)
    return segs[~(near_left | near_right | near_top | near_bottom)]


def _merge_collinear(segs: np.ndarray, params: VanishingPointParams, diag: float) -> np.ndarray:
    """Greedily join pieces of the same straight edge (longest first) into one segment."""
    segs = segs[np.argsort(-np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]))]
    cos_tol = np.cos(np.radians(params.merge_angle_deg))
    max_gap = params.merge_gap_frac * diag
    alive = np.ones(len(segs), dtype=bool)
    for i in range(len(segs)):
        if not alive[i]:
            continue
        changed = True
        while changed:
            changed = False
            a, b = segs[i, :2], segs[i, 2:]
            u = (b - a) / max(np.linalg.norm(b - a), 1e-9)
            normal = np.array([-u[1], u[0]])
            others = np.flatnonzero(alive)
            others = others[others != i]
            if len(others) == 0:
                break
            o1, o2 = segs[others, :2], segs[others, 2:]
            ov = o2 - o1
            olen = np.maximum(np.linalg.norm(ov, axis=1), 1e-9)
            parallel = np.abs(ov @ u) / olen >= cos_tol
            offset = np.maximum(np.abs((o1 - a) @ normal), np.abs((o2 - a) @ normal))
            t1, t2 = (o1 - a) @ u, (o2 - a) @ u
            seg_len = np.linalg.norm(b - a)
            gap = np.maximum(np.minimum(t1, t2) - seg_len, -np.maximum(t1, t2))
            ok = parallel & (offset < params.merge_offset_px) & (gap < max_gap)
            for j in others[ok]:
                ts = np.array([0.0, seg_len, (segs[j, :2] - a) @ u, (segs[j, 2:] - a) @ u])
                segs[i] = np.concatenate([a + ts.min() * u, a + ts.max() * u])
                alive[j] = False
                changed = True
    return segs[alive]


def _to_centred(seg_xy: np.ndarray, centre: np.ndarray, scale: float, length_power: float) -> _Segments:
    """Convert pixel segments to homogeneous centred coordinates."""
    n = len(seg_xy)
    ones = np.ones((n, 1))
    p1 = np.hstack([(seg_xy[:, :2] - centre) / scale, ones])
    p2 = np.hstack([(seg_xy[:, 2:] - centre) / scale, ones])
    lines = np.cross(p1, p2)
    lines /= np.maximum(np.linalg.norm(lines[:, :2], axis=1, keepdims=True), 1e-12)
    length = np.hypot(seg_xy[:, 2] - seg_xy[:, 0], seg_xy[:, 3] - seg_xy[:, 1])
    return _Segments(p1, p2, (p1 + p2) / 2.0, lines, length, length**length_power, scale)


# --------------------------------------------------------------------------- VP geometry


def _vp_distances(segs: _Segments, vps: np.ndarray) -> np.ndarray:
    """Distance (working px) of each segment's endpoints to the line joining its midpoint and each VP.

    ``vps`` has shape (..., 3); the result has shape (..., N).
    """
    through = np.cross(segs.mid, vps[..., None, :])  # (..., N, 3)
    norm = np.linalg.norm(through[..., :2], axis=-1)
    dist = np.abs(np.einsum("...nk,nk->...n", through, segs.p1)) / np.maximum(norm, 1e-12)
    return dist * segs.scale


def _frame_vps(focal: float, rot: np.ndarray) -> np.ndarray:
    """(3, 3) unit homogeneous VPs of the frame's axes: rows are K R e_k."""
    vps = (np.diag([focal, focal, 1.0]) @ rot).T
    return vps / np.linalg.norm(vps, axis=-1, keepdims=True)


def _support_weights(dist: np.ndarray, weight: np.ndarray, tau: float) -> np.ndarray:
    """Weighted truncated-quadratic consistency of segments with a VP."""
    return weight * np.clip(1.0 - (dist / tau) ** 2, 0.0, None)


def _segment_support(segs: _Segments, vps: np.ndarray, tau: float) -> np.ndarray:
    """Per-segment support of frames given as (..., 3, 3) VPs: each segment counts for its best VP."""
    return _support_weights(_vp_distances(segs, vps).min(axis=-2), segs.weight, tau)


def _vp_support(segs: _Segments, vps: np.ndarray, tau: float) -> np.ndarray:
    """Number of segments whose closest VP of the frame is each of the three VPs (within tau)."""
    dist = _vp_distances(segs, vps)  # (3, N)
    closest = dist.argmin(axis=0)
    inlier = dist.min(axis=0) < tau
    return np.bincount(closest[inlier], minlength=3)


def _fit_vp(segs: _Segments, weights: np.ndarray) -> np.ndarray:
    """Unit homogeneous point minimising the weighted squared distances to the segment lines."""
    m = (segs.lines * weights[:, None]).T @ segs.lines
    return np.linalg.eigh(m)[1][:, 0]


def _vp_candidates(segs: _Segments, rng: np.random.Generator, params: VanishingPointParams) -> np.ndarray:
    """(K, 3) diverse, well-supported VP candidates from random segment-pair intersections."""
    tau = params.inlier_px
    n = len(segs.length)
    prob = segs.weight / segs.weight.sum()
    i = rng.choice(n, size=params.n_vp_samples, p=prob)
    j = rng.choice(n, size=params.n_vp_samples, p=prob)
    sin_angle = np.abs(np.cross(segs.lines[i, :2], segs.lines[j, :2]))
    ok = (i != j) & (sin_angle > np.sin(np.radians(0.5)))
    vps = np.cross(segs.lines[i[ok]], segs.lines[j[ok]])
    vps /= np.linalg.norm(vps, axis=1, keepdims=True)
    vps = np.unique(np.round(vps * np.sign(vps[:, [2]] + 1e-15), 12), axis=0)

    weights = _support_weights(_vp_distances(segs, vps), segs.weight, tau)  # (M, N)
    order = np.argsort(-weights.sum(axis=1))
    kept: list[np.ndarray] = []
    claimed = np.zeros(n, dtype=bool)
    for m in order:
        inl = weights[m] > 0
        if inl.sum() < 2 or claimed[inl].mean() > params.candidate_overlap:
            continue
        kept.append(_polish_vp(segs, vps[m], tau))
        claimed |= inl
        if len(kept) == params.n_vp_candidates:
            break
    return np.array(kept).reshape(-1, 3)


def _polish_vp(segs: _Segments, vp: np.ndarray, tau: float, rounds: int = 2) -> np.ndarray:
    """Re-fit a VP on its inlier segments (weighted by length)."""
    for _ in range(rounds):
        weights = _support_weights(_vp_distances(segs, vp), segs.weight, tau)
        if np.count_nonzero(weights) < 2:
            break
        vp = _fit_vp(segs, weights)
    return vp


# --------------------------------------------------------------------------- Manhattan frames


def _focal_grid(h_units: float, params: VanishingPointParams) -> np.ndarray:
    """Focal lengths (centred units) for a grid of vertical FoVs."""
    vfov = np.arange(params.min_vfov_deg, params.max_vfov_deg + 1e-9, params.vfov_step_deg)
    return h_units / (2.0 * np.tan(np.radians(vfov) / 2.0))


def _nearest_rotation(m: np.ndarray) -> np.ndarray:
    """Closest rotation matrices (Frobenius) to a stack of 3x3 matrices."""
    u, _, vt = np.linalg.svd(m)
    u[..., :, 2] *= np.sign(np.linalg.det(u @ vt))[..., None]
    return u @ vt


def _polish_rotations(segs: _Segments, focals: np.ndarray, rots: np.ndarray, tau: float, rounds: int = 2) -> np.ndarray:
    """Re-fit each frame's axes to its supporting segments at fixed focal (weighted Procrustes).

    Each axis direction is the vector most orthogonal to the interpretation planes (K^T l) of
    the segments supporting its VP; the rotation is the closest one to these directions,
    weighted by their support.
    """
    k_diag = np.stack([focals, focals, np.ones_like(focals)], axis=1)  # (T, 3)
    normals = segs.lines[None] * k_diag[:, None, :]  # (T, N, 3)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    for _ in range(rounds):
        vps = np.einsum("ti,tik->tki", k_diag, rots)  # (T, 3, 3): VP of axis k is K R e_k
        dist = _vp_distances(segs, vps)  # (T, 3, N)
        own = np.arange(3)[None, :, None] == dist.argmin(axis=1)[:, None, :]
        w = _support_weights(dist, segs.weight, tau) * own
        scatter = np.einsum("tkn,tni,tnj->tkij", w, normals, normals, optimize=True)
        dirs = np.linalg.eigh(scatter)[1][..., 0]  # (T, 3 axes, 3)
        current = np.swapaxes(rots, 1, 2)  # current[t, k] = R e_k
        dirs *= np.where(np.sum(dirs * current, axis=-1, keepdims=True) < 0, -1.0, 1.0)
        axis_w = w.sum(axis=-1)[..., None]  # (T, 3, 1)
        target = axis_w * dirs + 1e-3 * axis_w.sum(axis=1, keepdims=True) * current
        rots = _nearest_rotation(np.swapaxes(target, 1, 2))
    return rots


def _pair_frames(candidates: np.ndarray, focals: np.ndarray, params: VanishingPointParams):
    """All (focal, rotation) frames from near-orthogonal candidate pairs at grid focals."""
    ia, ib = np.triu_indices(len(candidates), k=1)
    inv_k = 1.0 / np.stack([focals, focals, np.ones_like(focals)], axis=1)  # (F, 3)
    da = candidates[ia][:, None, :] * inv_k[None]  # (P, F, 3)
    db = candidates[ib][:, None, :] * inv_k[None]
    da /= np.linalg.norm(da, axis=-1, keepdims=True)
    db /= np.linalg.norm(db, axis=-1, keepdims=True)
    ortho = np.abs(np.sum(da * db, axis=-1)) < np.sin(np.radians(params.orthogonality_tol_deg))
    p, f = np.nonzero(ortho)
    da, db = da[p, f], db[p, f]
    rot = _nearest_rotation(np.stack([da, db, np.cross(da, db)], axis=-1))
    upright = np.abs(rot[:, 1, :]).max(axis=1) >= np.cos(np.radians(params.max_tilt_deg))
    return focals[f][upright], rot[upright]


def _best_grid_frames(segs: _Segments, candidates: np.ndarray, h_units: float, params: VanishingPointParams):
    """The ``n_refine`` best distinct (focal, rotation) frames over the focal grid, best first."""
    if len(candidates) < 2:
        return []
    focals, rots = _pair_frames(candidates, _focal_grid(h_units, params), params)
    if len(focals) == 0:
        return []
    rots = _polish_rotations(segs, focals, rots, params.inlier_px)
    vps = np.stack([_frame_vps(f, r) for f, r in zip(focals, rots)])
    scores = _segment_support(segs, vps, params.inlier_px).sum(axis=-1)
    chosen: list[tuple[float, np.ndarray]] = []
    for k in np.argsort(-scores, kind="stable"):
        if any(_same_frame(focals[k], rots[k], f, r, h_units) for f, r in chosen):
            continue
        chosen.append((float(focals[k]), rots[k]))
        if len(chosen) == params.n_refine:
            break
    return chosen


def _same_frame(f1: float, r1: np.ndarray, f2: float, r2: np.ndarray, h_units: float) -> bool:
    """Frames within 3 deg of FoV whose axes match up to permutation and sign within 5 deg."""
    if abs(_vfov_deg(f1, h_units) - _vfov_deg(f2, h_units)) > 3.0:
        return False
    return bool(np.all(np.abs(r1.T @ r2).max(axis=1) > np.cos(np.radians(5.0))))


def _refine_frame(segs: _Segments, focal: float, rot: np.ndarray, h_units: float, params: VanishingPointParams):
    """Robust least-squares refinement of (focal, rotation); returns (focal, rotation, vfov std in deg)."""
    tau, sigma = params.inlier_px, params.line_noise_px
    f_lo = h_units / (2.0 * np.tan(np.radians(params.max_vfov_deg) / 2.0))
    f_hi = h_units / (2.0 * np.tan(np.radians(params.min_vfov_deg) / 2.0))
    std = np.inf
    for _ in range(params.refine_rounds):
        dist = _vp_distances(segs, _frame_vps(focal, rot))
        axis = dist.argmin(axis=0)
        inl = dist.min(axis=0) < 2.0 * tau
        if inl.sum() < 3:
            break
        sub = _Segments(segs.p1[inl], segs.p2[inl], segs.mid[inl], segs.lines[inl], segs.length[inl], segs.weight[inl], segs.scale)
        sub_axis = axis[inl]
        base = rot

        def residuals(x: np.ndarray) -> np.ndarray:
            r = Rotation.from_rotvec(x[1:]).as_matrix() @ base
            vps = _frame_vps(np.exp(x[0]), r)
            d = _vp_distances(sub, vps)[sub_axis, np.arange(len(sub_axis))] / sigma
            prior = (_vfov_deg(np.exp(x[0]), h_units) - params.fallback_vfov_deg) / params.prior_sigma_deg
            return np.append(d, prior)

        x0 = np.array([np.clip(np.log(focal), np.log(f_lo), np.log(f_hi)), 0.0, 0.0, 0.0])
        sol = least_squares(
            residuals, x0, loss="soft_l1", f_scale=tau / sigma,
            bounds=([np.log(f_lo), -np.pi, -np.pi, -np.pi], [np.log(f_hi), np.pi, np.pi, np.pi]),
        )
        focal = float(np.exp(sol.x[0]))
        rot = Rotation.from_rotvec(sol.x[1:]).as_matrix() @ base
        std = _vfov_std_deg(sol.jac, focal, h_units)
    return focal, rot, std


def _vfov_std_deg(jac: np.ndarray, focal: float, h_units: float) -> float:
    """Gauss-Newton posterior std of the vertical FoV (deg) from the Jacobian in (log f, rotvec)."""
    try:
        var_log_f = np.linalg.inv(jac.T @ jac)[0, 0]
    except np.linalg.LinAlgError:
        return float("inf")
    t = h_units / (2.0 * focal)
    dvfov_dlogf = np.degrees(2.0 * t / (1.0 + t * t))
    return float(np.sqrt(max(var_log_f, 0.0)) * dvfov_dlogf)


def _bootstrap_vfov(contrib: np.ndarray, vfovs: np.ndarray, rng: np.random.Generator, n_boot: int) -> tuple[float, float]:
    """Median and robust std of the winning frame's FoV when segments are resampled with replacement.

    ``contrib`` is the (frames, segments) support matrix. The median is a bagged, lower-variance
    choice than the single best frame; a large spread means that competing frames with
    different focals explain the lines about equally well.
    """
    n = contrib.shape[1]
    counts = rng.multinomial(n, np.full(n, 1.0 / n), size=n_boot)  # (B, N)
    won = vfovs[np.argmax(contrib @ counts.T, axis=0)]
    lo, median, hi = np.percentile(won, [15.87, 50.0, 84.13])
    return float(median), float(hi - lo) / 2.0


def _shrink_to_prior(vfov: float, std: float, params: VanishingPointParams) -> tuple[float, float]:
    """Gaussian posterior (mean, std) of the FoV given a measurement and the prior around the fallback."""
    w_data, w_prior = 1.0 / max(std, 1e-6) ** 2, 1.0 / params.prior_sigma_deg**2
    mean = (w_data * vfov + w_prior * params.fallback_vfov_deg) / (w_data + w_prior)
    return mean, (w_data + w_prior) ** -0.5


# --------------------------------------------------------------------------- results


def _vfov_deg(focal: float, height: float) -> float:
    """Vertical FoV in degrees of a focal length and image height in the same units."""
    return float(np.degrees(2.0 * np.arctan(height / (2.0 * focal))))


def _vps_to_input_pixels(vps: np.ndarray, scale: float, width: int, height: int) -> list[tuple[float, float, float]]:
    """Map centred-unit VPs to unit homogeneous input-pixel coordinates."""
    to_pixels = np.array([[scale, 0, (width - 1) / 2.0], [0, scale, (height - 1) / 2.0], [0, 0, 1]])
    out = (to_pixels @ vps.T).T
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    return [tuple(float(c) for c in v) for v in out]


def _fallback_result(width: int, height: int, n_segments: int, params: VanishingPointParams) -> VanishingPointResult:
    """Result with the prior FoV, used when the lines do not support an estimate."""
    focal = height / (2.0 * np.tan(np.radians(params.fallback_vfov_deg) / 2.0))
    return VanishingPointResult(
        vfov_deg=float(params.fallback_vfov_deg),
        focal_px=float(focal),
        cx=(width - 1) / 2.0,
        cy=(height - 1) / 2.0,
        method="fallback",
        confidence=0.0,
        vanishing_points=[],
        n_segments=n_segments,
    )
