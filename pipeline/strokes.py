"""Is the located H painted solid? Its strokes, sampled along their middles.

A look-alike can share nearly every edge of the H: an H cut through a leg or
the crossbar (a broken H) still puts most of its sides where the H's are.
Along the middle of each stroke the paint must stay as bright as it is a few
pixels before and after: a gap cut through the stroke shows as a local dip.
Each point is compared with its own neighbours along the stroke, so shadows
and uneven light, which change the level slowly, do not read as gaps; the
brightest point across the stroke is taken, so a reference drawn with other
stroke widths than the pad in view still samples paint.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from pipeline.homography_fit import apply_point
from pipeline.jit import compiled, compiled_ieee, plain

STEP_PX = 1.0  # along each stroke's middle
MAX_DIP = 0.35  # of the H's contrast: a deeper dip along a stroke's middle is a gap
NOISE_DIP = 1.5  # ... and deeper by this many of the middles' noise (standard deviations)
MAX_NOISE = 0.25  # of the contrast: noisier middles are texture, not paint (no more allowance)
_ACROSS = np.linspace(-1.5, 1.5, 7)  # offsets across a stroke, in half stroke widths


def stroke_samples(
    corners_m: np.ndarray, H: np.ndarray, is_paint: Callable[[np.ndarray], np.ndarray]
):
    """Where to sample the strokes and the board beside them, in frame pixels.

    ``is_paint``: which pad points (N x 2 metres) the reference shows painted.
    Returns (paint, side_a, side_b, a_ok, b_ok, counts): ``paint`` (K x m x 2)
    holds K points across each of m middle points; the sides lie a
    stroke-half past the strokes' edges; ``a_ok``/``b_ok`` say which side
    points are board (not on the H or another painted mark); ``counts``: middle
    points per stroke.
    """
    paint, side_a, side_b, sides_m, counts = _stroke_points(plain(corners_m), plain(H), _ACROSS)
    board = ~is_paint(sides_m)
    m = len(side_a)
    return paint, side_a, side_b, board[:m], board[m:], tuple(int(n) for n in counts)


@compiled_ieee  # (an H that sends a point to infinity: inf or nan, as numpy's)
def _stroke_points(c, H, across):
    """`stroke_samples`' points: across (K x m x 2) and beside (m x 2, each side) the
    strokes' middles in pixels, the sides' points in pad metres (2m x 2, side a's
    first) and the middle points per stroke.

    The left leg's, right leg's and crossbar's middles, in the 12-corner order
    (corners 0, 1, 10, 11 are the left leg's, 4-7 the right's, 2, 3, 8, 9 the
    crossbar's inner corners): each runs from the mid-point of side (a, b) to that
    of side (d, e), its half width the mean of those sides' halves."""
    ia, ib, id_, ie = (0, 4, 2), (1, 5, 9), (11, 7, 3), (10, 6, 8)
    start = np.empty((3, 2))
    end = np.empty((3, 2))
    half = np.empty(3)
    counts = np.empty(3, np.int64)
    for s in range(3):
        a, b, d, e = c[ia[s]], c[ib[s]], c[id_[s]], c[ie[s]]
        across_ab = math.hypot(b[0] - a[0], b[1] - a[1])
        half[s] = 0.25 * (across_ab + math.hypot(e[0] - d[0], e[1] - d[1]))
        for k in range(2):
            start[s, k] = 0.5 * (a[k] + b[k])
            end[s, k] = 0.5 * (d[k] + e[k])
    length_m = np.empty(3)
    px_per_m = np.empty(3)
    for s in range(3):
        x0, y0 = apply_point(H, start[s, 0], start[s, 1])
        x1, y1 = apply_point(H, end[s, 0], end[s, 1])
        length_px = math.hypot(x1 - x0, y1 - y0)
        length_m[s] = max(math.hypot(end[s, 0] - start[s, 0], end[s, 1] - start[s, 1]), 1e-12)
        # (a stroke sent to infinity: 3 points, as numpy's cast of it gave)
        counts[s] = max(3, int(length_px / STEP_PX)) if math.isfinite(length_px) else 3
        px_per_m[s] = length_px / length_m[s]
    m = counts.sum()
    paint = np.empty((len(across), m, 2))
    side_a = np.empty((m, 2))
    side_b = np.empty((m, 2))
    sides_m = np.empty((2 * m, 2))
    q = 0
    for s in range(3):
        dx = (end[s, 0] - start[s, 0]) / length_m[s]
        dy = (end[s, 1] - start[s, 1]) / length_m[s]
        nx, ny = -dy, dx
        # beside the stroke: a stroke-half (at least 1.5 px) past its edge
        reach = half[s] + max(1.5, half[s] * px_per_m[s]) / px_per_m[s]
        inset = min(half[s] / length_m[s], 0.25)  # a stroke's blurred end is left out
        for u in range(counts[s]):
            t = inset + (1 - 2 * inset) * (u / (counts[s] - 1))
            mx = start[s, 0] + t * (end[s, 0] - start[s, 0])
            my = start[s, 1] + t * (end[s, 1] - start[s, 1])
            # A reference drawn with thinner or bolder strokes than the pad in view
            # puts its middles off the pad's: points across a stroke and a half.
            for k in range(len(across)):
                off = across[k] * half[s]
                paint[k, q, 0], paint[k, q, 1] = apply_point(H, mx + off * nx, my + off * ny)
            sides_m[q, 0], sides_m[q, 1] = mx + reach * nx, my + reach * ny
            sides_m[m + q, 0], sides_m[m + q, 1] = mx - reach * nx, my - reach * ny
            side_a[q, 0], side_a[q, 1] = apply_point(H, sides_m[q, 0], sides_m[q, 1])
            side_b[q, 0], side_b[q, 1] = apply_point(H, sides_m[m + q, 0], sides_m[m + q, 1])
            q += 1
    return paint, side_a, side_b, sides_m, counts


def _sample(image: np.ndarray, pts: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``weights . pixel`` at each point (N x 2), bilinear, the image's border
    replicated; nan at points that are not finite."""
    p = plain(pts).reshape(-1, 2)
    x0 = y0 = 0
    if not (image.flags.c_contiguous and image.flags.writeable):
        # A window's pixels (or a read-only picture's, which would need a compiled
        # variant of its own): only those around the points are copied (cut at the
        # image's own edges, the crop's replicated border is the image's).
        h, w = image.shape[:2]
        seen = p[np.isfinite(p).all(axis=1)]
        x1, y1 = w, h
        if len(seen):
            x0, y0 = np.clip(np.floor(seen.min(axis=0)) - 1, 0, [w - 1, h - 1]).astype(int)
            x1, y1 = np.clip(np.ceil(seen.max(axis=0)) + 2, [x0 + 1, y0 + 1], [w, h]).astype(int)
        image = plain(image[y0:y1, x0:x1], image.dtype)
        p = p - [x0, y0]
    weights = np.asarray(weights, np.float64).reshape(-1)
    if image.ndim == 2:  # (a gray picture: every channel alike)
        image, weights = image[..., None], np.array([weights.sum()])
    return _weighted_bilinear(image, p, weights)


@compiled
def _weighted_bilinear(img, pts, weights):
    """`_sample` on an H x W x C image (its channels weighed by ``weights``)."""
    h, w, c = img.shape
    out = np.empty(pts.shape[0])
    for i in range(pts.shape[0]):
        x, y = pts[i, 0], pts[i, 1]
        if not (math.isfinite(x) and math.isfinite(y)):
            out[i] = np.nan
            continue
        fx, fy = math.floor(x), math.floor(y)
        ax, ay = x - fx, y - fy
        x0, x1 = min(max(int(fx), 0), w - 1), min(max(int(fx) + 1, 0), w - 1)
        y0, y1 = min(max(int(fy), 0), h - 1), min(max(int(fy) + 1, 0), h - 1)
        acc = 0.0
        for k in range(c):
            top = img[y0, x0, k] * (1.0 - ax) + img[y0, x1, k] * ax
            bottom = img[y1, x0, k] * (1.0 - ax) + img[y1, x1, k] * ax
            acc += weights[k] * (top * (1.0 - ay) + bottom * ay)
        out[i] = acc
    return out


def paint_and_board(
    image: np.ndarray, weights: np.ndarray, samples
) -> tuple[np.ndarray, np.ndarray]:
    """Per middle point, the paint's and the board's value of ``weights . pixel``
    (the brightest across the stroke; the darker board side), without offset:
    a change of exposure scales both. Board values are nan where no side is board."""
    paint, side_a, side_b, a_ok, b_ok, _ = samples
    k, m = paint.shape[:2]
    v = _sample(image, np.vstack([paint.reshape(-1, 2), side_a, side_b]), weights)
    centre = v[: k * m].reshape(k, m).max(axis=0)
    va = np.where(a_ok, v[k * m : k * m + m], np.inf)
    vb = np.where(b_ok, v[k * m + m :], np.inf)
    board = np.minimum(va, vb)
    return centre, np.where(np.isfinite(board), board, np.nan)


def deepest_dip(image: np.ndarray, weights, samples) -> float:
    """The deepest local dip along any stroke's middle, as a share of the H's
    contrast with the board beside it (0: solid strokes; ~1: a clean gap)."""
    return _dip_and_noise(image, weights, samples)[0]


def cut_through(image: np.ndarray, weights, samples) -> bool:
    """Whether a stroke is cut through: its deepest dip is deeper than ``MAX_DIP``,
    and than the noise along the strokes' middles makes of solid paint
    (``NOISE_DIP``). A small H's strokes, 1-2 px in a noisy frame, change by a
    fifth of the contrast from one point to the next: their deepest dips came to
    0.37-0.52 on the bench's printed pad at 2.5-3 m; a gap's is 0.6 and over. The
    allowance stops at ``MAX_NOISE``: a real photo's H-shaped texture, its noise
    over its contrast, had a dip of 0.87."""
    dip, noise = _dip_and_noise(image, weights, samples)
    return dip > MAX_DIP + NOISE_DIP * min(noise, MAX_NOISE)


def _dip_and_noise(image: np.ndarray, weights, samples) -> tuple[float, float]:
    """The deepest dip (see `deepest_dip`) and the noise along the strokes' middles
    (its standard deviation, from the median step between neighbours), both as
    shares of the contrast; nan when no board lies beside the strokes."""
    centre, board = paint_and_board(image, weights, samples)
    return _dip_and_noise_of(centre, board, np.asarray(samples[5], np.int64))


@compiled
def _dip_and_noise_of(centre, board, counts):
    """`_dip_and_noise` from the middles' and the board's values (nan: no board)."""
    on_board = board[np.isfinite(board)]
    if not len(on_board):
        return np.nan, np.nan
    contrast = np.median(centre) - np.median(on_board)
    if contrast <= 0:
        return 1.0, 0.0
    # Steps between neighbours within each stroke; one between two points holds the
    # noise of both: median |step| = 0.954 sigma.
    steps = np.empty(len(centre) - len(counts))
    q = start = 0
    for n in counts:
        for i in range(n - 1):
            steps[q] = abs(centre[start + i + 1] - centre[start + i])
            q += 1
        start += n
    noise = np.median(steps) / 0.954 / contrast
    return _deepest_dip(centre, counts, contrast), noise


@compiled
def _deepest_dip(centre, counts, contrast):
    """Along each stroke (``counts`` points each, one after another in ``centre``),
    the deepest dip of a point under the brightest within w points before it and
    the brightest within w points after it (w: a twelfth of the stroke, at least 2)."""
    worst = 0.0
    start = 0
    for n in counts:
        w = max(2, n // 12)
        for i in range(n):
            left = -np.inf
            for k in range(max(0, i - w), i + 1):
                left = max(left, centre[start + k])
            right = -np.inf
            for k in range(i, min(n, i + w + 1)):
                right = max(right, centre[start + k])
            worst = max(worst, (min(left, right) - centre[start + i]) / contrast)
        start += n
    return worst
