"""Camera field of view from Manhattan vanishing points (offline, no learned model).

Pipeline:

1. detect line segments (LSD) on a downscaled grey image, after cropping a uniform
   frame (e.g. the white border of NYU frames); merge collinear pieces, drop short
   segments and segments hugging the frame;
2. propose vanishing-point (VP) candidates from length-weighted random pairs of
   segments, polish each on its inliers and keep a diverse set;
3. pair candidates over a grid of focal lengths, keeping pairs that are orthogonal at
   that focal, and complete each pair to a Manhattan frame (focal f and rotation R, so
   the three VPs are K R e_k); re-fit each frame's axes to its segments and score it by
   length-weighted segment consistency with its three VPs;
4. refine the best distinct frames by robust Gauss-Newton over (log f, R), with a weak
   Gaussian prior on the vertical FoV that only matters when the lines do not
   determine the focal (e.g. both horizontal VPs near infinity);
5. resample the segments (bootstrap) to see which refined frame wins: the median FoV of
   the winners is the estimate, their spread its ambiguity, and the estimate is shrunk
   towards the prior by that ambiguity;
6. fall back to ``fallback_vfov_deg`` when the photo has too few lines or no frame with
   at least two supported VPs.

Conventions: square pixels, principal point at the image centre, image y pointing down.
Internally, points use centred coordinates scaled by half the long side of the working
image, so K = diag(f, f, 1) with f in those units.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from psdr_room_core.engine.settings import setting
from psdr_room_core.method.visualize import to_uint8


@dataclass
class VanishingPointParams:
    """Knobs of :func:`estimate_camera` (pixel values refer to the working image): the ``fov.vanishing_points``
    settings, and the ``lines`` of the layout fit (``conf/lines.yaml`` holds the values both take)."""

    max_side: int = setting(ge=64, doc="Lines are detected on an image resized so its long side is at most this.")
    min_segment_frac: float = setting(
        ge=0, le=1, doc="Drop segments (after merging) shorter than this fraction of the image diagonal."
    )
    min_piece_frac: float = setting(
        ge=0, le=1, doc="LSD pieces shorter than this fraction of the diagonal are discarded before merging."
    )
    max_pieces: int = setting(
        ge=1, doc="At most this many LSD pieces (the longest) are merged (bounds time and memory)."
    )
    max_segments: int = setting(ge=1, doc="Keep at most this many segments (the longest).")
    frame_std: float = setting(
        ge=0, doc="Edge rows/columns whose grey-level std (0..255) is below this form a uniform frame, cropped."
    )
    max_frame_frac: float = setting(
        ge=0, lt=0.5, doc="Never crop more than this fraction of the width/height per side as a frame."
    )
    border_margin_px: float = setting(ge=0, doc="Segments lying within this distance of the crop border are dropped.")
    merge_angle_deg: float = setting(
        ge=0, doc="Collinear pieces are merged when their directions differ by less than this ..."
    )
    merge_offset_px: float = setting(ge=0, doc="... their endpoints lie within this distance of the other's line ...")
    merge_gap_frac: float = setting(
        ge=0, doc="... and the gap between them is below this fraction of the image diagonal."
    )
    inlier_px: float = setting(
        gt=0, doc="Endpoint distance to the midpoint-VP line below which a segment supports a VP."
    )
    line_noise_px: float = setting(gt=0, doc="Assumed endpoint noise; scales the residuals of the refinement.")
    n_vp_samples: int = setting(ge=1, doc="Random segment pairs intersected to propose VP candidates.")
    n_vp_candidates: int = setting(ge=1, doc="At most this many distinct VP candidates are kept.")
    candidate_overlap: float = setting(
        ge=0, le=1, doc="A candidate is a duplicate if this fraction of its supporting segments support a kept one."
    )
    min_vfov_deg: float = setting(gt=0, lt=180, doc="Smallest vertical FoV considered.")
    max_vfov_deg: float = setting(gt=0, lt=180, doc="Largest vertical FoV considered.")
    vfov_step_deg: float = setting(gt=0, doc="Step of the FoV grid used to pair VP candidates.")
    orthogonality_tol_deg: float = setting(
        ge=0, le=90, doc="Two candidates form a frame at a grid focal if their directions are this close to 90 degrees."
    )
    max_tilt_deg: float = setting(
        ge=0,
        le=90,
        doc="One Manhattan axis must lie within this angle of the image's vertical axis (bounded pitch/roll).",
    )
    n_refine: int = setting(ge=1, doc="Best distinct frames refined by Gauss-Newton.")
    refine_rounds: int = setting(ge=1, doc="Segment-to-VP reassignment rounds of the refinement.")
    gauss_newton_steps: int = setting(ge=0, doc="Gauss-Newton steps per reassignment round.")
    n_bootstrap: int = setting(
        ge=1, doc="Segment resamplings used to choose among refined frames and measure the ambiguity."
    )
    min_segments: int = setting(
        ge=2,
        doc="Fewer usable segments than this gives the fallback (a big-tiled floor seen from above shows 9 long lines).",
    )
    min_vp_support: int = setting(ge=2, doc="A VP counts as observed when at least this many segments support it.")
    min_confirming_support: int = setting(
        ge=2,
        doc="Segments that confirm a further VP of a frame one VP already pins: two lines that meet where the "
        "frame puts a VP are evidence (two lines at random meet anywhere, not there).",
    )
    prior_sigma_deg: float = setting(
        gt=0, doc="Std of the Gaussian prior on the vertical FoV, centred on ``fallback_vfov_deg``."
    )
    fallback_vfov_deg: float = setting(
        gt=0, lt=180, doc="Used when the photo has too few lines for an estimate; also the prior's centre."
    )
    seed: int = setting(doc="Seed of the random generator (segment-pair sampling and bootstrap).")


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
    """"orthogonal_triplet" (three supported VPs), "orthogonal_pair" (two) or "fallback"."""
    confidence: float
    """0..1: explained line evidence, observed VPs and FoV uncertainty combined; 0 for the fallback."""
    vanishing_points: list[tuple[float, float, float]]
    """Homogeneous unit-norm VPs (x, y, w) of the best frame in input pixels; w = 0 is at infinity."""
    n_segments: int
    """Number of line segments used."""


@dataclass(frozen=True)
class _Segments:
    """Line segments in centred, scaled homogeneous coordinates."""

    p1: np.ndarray  # (N, 3) first endpoints
    mid: np.ndarray  # (N, 3) midpoints
    lines: np.ndarray  # (N, 3) lines l with l . p = 0 and unit (l0, l1)
    length: np.ndarray  # (N,) lengths in working pixels
    scale: float  # working pixels per centred unit


def estimate_camera(rgb: np.ndarray, params: VanishingPointParams) -> VanishingPointResult:
    """Estimate the vertical FoV and focal length of ``rgb`` (float HxWx3 sRGB in [0, 1])."""
    height, width = rgb.shape[:2]
    grey, zoom = _working_grey(rgb, params.max_side)
    segs = _to_centred(_detect_segments(grey, params), grey.shape)
    n_segments = len(segs.length)
    fallback = _fallback_result(width, height, n_segments, params)
    if n_segments < params.min_segments:
        return fallback

    rng = np.random.default_rng(params.seed)
    tau = params.inlier_px
    h_units = grey.shape[0] / segs.scale  # working image height in centred units
    candidates = _vp_candidates(segs, rng, params)
    focals, rots = _best_grid_frames(segs, candidates, h_units, params)
    if len(focals) == 0:
        return fallback
    focals, rots, fit_std = _refine_frames(segs, focals, rots, h_units, params)
    contrib = _segment_support(segs, _frame_vps(focals, rots), tau)  # (frames, segments)
    best = int(np.argmax(contrib.sum(axis=1)))
    vps = _frame_vps(focals[best], rots[best])
    n_observed = _observed_vps(_vp_support(segs, vps, tau), params)
    if n_observed < 2:
        return fallback

    vfovs = _vfov_deg(focals, h_units)
    bagged, ambiguity = _bootstrap_vfov(contrib, vfovs, rng, params.n_bootstrap)
    vfov = _shrink_to_prior(bagged, ambiguity, params)
    vfov_std = float(np.hypot(fit_std[best], ambiguity))
    explained = contrib[best].sum() / segs.length.sum()
    return VanishingPointResult(
        vfov_deg=float(vfov),
        focal_px=float(_focal_for_vfov(vfov, height)),
        cx=(width - 1) / 2.0,
        cy=(height - 1) / 2.0,
        method="orthogonal_triplet" if n_observed == 3 else "orthogonal_pair",
        confidence=float(explained * n_observed / 3.0 * np.exp(-vfov_std / 5.0)),
        vanishing_points=_vps_to_input_pixels(vps, segs.scale / zoom, width, height),
        n_segments=n_segments,
    )


# --------------------------------------------------------------------------- line segments


def line_segments(rgb: np.ndarray, params: VanishingPointParams) -> np.ndarray:
    """(N, 4) line segments ``x1, y1, x2, y2`` of ``rgb`` in its own pixels, as the estimate uses them."""
    grey, zoom = _working_grey(rgb, params.max_side)
    return _detect_segments(grey, params) / zoom


def _working_grey(rgb: np.ndarray, max_side: int) -> tuple[np.ndarray, float]:
    """uint8 grey image resized so its long side is at most ``max_side``; returns (grey, zoom)."""
    rgb8 = to_uint8(rgb[..., :3])
    grey = cv2.cvtColor(rgb8, cv2.COLOR_RGB2GRAY)
    zoom = min(1.0, max_side / max(grey.shape))
    if zoom < 1.0:
        size = (round(grey.shape[1] * zoom), round(grey.shape[0] * zoom))
        grey = cv2.resize(grey, size, interpolation=cv2.INTER_AREA)
        zoom = grey.shape[0] / rgb.shape[0]
    return grey, zoom


def _content_box(grey: np.ndarray, params: VanishingPointParams) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the image without a uniform frame along its edges."""
    h, w = grey.shape
    row_std, col_std = grey.std(axis=1), grey.std(axis=0)

    def frame_width(std: np.ndarray, limit: int) -> int:
        flat = np.flatnonzero(std[:limit] >= params.frame_std)
        return int(flat[0]) if len(flat) else limit

    max_y, max_x = int(h * params.max_frame_frac), int(w * params.max_frame_frac)
    top, bottom = frame_width(row_std, max_y), frame_width(row_std[::-1], max_y)
    left, right = frame_width(col_std, max_x), frame_width(col_std[::-1], max_x)
    return left, top, w - right, h - bottom


def _detect_segments(grey: np.ndarray, params: VanishingPointParams) -> np.ndarray:
    """(N, 4) segments x1, y1, x2, y2 in working pixels: detected, merged and filtered."""
    x0, y0, x1, y1 = _content_box(grey, params)
    lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_STD)
    found = lsd.detect(np.ascontiguousarray(grey[y0:y1, x0:x1]))[0]
    if found is None:
        return np.zeros((0, 4))
    diag = float(np.hypot(*grey.shape))
    segs = found.reshape(-1, 4).astype(np.float64) + [x0, y0, x0, y0]
    length = _lengths(segs)
    segs = segs[np.argsort(-length, kind="stable")[: params.max_pieces]]
    segs = segs[_lengths(segs) >= params.min_piece_frac * diag]
    segs = _merge_collinear(segs, params, diag)
    segs = _drop_frame_segments(segs, (x0, y0, x1, y1), params.border_margin_px)
    length = _lengths(segs)
    keep = np.argsort(-length, kind="stable")[: params.max_segments]
    return segs[keep[length[keep] >= params.min_segment_frac * diag]]


def _lengths(segs: np.ndarray) -> np.ndarray:
    """Lengths of (N, 4) segments."""
    return np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1])


def _drop_frame_segments(segs: np.ndarray, box: tuple[int, int, int, int], margin: float) -> np.ndarray:
    """Remove segments running along the border of ``box`` (image or crop edge)."""
    x0, y0, x1, y1 = box
    xs, ys = segs[:, [0, 2]], segs[:, [1, 3]]
    along_x = np.all(xs < x0 + margin, axis=1) | np.all(xs > x1 - 1 - margin, axis=1)
    along_y = np.all(ys < y0 + margin, axis=1) | np.all(ys > y1 - 1 - margin, axis=1)
    return segs[~(along_x | along_y)]


def _merge_collinear(segs: np.ndarray, params: VanishingPointParams, diag: float) -> np.ndarray:
    """Greedily join pieces (sorted longest first) of the same straight edge.

    A piece absorbs the pieces that are parallel to it, lie on its line and are separated from
    its current span by a small gap; its span grows along its own line, so only the gap test
    has to be repeated as it grows.
    """
    length = _lengths(segs)
    start, end = segs[:, :2], segs[:, 2:]
    u = (end - start) / length[:, None]
    normal = np.stack([-u[:, 1], u[:, 0]], axis=1)
    offset = np.maximum(np.abs(_along(normal, start, start)), np.abs(_along(normal, start, end)))
    parallel = np.abs(u @ u.T) >= np.cos(np.radians(params.merge_angle_deg))
    on_line = parallel & (offset < params.merge_offset_px)
    np.fill_diagonal(on_line, False)
    t_start, t_end = _along(u, start, start), _along(u, start, end)
    max_gap = params.merge_gap_frac * diag
    lo, hi = np.zeros(len(segs)), length.copy()  # span of each piece along its own line
    alive = np.ones(len(segs), dtype=bool)
    for i in np.flatnonzero(on_line.any(axis=1)):
        partners = np.flatnonzero(on_line[i])
        t1, t2 = t_start[i, partners], t_end[i, partners]
        p_lo, p_hi = np.minimum(t1, t2), np.maximum(t1, t2)
        free = alive[partners]
        while alive[i] and free.any():
            join = free & (p_lo - hi[i] < max_gap) & (lo[i] - p_hi < max_gap)
            if not join.any():
                break
            lo[i], hi[i] = min(lo[i], p_lo[join].min()), max(hi[i], p_hi[join].max())
            alive[partners[join]] = False
            free &= ~join
    merged = np.hstack([start + lo[:, None] * u, start + hi[:, None] * u])
    return merged[alive]


def _along(axes: np.ndarray, origins: np.ndarray, points: np.ndarray) -> np.ndarray:
    """[i, j]: coordinate of ``points[j]`` along ``axes[i]`` measured from ``origins[i]``."""
    return axes @ points.T - np.sum(axes * origins, axis=1)[:, None]


def _to_centred(seg_xy: np.ndarray, shape: tuple[int, int]) -> _Segments:
    """Convert pixel segments of an image of ``shape`` to centred homogeneous coordinates."""
    scale = max(shape) / 2.0
    centre = np.array([(shape[1] - 1) / 2.0, (shape[0] - 1) / 2.0])
    ones = np.ones((len(seg_xy), 1))
    p1 = np.hstack([(seg_xy[:, :2] - centre) / scale, ones])
    p2 = np.hstack([(seg_xy[:, 2:] - centre) / scale, ones])
    lines = np.cross(p1, p2)
    lines /= np.maximum(np.linalg.norm(lines[:, :2], axis=1, keepdims=True), 1e-12)
    return _Segments(p1, (p1 + p2) / 2.0, lines, _lengths(seg_xy), scale)


# --------------------------------------------------------------------------- VP geometry


def _signed_offsets(segs: _Segments, vps: np.ndarray) -> np.ndarray:
    """Signed distance (working px) of each segment's endpoint to the line through its midpoint and VP.

    ``vps`` broadcasts against the (N, 3) segments: (..., N, 3) per-segment VPs or (..., 1, 3).
    """
    through = np.cross(segs.mid, vps)
    norm = np.maximum(np.linalg.norm(through[..., :2], axis=-1), 1e-12)
    return np.einsum("...nk,nk->...n", through, segs.p1) / norm * segs.scale


def _vp_distances(segs: _Segments, vps: np.ndarray) -> np.ndarray:
    """Consistency distance (working px) of every segment with each VP: (..., 3) VPs -> (..., N)."""
    return np.abs(_signed_offsets(segs, vps[..., None, :]))


def _support_weights(dist: np.ndarray, length: np.ndarray, tau: float) -> np.ndarray:
    """Length-weighted truncated-quadratic consistency of segments with a VP."""
    return length * np.clip(1.0 - (dist / tau) ** 2, 0.0, None)


def _segment_support(segs: _Segments, vps: np.ndarray, tau: float) -> np.ndarray:
    """Per-segment support of frames given as (..., 3, 3) VPs; each segment counts for its best VP."""
    return _support_weights(_vp_distances(segs, vps).min(axis=-2), segs.length, tau)


def _vp_support(segs: _Segments, vps: np.ndarray, tau: float) -> np.ndarray:
    """Number of segments within ``tau`` whose closest VP of the (3, 3) frame is each VP."""
    dist = _vp_distances(segs, vps)
    inlier = dist.min(axis=0) < tau
    return np.bincount(dist.argmin(axis=0)[inlier], minlength=3)


def _observed_vps(support: np.ndarray, params: VanishingPointParams) -> int:
    """How many of a frame's VPs the segments observe: none unless one has ``min_vp_support``; then each with
    ``min_confirming_support``."""
    if support.max() < params.min_vp_support:
        return 0
    return int(np.sum(support >= min(params.min_confirming_support, params.min_vp_support)))


def _vp_candidates(segs: _Segments, rng: np.random.Generator, params: VanishingPointParams) -> np.ndarray:
    """(K, 3) diverse, well-supported VP candidates from random segment-pair intersections."""
    tau, n = params.inlier_px, len(segs.length)
    prob = segs.length / segs.length.sum()
    i = rng.choice(n, size=params.n_vp_samples, p=prob)
    j = rng.choice(n, size=params.n_vp_samples, p=prob)
    li, lj = segs.lines[i], segs.lines[j]
    crossing = np.abs(li[:, 0] * lj[:, 1] - li[:, 1] * lj[:, 0]) > np.sin(np.radians(0.5))
    vps = np.cross(segs.lines[i[crossing]], segs.lines[j[crossing]])
    vps /= np.linalg.norm(vps, axis=1, keepdims=True)
    vps = np.unique(np.round(vps * np.where(vps[:, [2]] < 0, -1.0, 1.0), 12), axis=0)

    weights = _support_weights(_vp_distances(segs, vps), segs.length, tau)  # (M, N)
    kept: list[np.ndarray] = []
    claimed = np.zeros(n, dtype=bool)
    for m in np.argsort(-weights.sum(axis=1), kind="stable"):
        inlier = weights[m] > 0
        if inlier.sum() < 2 or claimed[inlier].mean() > params.candidate_overlap:
            continue
        kept.append(_polish_vp(segs, vps[m], tau))
        claimed |= inlier
        if len(kept) == params.n_vp_candidates:
            break
    return np.array(kept).reshape(-1, 3)


def _polish_vp(segs: _Segments, vp: np.ndarray, tau: float, rounds: int = 2) -> np.ndarray:
    """Re-fit a VP as the point closest (weighted least squares) to its supporting lines."""
    for _ in range(rounds):
        weights = _support_weights(_vp_distances(segs, vp), segs.length, tau)
        if np.count_nonzero(weights) < 2:
            break
        vp = np.linalg.eigh((segs.lines * weights[:, None]).T @ segs.lines)[1][:, 0]
    return vp


# --------------------------------------------------------------------------- Manhattan frames


def _frame_vps(focal: np.ndarray | float, rot: np.ndarray) -> np.ndarray:
    """Unit homogeneous VPs K R e_k of frames: focal (...), rot (..., 3, 3) -> (..., 3 axes, 3)."""
    focal = np.asarray(focal, dtype=np.float64)
    k_diag = np.stack([focal, focal, np.ones_like(focal)], axis=-1)  # (..., 3)
    vps = np.swapaxes(rot, -1, -2) * k_diag[..., None, :]
    return vps / np.linalg.norm(vps, axis=-1, keepdims=True)


def _nearest_rotation(m: np.ndarray) -> np.ndarray:
    """Closest rotation matrices (Frobenius norm) to a stack of 3x3 matrices."""
    u, _, vt = np.linalg.svd(m)
    u[..., :, 2] *= np.sign(np.linalg.det(u @ vt))[..., None]
    return u @ vt


def _pair_frames(
    candidates: np.ndarray, focals: np.ndarray, params: VanishingPointParams
) -> tuple[np.ndarray, np.ndarray]:
    """(focals, rotations) of all frames built from candidate pairs that are orthogonal at a grid focal."""
    ia, ib = np.triu_indices(len(candidates), k=1)
    inv_k = 1.0 / np.stack([focals, focals, np.ones_like(focals)], axis=1)  # (F, 3)
    da = candidates[ia][:, None, :] * inv_k[None]  # (P, F, 3) directions
    db = candidates[ib][:, None, :] * inv_k[None]
    da /= np.linalg.norm(da, axis=-1, keepdims=True)
    db /= np.linalg.norm(db, axis=-1, keepdims=True)
    pair, f = np.nonzero(np.abs(np.sum(da * db, axis=-1)) < np.sin(np.radians(params.orthogonality_tol_deg)))
    da, db = da[pair, f], db[pair, f]
    rots = _nearest_rotation(np.stack([da, db, np.cross(da, db)], axis=-1))
    upright = np.abs(rots[:, 1, :]).max(axis=1) >= np.cos(np.radians(params.max_tilt_deg))
    return focals[f][upright], rots[upright]


def _polish_rotations(segs: _Segments, focals: np.ndarray, rots: np.ndarray, tau: float, rounds: int = 2) -> np.ndarray:
    """Re-fit each frame's axes to its supporting segments at fixed focal (weighted Procrustes).

    An axis direction is the vector most orthogonal to the interpretation planes (K^T l) of
    the segments supporting its VP; the new rotation is the closest one to these directions,
    weighted by their support.
    """
    k_diag = np.stack([focals, focals, np.ones_like(focals)], axis=1)  # (T, 3)
    normals = segs.lines[None] * k_diag[:, None, :]  # (T, N, 3)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    for _ in range(rounds):
        dist = _vp_distances(segs, _frame_vps(focals, rots))  # (T, 3, N)
        own = np.arange(3)[None, :, None] == dist.argmin(axis=1)[:, None, :]
        w = _support_weights(dist, segs.length, tau) * own
        scatter = np.einsum("tkn,tni,tnj->tkij", w, normals, normals, optimize=True)
        dirs = np.linalg.eigh(scatter)[1][..., 0]  # (T, 3 axes, 3)
        current = np.swapaxes(rots, 1, 2)  # current[t, k] = R e_k
        dirs *= np.where(np.sum(dirs * current, axis=-1, keepdims=True) < 0, -1.0, 1.0)
        axis_w = w.sum(axis=-1)[..., None]  # (T, 3, 1)
        target = axis_w * dirs + 1e-3 * axis_w.sum(axis=1, keepdims=True) * current
        rots = _nearest_rotation(np.swapaxes(target, 1, 2))
    return rots


def _best_grid_frames(
    segs: _Segments, candidates: np.ndarray, h_units: float, params: VanishingPointParams
) -> tuple[np.ndarray, np.ndarray]:
    """The ``n_refine`` best distinct frames over the focal grid, best first, as (focals, rotations)."""
    if len(candidates) < 2:
        return np.zeros(0), np.zeros((0, 3, 3))
    focals, rots = _pair_frames(candidates, _focal_for_vfov(_vfov_grid(params), h_units), params)
    if len(focals) == 0:
        return focals, rots
    rots = _polish_rotations(segs, focals, rots, params.inlier_px)
    scores = _segment_support(segs, _frame_vps(focals, rots), params.inlier_px).sum(axis=-1)
    vfovs = _vfov_deg(focals, h_units)
    chosen: list[int] = []
    for k in np.argsort(-scores, kind="stable"):
        if not any(_same_frame(vfovs[k], rots[k], vfovs[c], rots[c]) for c in chosen):
            chosen.append(int(k))
            if len(chosen) == params.n_refine:
                break
    return focals[chosen], rots[chosen]


def _same_frame(vfov1: float, rot1: np.ndarray, vfov2: float, rot2: np.ndarray) -> bool:
    """Frames within 3 deg of FoV whose axes match up to permutation and sign within 5 deg."""
    axes_match = np.abs(rot1.T @ rot2).max(axis=1) > np.cos(np.radians(5.0))
    return abs(vfov1 - vfov2) <= 3.0 and bool(np.all(axes_match))


def _refine_frames(
    segs: _Segments, focals: np.ndarray, rots: np.ndarray, h_units: float, params: VanishingPointParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Robust Gauss-Newton refinement of (log focal, rotation) of all frames at once.

    Each round assigns segments to their closest VP (inliers within 2 ``inlier_px``), then takes
    slightly damped Gauss-Newton steps on the soft-L1 robustified endpoint offsets (IRLS) plus
    the Gaussian FoV prior. Returns refined focals, rotations and the FoV std (deg) of each frame.
    """
    from scipy.spatial.transform import Rotation  # imported on use: cached runs skip scipy

    log_f = np.log(focals)
    log_lo, log_hi = np.log(_focal_for_vfov(np.array([params.max_vfov_deg, params.min_vfov_deg]), h_units))
    soft_scale = params.inlier_px / params.line_noise_px
    hess = np.tile(np.eye(4), (len(focals), 1, 1))
    for _ in range(params.refine_rounds):
        dist = _vp_distances(segs, _frame_vps(np.exp(log_f), rots))  # (T, 3, N)
        axis = dist.argmin(axis=1)
        inlier = dist.min(axis=1) < 2.0 * params.inlier_px
        for _ in range(params.gauss_newton_steps):
            res, jac = _offsets_and_jacobian(segs, log_f, rots, axis, params.line_noise_px)
            w = inlier / np.sqrt(1.0 + (res / soft_scale) ** 2)
            prior_res, prior_jac = _prior_residual(log_f, h_units, params)
            hess = np.einsum("tn,tni,tnj->tij", w, jac, jac)
            grad = np.einsum("tn,tni,tn->ti", w, jac, res)
            hess[:, 0, 0] += prior_jac**2
            grad[:, 0] += prior_jac * prior_res
            damping = 1e-3 * np.trace(hess, axis1=1, axis2=2)[:, None, None] / 4.0 + 1e-9
            step = -np.linalg.solve(hess + damping * np.eye(4), grad[..., None])[..., 0]
            log_f = np.clip(log_f + step[:, 0], log_lo, log_hi)
            rots = Rotation.from_rotvec(step[:, 1:]).as_matrix() @ rots
    ridge = 1e-9 * np.maximum(np.trace(hess, axis1=1, axis2=2), 1.0)[:, None, None]  # few segments: singular
    var_log_f = np.linalg.inv(hess + ridge * np.eye(4))[:, 0, 0]
    std = np.sqrt(np.clip(var_log_f, 0.0, None)) * np.abs(_dvfov_dlogf(log_f, h_units))
    return np.exp(log_f), rots, std


def _offsets_and_jacobian(
    segs: _Segments, log_f: np.ndarray, rots: np.ndarray, axis: np.ndarray, noise: float
) -> tuple[np.ndarray, np.ndarray]:
    """Signed offsets (in noise units) of segments to their assigned VPs, and their numeric
    Jacobian w.r.t. (log f, small rotation applied on the left): shapes (T, N) and (T, N, 4)."""
    from scipy.spatial.transform import Rotation  # imported on use: cached runs skip scipy

    eps = 1e-6
    log_fs = log_f[None] + eps * np.array([0.0, 1.0, 0.0, 0.0, 0.0])[:, None]  # (5, T)
    tweaks = Rotation.from_rotvec(eps * np.vstack([np.zeros((2, 3)), np.eye(3)])).as_matrix()  # (5, 3, 3)
    vps = _frame_vps(np.exp(log_fs), tweaks[:, None] @ rots[None])  # (5, T, 3, 3)
    per_segment = np.take_along_axis(vps, axis[None, :, :, None], axis=2)  # (5, T, N, 3)
    offsets = _signed_offsets(segs, per_segment) / noise  # (5, T, N)
    return offsets[0], np.moveaxis((offsets[1:] - offsets[0]) / eps, 0, -1)


def _prior_residual(log_f: np.ndarray, h_units: float, params: VanishingPointParams) -> tuple[np.ndarray, np.ndarray]:
    """Residual and derivative (w.r.t. log f) of the Gaussian FoV prior."""
    residual = (_vfov_deg(np.exp(log_f), h_units) - params.fallback_vfov_deg) / params.prior_sigma_deg
    return residual, _dvfov_dlogf(log_f, h_units) / params.prior_sigma_deg


def _bootstrap_vfov(
    contrib: np.ndarray, vfovs: np.ndarray, rng: np.random.Generator, n_boot: int
) -> tuple[float, float]:
    """Median and robust std of the winning frame's FoV when segments are resampled with replacement.

    ``contrib`` is the (frames, segments) support matrix. The median is a bagged, lower-variance
    choice than the single best frame; a large spread means competing frames with different
    focals explain the lines about equally well.
    """
    n = contrib.shape[1]
    counts = rng.multinomial(n, np.full(n, 1.0 / n), size=n_boot)  # (B, N)
    won = vfovs[np.argmax(contrib @ counts.T, axis=0)]
    lo, median, hi = np.percentile(won, [15.87, 50.0, 84.13])
    return float(median), float(hi - lo) / 2.0


def _shrink_to_prior(vfov: float, std: float, params: VanishingPointParams) -> float:
    """Posterior mean of the FoV given a Gaussian measurement and the Gaussian prior."""
    w_data, w_prior = 1.0 / max(std, 1e-6) ** 2, 1.0 / params.prior_sigma_deg**2
    return (w_data * vfov + w_prior * params.fallback_vfov_deg) / (w_data + w_prior)


# --------------------------------------------------------------------------- camera helpers


def _vfov_grid(params: VanishingPointParams) -> np.ndarray:
    """Vertical FoVs (deg) at which candidate pairs are tried."""
    return np.arange(params.min_vfov_deg, params.max_vfov_deg + 1e-9, params.vfov_step_deg)


def _vfov_deg(focal: np.ndarray | float, height: float) -> np.ndarray:
    """Vertical FoV in degrees for focal lengths and an image height in the same units (elementwise)."""
    return np.degrees(2.0 * np.arctan(height / (2.0 * np.asarray(focal))))


def _focal_for_vfov(vfov_deg: np.ndarray | float, height: float) -> np.ndarray:
    """Focal lengths for vertical FoVs in degrees, in the units of ``height`` (elementwise)."""
    return height / (2.0 * np.tan(np.radians(vfov_deg) / 2.0))


def _dvfov_dlogf(log_f: np.ndarray, h_units: float) -> np.ndarray:
    """Derivative of the vertical FoV (deg) w.r.t. the log focal length."""
    t = h_units / (2.0 * np.exp(log_f))
    return -np.degrees(2.0 * t / (1.0 + t * t))


def _vps_to_input_pixels(vps: np.ndarray, scale: float, width: int, height: int) -> list[tuple[float, float, float]]:
    """Map centred-unit VPs to unit homogeneous input-pixel coordinates."""
    to_pixels = np.array([[scale, 0, (width - 1) / 2.0], [0, scale, (height - 1) / 2.0], [0, 0, 1]])
    out = vps @ to_pixels.T
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    return [(float(x), float(y), float(w)) for x, y, w in out]


def _fallback_result(width: int, height: int, n_segments: int, params: VanishingPointParams) -> VanishingPointResult:
    """Result with the fallback FoV, used when the lines do not support an estimate."""
    return VanishingPointResult(
        vfov_deg=float(params.fallback_vfov_deg),
        focal_px=float(_focal_for_vfov(params.fallback_vfov_deg, height)),
        cx=(width - 1) / 2.0,
        cy=(height - 1) / 2.0,
        method="fallback",
        confidence=0.0,
        vanishing_points=[],
        n_segments=n_segments,
    )
