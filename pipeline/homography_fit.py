"""The H's homography from its edges: where the pad plane's H lies in a frame.

The same edge measurements as the pose fit (``pipeline.edgefit``: strongest
gradient of the right polarity across each projected side, sub-pixel), but
the unknown is the plane-to-image homography, which needs no camera model:
it works before the pose, on frames from cameras whose intrinsics are only
roughly known, and it finds the corners of H's whose stroke ends or serifs
no corner detector reads well. All sides are fitted at once (Gauss-Newton
with Huber weights, a little Levenberg damping), so a stroke end of 3 px
still pins the H's height.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pipeline.edge_kernels import MIN_DROP, homography_steps, side_support
from pipeline.edgefit import EdgeModel, normalising
from pipeline.jit import compiled_ieee, pixels, plain

MIN_SIDE_PX = 1.0  # a stroke end of a small H may be 2 px: still measured
DAMPING = 1e-3
# An H's far corners this many times as far from the camera as its near ones: the H
# would lie at its vanishing line (a pad tilted 35 degrees at the frame's edge, its H
# a third of the altitude across, reads under 2).
MAX_DEPTH_RATIO = 4.0
MIN_CLEARANCE_PX = 1.0  # closer parallel sides blur into one line: not used (a thin
# stroke's two sides pull each other inward alike, so its middle stays right)


@dataclass(frozen=True, eq=False)
class HomographyFit:
    """``H``: 3 x 3 map from pad metres (x, y, 1) to frame pixels. ``rms_px``: RMS
    distance of the inlier edge points to the model's sides. ``support``: per
    visible side, the share of its samples with an edge of the right polarity
    within 0.75 px of where ``H`` puts it, averaged over the sides;
    ``side_found``: those shares, per side of the model (nan for sides not seen).
    ``shape``: the fitted deformation (see `Deformation`; empty without one)."""

    H: np.ndarray
    rms_px: float
    support: float
    side_found: np.ndarray  # per model side: share of its samples on an edge (nan: not seen)
    shape: np.ndarray = field(default_factory=lambda: np.zeros(0))  # the deformation's p


@dataclass(frozen=True, eq=False)
class Deformation:
    """Ways a model's picture may differ from the thing in view, fitted with the
    homography: with parameters p (K numbers, metres), side j's start moves by
    ``a[j] @ p`` and its end by ``b[j] @ p`` in the pad plane; each p_k is held near 0
    with a spread of ``sigma[k]``."""

    a: np.ndarray  # (S, 2, K)
    b: np.ndarray  # (S, 2, K)
    sigma: np.ndarray  # (K,)

    @classmethod
    def none(cls, sides: int) -> Deformation:
        empty = np.zeros((sides, 2, 0))
        return cls(empty, empty, np.zeros(0))

    def corners(self, corners_m: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """A closed polygon's corners (its sides' starts) moved by the fitted ``shape``."""
        if not len(shape):
            return corners_m
        return corners_m + self.a @ shape


def seen_from_above(H: np.ndarray, pts_m: np.ndarray) -> bool:
    """Whether a camera above the pad could see ``pts_m`` (pad metres, N x 2) where
    ``H`` puts them: every point in front of it, none ``MAX_DEPTH_RATIO`` times as far
    as another, and the plane not mirrored (pad metres have y up, pixels y down).

    A fit gone astray may still find edges under a few of its sides: an H folded
    through its vanishing line or mirrored, its corners bunched, is no view of it.

    Examples
    --------
    >>> pts = np.array([[-1.0, 1.0], [1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]])
    >>> view = np.array([[100.0, 0.0, 320.0], [0.0, -100.0, 240.0], [0.0, 0.0, 1.0]])
    >>> seen_from_above(view, pts), seen_from_above(view @ np.diag([1.0, -1.0, 1.0]), pts)
    (True, False)
    >>> seen_from_above(view @ np.array([[1.0, 0, 0], [0, 1, 0], [0.0, 0.9, 1]]), pts)
    False
    """
    return _seen_from_above(plain(H), plain(pts_m).reshape(-1, 2), MAX_DEPTH_RATIO)


@compiled_ieee
def _seen_from_above(H, pts, max_ratio):
    # (every pose asks this of its start: numpy's calls on a dozen points, compiled out)
    sign = 0.0
    lo, hi = np.inf, 0.0
    for i in range(pts.shape[0]):
        w = H[2, 0] * pts[i, 0] + H[2, 1] * pts[i, 1] + H[2, 2]
        if not w > 0.0 and not w < 0.0:  # (on the vanishing line, or nan)
            return False
        s = 1.0 if w > 0.0 else -1.0
        if i == 0:
            sign = s
        elif s != sign:
            return False
        lo, hi = min(lo, abs(w)), max(hi, abs(w))
    # The map's local area scale is det(H) / w^3: a view from above turns it negative.
    det = (
        H[0, 0] * (H[1, 1] * H[2, 2] - H[1, 2] * H[2, 1])
        - H[0, 1] * (H[1, 0] * H[2, 2] - H[1, 2] * H[2, 0])
        + H[0, 2] * (H[1, 0] * H[2, 1] - H[1, 1] * H[2, 0])
    )
    if (det > 0.0 and sign > 0.0) or (det < 0.0 and sign < 0.0):
        return False
    return hi <= max_ratio * lo


def apply_h(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Map N x 2 points through a homography (a point it sends to infinity: inf or nan)."""
    return _apply_h(plain(H), plain(pts).reshape(-1, 2))


@compiled_ieee
def _apply_h(H, p):
    # (a frame calls this a few hundred times on a few points: numpy's overhead, compiled out)
    out = np.empty((p.shape[0], 2))
    for i in range(p.shape[0]):
        out[i, 0], out[i, 1] = apply_point(H, p[i, 0], p[i, 1])
    return out


@compiled_ieee
def apply_point(H, x, y):
    """One point (x, y) through a homography, for compiled loops (see `apply_h`)."""
    w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    return (H[0, 0] * x + H[0, 1] * y + H[0, 2]) / w, (H[1, 0] * x + H[1, 1] * y + H[1, 2]) / w


def span_of(pts: np.ndarray) -> float:
    """The larger side of the points' (N x 2) bounding box: ``np.ptp(pts, axis=0).max()``
    (nan where a coordinate is), in one compiled pass."""
    return _span(plain(pts).reshape(-1, 2))


@compiled_ieee
def _span(p):
    if not len(p):
        return np.nan
    out = 0.0
    for c in range(2):
        lo = hi = p[0, c]
        for i in range(len(p)):
            v = p[i, c]
            if v != v:
                return np.nan
            lo, hi = min(lo, v), max(hi, v)
        d = hi - lo  # (inf - inf: nan, as numpy's)
        if d != d:
            return np.nan
        out = max(out, d) if c else d
    return out


def affine_part(H: np.ndarray, centre_m: np.ndarray) -> np.ndarray:
    """The affine map that agrees with ``H`` at ``centre_m`` to first order."""
    x, y = (float(v) for v in np.asarray(centre_m, np.float64).reshape(2))
    return _affine_part(plain(H), x, y)


@compiled_ieee
def _affine_part(H, x, y):
    w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    at = ((H[0, 0] * x + H[0, 1] * y + H[0, 2]) / w, (H[1, 0] * x + H[1, 1] * y + H[1, 2]) / w)
    A = np.eye(3)
    for r in range(2):
        for c in range(2):
            A[r, c] = (H[r, c] - at[r] * H[2, c]) / w
        A[r, 2] = at[r] - (A[r, 0] * x + A[r, 1] * y)
    return A


def fit_homography(
    image: np.ndarray,
    model: EdgeModel,
    H0: np.ndarray,
    *,
    iterations: int = 6,
    search_px: float = 2.5,
    sides_alike: bool = True,
    deform: Deformation | None = None,
    min_clearance_px: float = MIN_CLEARANCE_PX,
    give_up_below: float = 0.0,
    centroid: bool = False,
) -> HomographyFit | None:
    """Refine ``H0`` so that the model's sides lie on the edges of ``image``.

    Parameters
    ----------
    image : smoothed channel (uint8, or float) in which the model's bright polygons are bright.
    model : the sides to fit (pad metres).
    H0 : starting homography, pad metres -> pixels (an affine guess will do).
    iterations : Gauss-Newton steps at most.
    search_px : how far across each side the first step looks for its edge;
        each later step looks half as far, down to 1.5 px.
    sides_alike : weigh every side alike however many samples it has (for
        the H alone, whose stroke ends pin its height), or every sample alike.
    deform : ways the model may differ from what is in view (the H's strokes
        wider or narrower than the reference's), fitted with the homography.
    min_clearance_px : sides closer than this to a side alongside them are not
        fitted (their edges blur into one).
    give_up_below : a fit that has found less than this share of the sides after
        a few steps (``edge_kernels.GIVE_UP_STEPS``) stops there: for a caller that
        refuses far better fits anyway.
    centroid : edges placed at their drops' centroid (`edge_kernels.edge_offsets`):
        for a pose, not a detection.

    Returns
    -------
    The fit after the step that found the most of the sides' edges, or None
    when too few edges were found to take a step.

    Examples
    --------
    >>> import cv2
    >>> from pipeline.render import PadGeometry
    >>> h = PadGeometry().h_corners_m
    >>> true = np.array([[800.0, 60, 320], [40, -760, 240], [0.1, 0.05, 1]])
    >>> big = np.zeros((480 * 8, 640 * 8), np.float32)  # drawn 8x finer, then averaged
    >>> pts = np.round(((apply_h(true, h) + 0.5) * 8 - 0.5) * 16).astype(np.int32)
    >>> _ = cv2.fillPoly(big, [pts], 200, shift=4)
    >>> img = cv2.resize(big, (640, 480), interpolation=cv2.INTER_AREA)
    >>> start = true.copy(); start[0, 2] += 1.5; start[1, 1] *= 1.02
    >>> fit = fit_homography(img, EdgeModel.from_polygons([(h, True)]), start)
    >>> bool(np.abs(apply_h(fit.H, h) - apply_h(true, h)).max() < 0.25), fit.support > 0.9
    (True, True)
    """
    img = pixels(image)
    H = np.asarray(H0, np.float64) / H0[2, 2]
    # Condition the unknowns: pad metres and pixels both scaled to ~unit size.
    ends, Tm, Tm_inv = model.ends_normalised
    proj0 = apply_h(H, ends)
    if not np.isfinite(proj0).all():
        return None
    Tp, Tp_inv = normalising(proj0)
    Hn = Tp @ H @ Tm_inv
    h0 = (Hn / Hn[2, 2]).ravel()[:8].copy()
    side, t = model.sampling
    deform = deform or Deformation.none(len(model.a_m))
    h, shape, fitted, found, ok = homography_steps(
        img,
        model.a_m,
        model.b_m,
        model.bright,
        model.polygon,
        model.clearance_m,
        model.curved,
        side,
        t,
        deform.a,
        deform.b,
        deform.sigma,
        Tm,
        Tp,
        h0,
        iterations,
        float(search_px),
        sides_alike,
        float(min_clearance_px),
        MIN_SIDE_PX,
        DAMPING,
        MIN_DROP,
        float(give_up_below),
        centroid,
    )
    if not ok:
        return None
    H = Tp_inv @ np.concatenate((h, [1.0])).reshape(3, 3) @ Tm
    H = H / H[2, 2]
    return HomographyFit(H, fitted, _seen_mean(found), found, shape)


def support(
    image: np.ndarray, model: EdgeModel, H: np.ndarray, min_side_px: float = MIN_SIDE_PX
) -> float:
    """Mean over the model's visible sides of the share of samples that sit on an edge.

    Per side, so that a stroke's end, a few samples long, counts as much as a
    leg's side: an H stretched past its strokes' ends must not pass for found.
    """
    H = np.asarray(H, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        if not np.isfinite(apply_h(H, model.ends)).all():
            return 0.0
    pts_m, side = model.samples
    found = side_support(
        pixels(image),
        model.a_m,
        model.b_m,
        model.bright,
        model.polygon,
        model.clearance_m,
        model.curved,
        pts_m,
        side,
        H,
        MIN_CLEARANCE_PX,
        float(min_side_px),
        MIN_DROP,
    )
    return _seen_mean(found)


def _seen_mean(found: np.ndarray) -> float:
    """The mean of the sides' shares that are not nan (0 when none is): ``.mean()``'s
    sum and division, without its call's overhead."""
    seen = found[np.isfinite(found)]
    return float(seen.sum()) / len(seen) if len(seen) else 0.0
