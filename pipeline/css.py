"""Curvature-scale-space (CSS) corners: He & Yung's detector, ported from its description.

The detector (X.C. He and N.H.C. Yung, ICPR 2004 / Optical Engineering 2008; the seed's
section 4.1.2, eqs. 4.5-4.7) finds corners on edge curves:

1. an edge map (Canny from a gray image, or a binary region's boundary);
2. edge curves traced from it (:func:`trace_edges`), each open or closed;
3. the curvature ``K = |x'y'' - x''y'| / (x'^2 + y'^2)^(3/2)`` of each curve smoothed
   by a Gaussian of ``sigma`` (window ``W``: the largest ``p <= 30`` with
   ``g(p) > 1e-4``, 12 for sigma 3), closed curves wrapped, open ones extended by
   point reflection;
4. local maxima of ``K`` as candidates;
5. round corners removed: keep a maximum only if ``K >= c * mean(K)`` over its region
   of support (from the local minimum on its left to the one on its right);
6. false corners removed: the angle between the two arms (each running to the
   previous or next candidate, looked at over ``2 W`` samples at most) must lie
   outside ``[t_angle, 360 - t_angle]``; repeated until a pass removes nothing. The
   angle is estimated twice on the smoothed curve and either estimate may reject:
   from the arms' mean offsets (the seed's eq. 4.7a/b) and, where both arms reach
   ``2 W`` samples, from the reference's three-point circle fit;
7. corners reported at the unsmoothed contour pixel; an open curve's end points are
   added unless within 5 px of a corner already listed.

Defaults are the authors': ``sigma=3``, ``c=1.5``, ``t_angle_deg=162``, Canny
high/low ``0.35/0`` of the largest gradient, end points on, gap size 1.

Faults of the authors' MATLAB reference (``corner.m``) that this port does not have:

- tangent directions were not wrapped, so a kink of 169 deg could read 530 deg and be
  kept: here each direction comes from ``angle()`` and the difference is taken modulo
  360, so the test does not depend on the curve's rotation;
- (a weakness rather than a bug) its circle fit through the arm's far end lets
  staircase ripples on a short edge between two close corners pass as corners (the
  far end lies in the neighbour's rounded-off zone), and bends true corners of
  polygons with short edges towards 180 deg. Here the mean offset decides on short
  arms and the circle fit is consulted only over arms clear of the neighbours: on
  840 rasterised H outlines (bar width 10-80 px, rotations 3 deg apart) the circle
  fit alone miscounted 24 and this none, while filled digital circles of radius
  8-200 px stay free of corners;
- smoothing zero-padded the (already extended) curve, dragging its first and last
  ``W`` samples towards the image origin, so results changed when the image was
  shifted: here the curve is extended first (wrapped or reflected) and smoothed with
  ``'valid'`` convolution, so results move exactly with the image;
- it crashed when no corner was found on a curve set with an open curve, and when no
  curve was long enough: here those give empty results;
- curvature was quantised to 0.01 with ``ceil``, making threshold ties depend on the
  summation order: here it is not quantised;
- it drew markers that crashed on the image border: nothing here draws.

Closed curves are handled circularly throughout (extrema, regions of support and arms
wrap around), so a corner at a contour's first point is found like any other.

Examples
--------
>>> import numpy as np
>>> side = np.arange(0, 40)
>>> square = np.concatenate([
...     np.stack([np.zeros(40), side], 1), np.stack([side, np.full(40, 40)], 1),
...     np.stack([np.full(40, 40), 40 - side], 1), np.stack([40 - side, np.zeros(40)], 1)])
>>> css_corners(square, closed=True).tolist()
[0, 40, 80, 120]
"""

from __future__ import annotations

import functools
import math
import numbers

import cv2
import numpy as np

__all__ = ["css_corners", "detect_corners", "gaussian_window", "trace_edges"]

# Curvature (1/px) at or below which a maximum is floating-point noise on a straight run.
_K_NOISE = 1e-9
# Cross products (px^2) below which three points count as collinear.
_COLLINEAR = 1e-8
# Squared distance (px^2) under which a traced curve's two ends make it closed.
_CLOSED_GAP2 = 32
# An open curve's end point is added only if farther than this (px^2) from all corners.
_ENDPOINT_GAP2 = 25


def gaussian_window(sigma: float) -> int:
    """Half-width ``W`` of the curvature smoothing kernel for ``sigma``.

    The largest ``p`` in 1..30 with ``exp(-p^2 / 2 sigma^2) > 1e-4`` (1 if none).

    Examples
    --------
    >>> gaussian_window(3.0)
    12
    """
    sigma = _positive(sigma, "sigma")
    p = np.arange(1, 31)
    above = np.flatnonzero(np.exp(-(p * p) / (2 * sigma * sigma)) > 1e-4)
    return int(p[above[-1]]) if above.size else 1


def css_corners(
    curve: np.ndarray,
    closed: bool,
    *,
    sigma: float = 3.0,
    c: float = 1.5,
    t_angle_deg: float = 162.0,
    endpoints: bool = True,
    fewest: int = 0,
) -> np.ndarray:
    """Corners of one ordered contour, as sorted indices into ``curve``.

    Parameters
    ----------
    curve : (N, 2) or OpenCV (N, 1, 2) array
        The contour's points (x, y) in order, e.g. from ``cv2.findContours`` with
        ``CHAIN_APPROX_NONE`` or from :func:`trace_edges`.
    closed : bool
        True for a closed contour (its last point joins its first).
    sigma : float
        Scale of the Gaussian smoothing before the curvature is taken.
    c : float
        Round-corner factor: a maximum must reach ``c`` times the mean curvature of
        its region of support.
    t_angle_deg : float
        Corners whose angle lies in ``[t_angle_deg, 360 - t_angle_deg]`` are rejected.
    endpoints : bool
        For an open curve, also report its end points (unless within 5 px of a corner).
    fewest : int
        For a caller that wants at least this many corners: when fewer candidates pass
        the round-corner test, they are returned without the false-corner passes
        (which only remove corners: the result has fewer either way).

    Returns
    -------
    np.ndarray of int
        Sorted indices of the corners; empty when there are none.

    Notes
    -----
    Features must be a few ``sigma`` apart to be told apart: at ``sigma=3`` a
    rasterised H gives its 12 corners at every rotation when its bars are 10 px wide
    or more, but not at 8 px. Where a curvature peak is a two-sample plateau (an exact
    tie, e.g. a concave pixel corner) rounding picks one of the two, so moving the
    contour's start point may move such a corner by one sample.

    Examples
    --------
    >>> import numpy as np
    >>> ell = np.array([(30, y) for y in range(20, 80)] + [(x, 80) for x in range(30, 81)])
    >>> css_corners(ell, closed=False).tolist()
    [0, 60, 110]
    """
    z = _curve_as_complex(curve)
    closed = _flag(closed, "closed")
    sigma = _positive(sigma, "sigma")
    c = _non_negative(c, "c")
    t_angle = _angle_threshold(t_angle_deg)
    endpoints = _flag(endpoints, "endpoints")

    found = _curve_corners(z, closed, sigma, c, t_angle, int(fewest))
    if endpoints and not closed and z.size:
        found = _with_endpoints(z, found, z[found])
    return found


def trace_edges(
    edge_map: np.ndarray, *, gap_size: int = 1, min_length: float | None = None
) -> list[tuple[np.ndarray, bool]]:
    """Trace an edge map into ordered curves.

    From each seed pixel (taken in column-major order, as the reference does) walk to
    the nearest remaining edge pixel inside a ``(2 gap_size + 1)^2`` window until none
    is left, then walk backward from the seed the same way; pixels are consumed as
    they are visited. Ties between equally near pixels go to the smaller x, then y.

    Parameters
    ----------
    edge_map : 2-D bool or integer array
        Non-zero pixels are edges.
    gap_size : int
        1 is plain 8-connectivity; 2 bridges one-pixel gaps.
    min_length : float, optional
        Keep curves with more than this many points; default ``(rows + cols) / 25``.

    Returns
    -------
    list of (points, closed)
        ``points``: (n, 2) int array of (x, y) pixels in order; ``closed``: its ends
        are within sqrt(32) px of each other.

    Examples
    --------
    >>> import numpy as np
    >>> em = np.zeros((20, 20), bool)
    >>> em[5, 2:15] = True
    >>> [(len(p), closed) for p, closed in trace_edges(em)]
    [(13, False)]
    """
    em = _edge_map(edge_map)
    if isinstance(gap_size, bool) or not isinstance(gap_size, int | np.integer) or gap_size < 1:
        raise ValueError(f"gap_size must be a positive integer, got {gap_size!r}")
    g = int(gap_size)
    rows, cols = em.shape
    if min_length is None:
        min_length = (rows + cols) / 25
    min_length = _non_negative(min_length, "min_length")
    if em.size == 0 or not em.any():
        return []

    # Work on a flat, padded copy: a bytearray is the fastest thing to poke from Python.
    width = cols + 2 * g
    padded = np.zeros((rows + 2 * g, width), np.uint8)
    padded[g : g + rows, g : g + cols] = em
    alive = bytearray(padded.tobytes())
    window = [
        (dx * dx + dy * dy, dx, dy)
        for dx in range(-g, g + 1)
        for dy in range(-g, g + 1)
        if dx or dy
    ]
    offsets = [dy * width + dx for _, dx, dy in sorted(window)]

    def walk(start: int) -> list[int]:
        path, here = [], start
        while True:
            for off in offsets:
                there = here + off
                if alive[there]:
                    break
            else:
                return path
            alive[there] = 0
            path.append(there)
            here = there

    xs, ys = np.nonzero(em.T)  # column-major order, like MATLAB's find
    seeds = ((ys + g) * width + (xs + g)).tolist()
    curves: list[tuple[np.ndarray, bool]] = []
    for seed in seeds:
        if not alive[seed]:
            continue
        alive[seed] = 0
        ahead = walk(seed)
        behind = walk(seed)
        flat = np.array([*behind[::-1], seed, *ahead], dtype=np.int64)
        if flat.size <= min_length:
            continue
        pts = np.stack([flat % width - g, flat // width - g], axis=1)
        gap = pts[0] - pts[-1]
        curves.append((pts, bool(gap @ gap <= _CLOSED_GAP2)))
    return curves


def detect_corners(
    image: np.ndarray,
    *,
    sigma: float = 3.0,
    c: float = 1.5,
    t_angle_deg: float = 162.0,
    gap_size: int = 1,
    endpoints: bool = True,
    canny: tuple[float, float] = (0.35, 0.0),
) -> np.ndarray:
    """He & Yung's whole detector: edges, curves, CSS corners.

    Parameters
    ----------
    image : 2-D bool or uint8 array
        A bool array is taken as the edge map; a uint8 gray image goes through Canny
        first (L2 gradient, thresholds as fractions of its largest Sobel magnitude).
    sigma, c, t_angle_deg, endpoints
        As in :func:`css_corners`; end points are checked against the corners of all
        curves, as the reference does.
    gap_size : int
        As in :func:`trace_edges`.
    canny : (high, low)
        Canny's thresholds as fractions of the largest gradient magnitude.

    Returns
    -------
    (M, 2) float array
        Corner points (x, y), 0-based pixels; curves in tracing order, each curve's
        corners in its order, then the added end points. ``(0, 2)`` when none.

    Examples
    --------
    >>> import numpy as np
    >>> em = np.zeros((100, 100), bool)
    >>> em[29:70, [29, 69]] = True
    >>> em[[29, 69], 29:70] = True
    >>> detect_corners(em).tolist()
    [[29.0, 29.0], [29.0, 69.0], [69.0, 69.0], [69.0, 29.0]]
    """
    sigma = _positive(sigma, "sigma")
    c = _non_negative(c, "c")
    t_angle = _angle_threshold(t_angle_deg)
    endpoints = _flag(endpoints, "endpoints")
    if image is None:
        raise ValueError("image must be a 2-D bool edge map or uint8 gray image, got None")
    arr = np.asarray(image)
    if arr.ndim != 2:
        raise ValueError(f"image must be 2-D (bool edge map or uint8 gray), got shape {arr.shape}")
    if arr.dtype == np.bool_:
        edge_map = arr
    elif arr.dtype == np.uint8:
        edge_map = _canny(arr, canny)
    else:
        raise ValueError(f"image must be bool (edge map) or uint8 (gray), got dtype {arr.dtype}")

    curves = trace_edges(edge_map, gap_size=gap_size)
    found: list[np.ndarray] = []
    for pts, closed in curves:
        z = pts[:, 0] + 1j * pts[:, 1]
        found.append(pts[_curve_corners(z, closed, sigma, c, t_angle)])
    corners = np.concatenate(found) if found else np.zeros((0, 2))
    if endpoints:
        for pts, closed in curves:
            if closed:
                continue
            for end in (pts[0], pts[-1]):
                gaps = corners - end
                if corners.shape[0] == 0 or np.min(np.sum(gaps * gaps, axis=1)) > _ENDPOINT_GAP2:
                    corners = np.concatenate([corners, end[None, :]])
    return np.asarray(corners, dtype=np.float64).reshape(-1, 2)


# --- the algorithm ----------------------------------------------------------------------


@functools.lru_cache(maxsize=16)
def _kernel(sigma: float) -> tuple[int, np.ndarray]:
    """Half-width and normalised Gaussian kernel for ``sigma`` (read-only, cached)."""
    w = gaussian_window(sigma)
    t = np.arange(-w, w + 1)
    kernel = np.exp(-(t * t) / (2 * sigma * sigma))
    kernel /= kernel.sum()
    kernel.setflags(write=False)
    return w, kernel


def _curve_corners(
    z: np.ndarray, closed: bool, sigma: float, c: float, t_angle: float, fewest: int = 0
) -> np.ndarray:
    """Steps 3-6 on one curve given as complex points; sorted corner indices (step 6
    left out when fewer than ``fewest`` candidates come to it)."""
    n_pts = z.size
    w, kernel = _kernel(sigma)
    if n_pts <= w or n_pts < 3:
        return np.zeros(0, dtype=np.intp)
    # Relative to the first point: exact for integer coordinates, so a shifted curve
    # gives bit-identical arithmetic (and smaller rounding for curves far from 0).
    z = z - z[0]

    # Extend first, then 'valid' convolution: every smoothed sample sees only curve
    # points (wrapped or point-reflected), never zero padding. Two extra samples at
    # each end let both central differences stay central.
    ext = _extend(z, w + 2) if closed else _extend(z, 2 * w + 2, reflect=True)
    smooth = np.convolve(ext, kernel, mode="valid")
    d1 = (smooth[2:] - smooth[:-2]) * 0.5
    d2 = (d1[2:] - d1[:-2]) * 0.5
    d1 = d1[1:-1]
    smooth = smooth[2:-2]
    speed2 = np.maximum(d1.real * d1.real + d1.imag * d1.imag, 1e-12)
    curvature = np.abs(d1.real * d2.imag - d2.real * d1.imag) / (speed2 * np.sqrt(speed2))

    if closed:
        cand = _round_corner_filter_closed(curvature, c)
    else:
        cand = _round_corner_filter_open(curvature, c)
    # Maxima at rounding-noise level lie on straight runs; dropping them is no
    # quantisation (no real corner comes near) but keeps them from cutting arms short.
    cand = cand[curvature[cand] > _K_NOISE]
    if cand.size >= fewest:
        cand = _false_corner_filter(smooth, cand, closed, t_angle, 2 * w)
    if not closed:
        cand = cand[(cand >= w) & (cand < w + n_pts)] - w
    return cand.astype(np.intp)


def _extend(z: np.ndarray, m: int, *, reflect: bool = False) -> np.ndarray:
    """``z`` with ``m`` more samples at each end: wrapped around, or point-reflected
    about the end points (``2 z[0] - z[k]``) for an open curve."""
    if z.size <= m:  # too short to slice: let np.pad repeat the pattern
        if reflect:
            return np.pad(z, m, mode="reflect", reflect_type="odd")
        return np.pad(z, m, mode="wrap")
    if reflect:
        return np.concatenate((2 * z[0] - z[m:0:-1], z, 2 * z[-1] - z[-2 : -m - 2 : -1]))
    return np.concatenate((z[-m:], z, z[:m]))


def _round_corner_filter_open(k: np.ndarray, c: float) -> np.ndarray:
    """Local maxima of ``k`` (a sequence) that pass the adaptive threshold."""
    n = k.size
    slope = np.sign(np.diff(k))
    nz = np.flatnonzero(slope)
    if nz.size == 0:
        return np.zeros(0, dtype=np.intp)
    sv = slope[nz]
    change = np.flatnonzero(sv[1:] != sv[:-1]) + 1
    ext = nz[change]
    if sv[0] > 0:  # rising from the start: the start of the rise is a minimum
        ext = np.concatenate([nz[:1], ext])
    # ext alternates min, max, min, ... (a maximum needs a rise before it).
    if ext.size % 2 == 0:
        ext = np.concatenate([ext, [n - 1]])
    peaks, left, right = ext[1::2], ext[0:-1:2], ext[2::2]
    if peaks.size == 0:
        return peaks
    csum = np.concatenate([[0.0], np.cumsum(k)])
    mean = (csum[right + 1] - csum[left]) / (right - left + 1)
    return peaks[k[peaks] >= c * mean]


def _round_corner_filter_closed(k: np.ndarray, c: float) -> np.ndarray:
    """As :func:`_round_corner_filter_open`, on a circular sequence."""
    n = k.size
    slope = np.empty_like(k)  # slope[i]: the sign of k[i+1 mod n] - k[i]
    np.subtract(k[1:], k[:-1], out=slope[:-1])
    slope[-1] = k[0] - k[-1]
    np.sign(slope, out=slope)
    nz = np.flatnonzero(slope)
    if nz.size == 0:
        return np.zeros(0, dtype=np.intp)
    sv = slope[nz]
    change = np.flatnonzero(sv != np.concatenate((sv[-1:], sv[:-1])))
    if change.size == 0:
        return np.zeros(0, dtype=np.intp)
    ext, kind = nz[change], sv[change]
    at = np.flatnonzero(kind < 0)  # positions of the maxima in the alternating list
    peaks = ext[at]
    left = ext[(at - 1) % ext.size]
    right = ext[(at + 1) % ext.size]
    # Inclusive run from left to right going forward; the whole loop (plus one) when a
    # single minimum bounds the maximum on both sides.
    length = (right - left - 1) % n + 2
    csum = np.concatenate([[0.0], np.cumsum(np.concatenate([k, k]))])
    mean = (csum[left + length] - csum[left]) / length
    return np.sort(peaks[k[peaks] >= c * mean])


def _false_corner_filter(
    smooth: np.ndarray, cand: np.ndarray, closed: bool, t_angle: float, reach: int
) -> np.ndarray:
    """Drop candidates whose corner angle is nearly straight, pass after pass.

    Each arm runs from the candidate to its neighbour candidate (the curve's end for
    the first and last of an open curve) but is looked at over ``reach`` samples at
    most. Two estimates of the angle, each rejecting what it finds nearly straight:

    - mean offset (the seed's eq. 4.7a/b): the direction from the candidate to the
      mean of its arm's points. Robust where an arm is short and ends in the
      neighbour's rounded-off zone, where the reference's circle fit, decided by the
      arm's far end alone, let staircase ripples between two close corners pass;
    - circle fit (the reference's): the tangent at the candidate of the circle through
      the candidate and the points ``reach / 2`` and ``reach`` along the arm, used only
      when both arms are at least ``reach`` long. Exact on round arcs, where the mean
      offset is biased (it made corners on digitised circles).
    """
    n = smooth.size
    if closed:
        # Three laps, so that arms may wrap either way with plain cumulative sums.
        csum = np.concatenate([[0], np.cumsum(np.concatenate([smooth, smooth, smooth]))])
    else:
        csum = np.concatenate([[0], np.cumsum(smooth)])
    while cand.size:
        if closed:
            if cand.size == 1:
                back = fwd = np.array([max(n // 2, 1)])
            else:
                gaps = (np.diff(cand, append=cand[0]) % n).astype(np.intp)  # to the next
                back = np.concatenate((gaps[-1:], gaps[:-1]))
                fwd = gaps
            at = cand + n
        else:
            back = cand - np.concatenate([[0], cand[:-1]])
            fwd = np.concatenate([cand[1:], [n - 1]]) - cand
            at = cand
        b = np.maximum(np.minimum(back, reach), 1)
        f = np.maximum(np.minimum(fwd, reach), 1)
        here = smooth[cand]
        behind = (csum[at] - csum[at - b]) / b - here
        ahead = (csum[at + f + 1] - csum[at + 1]) / f - here
        straight = _nearly_straight(np.angle(behind) - np.angle(ahead), t_angle)
        long = np.flatnonzero((back >= reach) & (fwd >= reach))
        if long.size:
            c = cand[long]
            d_back = _circle_tangent(smooth, c, reach, -1)
            d_fwd = _circle_tangent(smooth, c, reach, 1)
            straight[long] |= _nearly_straight(d_back - d_fwd, t_angle)
        if not straight.any():
            break
        cand = cand[~straight]
    return cand


def _nearly_straight(turn: np.ndarray, t_angle: float) -> np.ndarray:
    """Angles (radians, any range) that fall in [t_angle, 360 - t_angle] once wrapped."""
    angle = np.degrees(turn) % 360.0
    return (angle >= t_angle) & (angle <= 360.0 - t_angle)


def _circle_tangent(smooth: np.ndarray, at: np.ndarray, reach: int, way: int) -> np.ndarray:
    """Direction (radians) at ``at`` of the circle through the points 0, ``reach // 2``
    and ``reach`` samples along the curve (``way`` -1 walks backward; indices wrap);
    the chord's when the three points are collinear."""
    n = smooth.size
    p1 = smooth[at]
    a = smooth[(at + way * (reach // 2)) % n] - p1
    b = smooth[(at + way * reach) % n] - p1
    cross = a.real * b.imag - a.imag * b.real
    chord = np.abs(cross) < _COLLINEAR
    safe = np.where(chord, 1.0, cross)
    # Circumcentre relative to p1; the tangent is perpendicular to it, turned towards a.
    centre = 1j * (np.abs(b) ** 2 * a - np.abs(a) ** 2 * b) / (2 * safe)
    side = np.sign(centre.real * a.imag - centre.imag * a.real)
    return np.angle(np.where(chord, b, 1j * centre * side))


def _with_endpoints(z: np.ndarray, found: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Add an open curve's end points that are more than 5 px from every corner."""
    listed = list(corners)
    out = list(found)
    for idx in (0, z.size - 1):
        if idx in out:
            continue
        if all(abs(z[idx] - q) ** 2 > _ENDPOINT_GAP2 for q in listed):
            out.append(idx)
            listed.append(z[idx])
    return np.array(sorted(set(out)), dtype=np.intp)


def _canny(gray: np.ndarray, canny: tuple[float, float]) -> np.ndarray:
    try:
        high, low = (float(v) for v in canny)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"canny must be a (high, low) pair of fractions, got {canny!r}") from exc
    if not (0.0 <= low <= high <= 1.0):
        raise ValueError(f"canny must satisfy 0 <= low <= high <= 1, got {canny!r}")
    if gray.size == 0:
        return np.zeros(gray.shape, bool)
    # Canny's own gradient: 3x3 Sobel, replicated border, L2 magnitude.
    gx = cv2.Sobel(gray, cv2.CV_32F, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
    gy = cv2.Sobel(gray, cv2.CV_32F, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
    top = float(np.sqrt(np.max(gx * gx + gy * gy)))
    if top <= 0.0:
        return np.zeros(gray.shape, bool)
    edges = cv2.Canny(gray, low * top, high * top, apertureSize=3, L2gradient=True)
    return edges > 0


# --- input checks -----------------------------------------------------------------------


def _curve_as_complex(curve: np.ndarray) -> np.ndarray:
    if curve is None:
        raise ValueError("curve must be an (N, 2) array of points, got None")
    arr = np.asarray(curve)
    if arr.ndim == 3 and arr.shape[1:] == (1, 2):
        arr = arr[:, 0, :]
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"curve must have shape (N, 2) or (N, 1, 2), got {arr.shape}")
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.number):
        raise ValueError(f"curve must hold numbers, got dtype {arr.dtype}")
    if np.issubdtype(arr.dtype, np.complexfloating):
        raise ValueError("curve must hold real (x, y) coordinates, got complex numbers")
    arr = arr.astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        raise ValueError("curve must hold finite coordinates (found NaN or inf)")
    return arr[:, 0] + 1j * arr[:, 1]


def _edge_map(edge_map: np.ndarray) -> np.ndarray:
    if edge_map is None:
        raise ValueError("edge_map must be a 2-D bool or integer array, got None")
    arr = np.asarray(edge_map)
    if arr.ndim != 2:
        raise ValueError(f"edge_map must be 2-D, got shape {arr.shape}")
    if not (arr.dtype == np.bool_ or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"edge_map must be bool or integer, got dtype {arr.dtype}")
    return arr != 0


def _flag(value: object, name: str) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _number(value: object, name: str) -> float:
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def _positive(value: object, name: str) -> float:
    out = _number(value, name)
    if out <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return out


def _non_negative(value: object, name: str) -> float:
    out = _number(value, name)
    if out < 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return out


def _angle_threshold(value: object) -> float:
    out = _number(value, "t_angle_deg")
    if not 0 < out <= 180:
        raise ValueError(f"t_angle_deg must be in (0, 180], got {value!r}")
    return out
