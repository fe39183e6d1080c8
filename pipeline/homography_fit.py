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

from dataclasses import dataclass

import numpy as np

from pipeline.edgefit import EdgeModel, edge_offsets, side_samples

MIN_SIDE_PX = 1.0  # a stroke end of a small H may be 2 px: still measured
DAMPING = 1e-3
MIN_CLEARANCE_PX = 1.0  # closer parallel sides blur into one line: not used (a thin
# stroke's two sides pull each other inward alike, so its middle stays right)


@dataclass(frozen=True, eq=False)
class HomographyFit:
    """``H``: 3 x 3 map from pad metres (x, y, 1) to frame pixels. ``rms_px``: RMS
    distance of the inlier edge points to the model's sides. ``support``: per
    visible side, the share of its samples with an edge of the right polarity
    within 0.75 px of where ``H`` puts it, averaged over the sides."""

    H: np.ndarray
    rms_px: float
    support: float


def apply_h(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Map N x 2 points through a homography."""
    p = np.asarray(pts, np.float64).reshape(-1, 2)
    q = p @ H[:2, :2].T + H[:2, 2]
    w = p @ H[2, :2] + H[2, 2]
    return q / w[:, None]


def fit_homography(
    image: np.ndarray,
    model: EdgeModel,
    H0: np.ndarray,
    *,
    iterations: int = 6,
    search_px: float = 2.5,
    sides_alike: bool = True,
) -> HomographyFit | None:
    """Refine ``H0`` so that the model's sides lie on the edges of ``image``.

    Parameters
    ----------
    image : float32 smoothed channel in which the model's bright polygons are bright.
    model : the sides to fit (pad metres).
    H0 : starting homography, pad metres -> pixels (an affine guess will do).
    iterations : Gauss-Newton steps at most.
    search_px : how far across each side the first step looks for its edge;
        each later step looks half as far, down to 1.5 px.
    sides_alike : weigh every side alike however many samples it has (for
        the H alone, whose stroke ends pin its height), or every sample alike.

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
    img = image if image.dtype == np.float32 else image.astype(np.float32)
    H = np.asarray(H0, np.float64) / H0[2, 2]
    # Condition the unknowns: pad metres and pixels both scaled to ~unit size.
    ends = np.vstack([model.a_m, model.b_m])
    cm = ends.mean(axis=0)
    sm = 1.0 / max(float(np.ptp(ends, axis=0).max()), 1e-9)
    Tm = np.array([[sm, 0, -sm * cm[0]], [0, sm, -sm * cm[1]], [0, 0, 1]])
    proj0 = apply_h(H, ends)
    cp = proj0.mean(axis=0)
    sp = 1.0 / max(float(np.ptp(proj0, axis=0).max()), 1e-9)
    Tp = np.array([[sp, 0, -sp * cp[0]], [0, sp, -sp * cp[1]], [0, 0, 1]])
    Hn = Tp @ H @ np.linalg.inv(Tm)
    Hn = Hn / Hn[2, 2]
    h = Hn.ravel()[:8].copy()
    fitted = None
    for it in range(iterations):
        H = np.linalg.inv(Tp) @ _h_matrix(h) @ Tm
        search = max(1.5, search_px / 2**it)  # wide first, then within 1.5 px
        samples = _samples(model, H, MIN_CLEARANCE_PX)
        if samples is None:
            return None
        pts_m, normal, side = samples
        xn = apply_h(Tm, pts_m)
        proj_n, jac_n = _project(h, xn)
        proj = (proj_n - Tp[:2, 2]) / sp
        delta, ok = edge_offsets(img, proj, normal, search)
        if np.count_nonzero(ok) < 10:
            return None
        r = -delta[ok]
        J = np.einsum("nk,nkp->np", normal[ok], jac_n[ok]) / sp
        keep = np.abs(r - np.median(r)) <= max(0.5, 3.0 * _mad(r))
        r, J, sid = r[keep], J[keep], side[ok][keep]
        if len(r) < 10:
            return None
        # Every side counts alike, however long: a stroke's end, a few pixels
        # wide, is all that pins the H's height.
        w = np.where(np.abs(r) <= 0.5, 1.0, 0.5 / np.maximum(np.abs(r), 1e-9))
        if sides_alike:
            w = w / np.bincount(sid, minlength=len(model.a_m))[sid]
        JtW = J.T * w
        A = JtW @ J
        A += DAMPING * np.diag(np.diag(A)) + 1e-12 * np.eye(8)
        try:
            step = np.linalg.solve(A, -JtW @ r)
        except np.linalg.LinAlgError:
            return None
        h = h + step
        fitted = float(np.sqrt(np.mean((r + J @ step) ** 2)))
        if it > 0 and np.abs(step).max() < 0.05 * sp:  # under ~0.05 px anywhere on the H
            break
    if fitted is None:
        return None
    H = np.linalg.inv(Tp) @ _h_matrix(h) @ Tm
    H = H / H[2, 2]
    return HomographyFit(H, fitted, support(img, model, H))


def support(
    image: np.ndarray, model: EdgeModel, H: np.ndarray, min_side_px: float = MIN_SIDE_PX
) -> float:
    """Mean over the model's visible sides of the share of samples that sit on an edge.

    Per side, so that a stroke's end, a few samples long, counts as much as a
    leg's side: an H stretched past its strokes' ends must not pass for found.
    """
    samples = _samples(model, H, MIN_CLEARANCE_PX, min_side_px)
    if samples is None:
        return 0.0
    pts_m, normal, side = samples
    proj = apply_h(H, pts_m)
    delta, ok = edge_offsets(image, proj, normal, 1.5)
    h, w = image.shape[:2]
    seen = (proj[:, 0] > 2) & (proj[:, 1] > 2) & (proj[:, 0] < w - 3) & (proj[:, 1] < h - 3)
    if not seen.any():
        return 0.0
    hit = (ok & (np.abs(delta) <= 0.75))[seen].astype(np.float64)
    sides = side[seen]
    n = np.bincount(sides)
    present = n > 0
    return float(np.mean(np.bincount(sides, hit)[present] / n[present]))


def _samples(
    model: EdgeModel, H: np.ndarray, min_clearance_px: float, min_side_px: float = MIN_SIDE_PX
):
    n = len(model.a_m)
    ends = apply_h(H, np.vstack([model.a_m, model.b_m]))
    if not np.all(np.isfinite(ends)):
        return None
    pa, pb = ends[:n], ends[n:]
    len_m = np.hypot(*(model.b_m - model.a_m).T)
    len_px = np.hypot(*(pb - pa).T)
    clearance_px = model.clearance_m * len_px / np.maximum(len_m, 1e-12)
    return side_samples(model, pa, pb, clearance_px >= min_clearance_px, min_side_px)


def _h_matrix(h: np.ndarray) -> np.ndarray:
    return np.append(h, 1.0).reshape(3, 3)


def _project(h: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Projected points (N x 2) and their Jacobian (N x 2 x 8) w.r.t. the 8 entries."""
    X, Y = x[:, 0], x[:, 1]
    w = h[6] * X + h[7] * Y + 1.0
    u = (h[0] * X + h[1] * Y + h[2]) / w
    v = (h[3] * X + h[4] * Y + h[5]) / w
    z = np.zeros_like(X)
    one = np.ones_like(X)
    ju = np.stack([X, Y, one, z, z, z, -u * X, -u * Y], axis=1) / w[:, None]
    jv = np.stack([z, z, z, X, Y, one, -v * X, -v * Y], axis=1) / w[:, None]
    return np.column_stack([u, v]), np.stack([ju, jv], axis=1)


def _mad(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))
