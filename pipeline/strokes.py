"""Is the located H painted as an H is? Its strokes solid, its notches bare.

A look-alike can share nearly every edge of the H: an H cut through a leg or
the crossbar (a broken H) still puts most of its sides where the H's are.
Along the middle of each stroke the paint must stay as bright as it is a few
pixels before and after: a gap cut through the stroke shows as a local dip.
Each point is compared with its own neighbours along the stroke, so shadows
and uneven light, which change the level slowly, do not read as gaps; the
brightest point across the stroke is taken, so a reference drawn with other
stroke widths than the pad in view still samples paint.

A bold letter M puts its legs and its V's edges where a bold H's sides are, its
V's point standing for the crossbar: the H's notches, between its legs above
and below the crossbar, must read as board (`notch_fill`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.homography_fit import apply_h, apply_point
from pipeline.jit import compiled, compiled_ieee, plain

STEP_PX = 1.0  # along each stroke's middle
MAX_DIP = 0.35  # of the H's contrast: a deeper dip along a stroke's middle is a gap
NOISE_DIP = 1.5  # ... and deeper by this many of the middles' noise (standard deviations)
MAX_NOISE = 0.25  # of the contrast: noisier middles are texture, not paint (no more allowance)
_ACROSS = np.linspace(-1.5, 1.5, 7)  # offsets across a stroke, in half stroke widths
# Along the middle of each notch, from the crossbar out: these shares of its depth.
NOTCH_DEPTHS = np.array([0.1, 0.2, 0.3, 0.4])
# A notch that reads this far from its board toward its paint is painted. On the design
# bench's views (ten designs and six more, 40 each, with and without their pads), H's
# read right came to 0.12 at most in today's mix; in the real-world mix the 11 of 922
# readings over it were H's read a quarter turn off (their crossbar on a leg) and one
# misfit in a closer look's window, each read right after. A bold letter M's V, under a
# bold H's crossbar fitted at its point, read 0.90-0.99 (13 readings).
MAX_NOTCH_FILL = 0.5
_UNIT_BOX = np.array([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]], np.float32)


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
    of side (d, e), its half width the mean of those sides' halves. A leg's blurred
    ends are left out; the crossbar's ends meet the legs, paint on paint, and its
    middle runs on into the legs' middles: a gap cut next to a leg lies between the
    leg's paint and the bar's."""
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
    t0 = np.empty(3)  # where the samples start along each middle (0..1: its ends)
    run = np.empty(3)  # and how far they run
    for s in range(3):
        x0, y0 = apply_point(H, start[s, 0], start[s, 1])
        x1, y1 = apply_point(H, end[s, 0], end[s, 1])
        length_px = math.hypot(x1 - x0, y1 - y0)
        length_m[s] = max(math.hypot(end[s, 0] - start[s, 0], end[s, 1] - start[s, 1]), 1e-12)
        if s < 2:
            t0[s] = min(half[s] / length_m[s], 0.25)
            run[s] = 1 - 2 * t0[s]
        else:
            t0[s] = -half[0] / length_m[s]
            run[s] = 1.0 + (half[0] + half[1]) / length_m[s]
        # (a stroke sent to infinity: 3 points, as numpy's cast of it gave; the legs'
        # spaced as their whole length would be, the crossbar's a pixel apart)
        span_px = length_px * (1.0 if s < 2 else run[s])
        counts[s] = max(3, int(span_px / STEP_PX)) if math.isfinite(span_px) else 3
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
        for u in range(counts[s]):
            t = t0[s] + run[s] * (u / (counts[s] - 1))
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


@dataclass(frozen=True, eq=False)
class Notches:
    """Where `notch_fill` reads an H, in pad metres: per notch (above the crossbar,
    below it), rows of `NOTCH_DEPTHS` points along its middle next to the crossbar,
    the two legs' middles and beside the two legs at the same heights, and along its
    far half (``points_m``: 2 x 6 x n x 2); and which of those beside the legs the
    reference shows as board (``board``: 2 x 2 x n)."""

    points_m: np.ndarray
    board: np.ndarray


def notches(corners_m: np.ndarray, is_paint: Callable[[np.ndarray], np.ndarray]) -> Notches:
    """The `Notches` of an H of the 12 ``corners_m``; ``is_paint``: which pad points
    (N x 2 metres) the reference shows painted."""
    c = np.asarray(corners_m, np.float64).reshape(-1, 2)
    # The H's box as the unit square (s to its right, t up): its outer corners.
    outer = np.float32(c[[0, 5, 6, 11]])
    u = apply_h(cv2.getPerspectiveTransform(outer, _UNIT_BOX), c)
    left, right = 0.5 * (u[1, 0] + u[10, 0]), 0.5 * (u[4, 0] + u[7, 0])  # legs' inner sides
    middle = 0.5 * (left + right)
    # the notch's middle, the legs' middles, and beside the legs (then the far half)
    columns = (middle, 0.5 * left, 0.5 * (right + 1.0), -0.5 * left, 1.0 + 0.5 * (1.0 - right))
    unit = []
    for bar, end in ((0.5 * (u[2, 1] + u[3, 1]), 1.0), (0.5 * (u[8, 1] + u[9, 1]), 0.0)):
        near = bar + NOTCH_DEPTHS * (end - bar)
        far = bar + (1.0 - NOTCH_DEPTHS) * (end - bar)
        unit += [(x, y) for x in columns for y in near] + [(middle, y) for y in far]
    n = len(NOTCH_DEPTHS)
    points_m = apply_h(cv2.getPerspectiveTransform(_UNIT_BOX, outer), np.array(unit))
    points_m = points_m.reshape(2, 6, n, 2)
    board = ~is_paint(points_m[:, 3:5].reshape(-1, 2)).reshape(2, 2, n)
    return Notches(points_m, board)


def notch_fill(image: np.ndarray, weights: np.ndarray, where: Notches, H: np.ndarray) -> float:
    """How painted the H's notches read next to its crossbar, from 0 (an H's: board) to
    1 (paint): the larger of the two notches'.

    Along the middle of a notch, next to the crossbar, its level is read toward each
    leg's middle at the same height from two grounds: the board beside that leg, at
    the same height (a shadow's edge across the legs dims all three alike), and the
    notch's own far half (a shadow band down the H's middle dims both). A shadow
    darkens one ground and not the other where it falls between them, and paint fills
    a notch from both: the smaller of the two readings, the smaller of the two legs'
    (a shadow's edge between the notch and a leg reads it off too), their median. nan
    where neither ground is seen.

    ``image``: the view (BGR), ``weights`` its channel's; ``where``: the H's `Notches`;
    ``H``: pad metres -> the view's pixels."""
    shape = where.points_m.shape[:3]
    v = _sample(image, apply_h(H, where.points_m.reshape(-1, 2)), weights).reshape(shape)
    return _notch_fill_of(v, where.board)


@compiled
def _notch_fill_of(v, board):
    """`notch_fill` from its samples' levels (``v``, 2 x 6 x n: see `Notches`) and
    which of those beside the legs are board (2 x 2 x n)."""
    n = v.shape[2]
    best = np.nan
    fill = np.empty(n)
    for k in range(2):
        far = np.median(v[k, 5])
        told = 0
        for i in range(n):
            lowest = np.nan  # (the smallest reading, of both legs from both grounds)
            for leg in range(2):
                for ground in (v[k, 3 + leg, i] if board[k, leg, i] else np.nan, far):
                    contrast = v[k, 1 + leg, i] - ground
                    if contrast > 0.0:
                        read = (v[k, 0, i] - ground) / contrast
                        if not read >= lowest:  # (nan: none yet)
                            lowest = read
            fill[told] = lowest
            told += lowest == lowest
        if told:
            median = np.median(fill[:told])
            if not median <= best:
                best = median
    return best
