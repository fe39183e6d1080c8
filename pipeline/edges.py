"""Sub-pixel polygon refinement from gray-level edges.

Contour pixels sit on the integer grid and their position depends on the
threshold; corners found on them are off by up to a pixel, which at a 25 px
wide H is several percent of range. Here each polygon side is re-measured on
the smoothed gray image: profiles across the side locate the edge at the
centroid of the bright-to-dark drops around the steepest, a line is fitted
through those edge points, and the corners become the intersections of
neighbouring lines. The result does not depend on the threshold and is good to
a few hundredths of a pixel on clean edges.

A reference picture is drawn square to its pixels, so every side of its H lies
along a row or a column, where a parabola through the steepest drops locks to
the pixel grid (`pipeline.edge_kernels.edge_offsets`): up to 0.39 px off by the
edge's phase alone, the same all along the side.
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.edge_kernels import MAX_TAIL, MIN_DROP, STEP_PX, TAIL_SHARE, WEIGHT_FLOOR


def signed_area(poly: np.ndarray) -> float:
    """Shoelace area in image coordinates (positive = clockwise on screen)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def refine_polygon(
    image: np.ndarray,
    corners: np.ndarray,
    *,
    bright_inside: bool = True,
    search_px: float = 2.5,
    inset: float = 0.2,
) -> tuple[np.ndarray, float] | None:
    """Refine a closed polygon's corners on ``image`` (2-D, smoothed gray).

    Parameters
    ----------
    image : 2-D uint8 or float32 gray image.
    corners : (N, 2) polygon vertices in order (x, y), N >= 3.
    bright_inside : the polygon is brighter than its surroundings.
    search_px : how far across each side to look for the edge.
    inset : fraction of each side left out at both ends (the other side's
        edge disturbs profiles near a corner).

    Returns
    -------
    (refined corners, RMS distance of edge points to their lines in px), or
    None when a side has too few edge points or two neighbouring sides are
    nearly parallel.

    Examples
    --------
    >>> img = np.zeros((60, 60), np.float32); img[20:40, 15:45] = 200
    >>> sq = np.array([[15, 20], [44, 20], [44, 39], [15, 39]], float)
    >>> out, rms = refine_polygon(cv2.GaussianBlur(img, (5, 5), 1), sq)
    >>> out.round(2).tolist()
    [[14.5, 19.5], [44.5, 19.5], [44.5, 39.5], [14.5, 39.5]]
    """
    corners = np.asarray(corners, np.float64).reshape(-1, 2)
    n = len(corners)
    if n < 3:
        raise ValueError(f"corners must hold at least 3 points, got {n}")
    orient = 1.0 if signed_area(corners) > 0 else -1.0
    sign = 1.0 if bright_inside else -1.0
    # Sampled beyond the search by the drops' tails (the steepest is looked for within it).
    half = int(np.floor(search_px / STEP_PX + 1e-6))
    offsets = STEP_PX * np.arange(-half - MAX_TAIL, half + MAX_TAIL + 1, dtype=np.float64)

    a = corners
    d = np.roll(corners, -1, axis=0) - a
    length = np.hypot(d[:, 0], d[:, 1])
    if np.any(length < 2.0):
        return None
    u = d / length[:, None]
    normal = orient * np.stack([u[:, 1], -u[:, 0]], axis=1)  # outward

    # Sample positions along every side at once: one remap for the polygon.
    # Sides too short to measure keep the line through their two corners.
    margin = np.maximum(inset * length, np.minimum(2.0, 0.3 * length))
    measurable = length - 2 * margin >= 3.0
    if np.count_nonzero(measurable) < 2:
        return None  # (too few sides to place a corner by; none at all to sample)
    lo = np.where(measurable, margin, 0.0)
    hi = np.where(measurable, length - margin, 0.0)
    counts = np.where(measurable, np.clip(hi - lo, 3, 80), 0).astype(int)
    side = np.repeat(np.arange(n), counts)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    frac = (np.arange(len(side)) - first[side]) / np.maximum(counts[side] - 1, 1)
    t = lo[side] + frac * (hi - lo)[side]
    base = a[side] + t[:, None] * u[side]
    pts = base[:, None, :] + offsets[None, :, None] * normal[side][:, None, :]
    img = image if image.dtype == np.float32 else image.astype(np.float32)
    samples = cv2.remap(
        img,
        pts[..., 0].astype(np.float32),
        pts[..., 1].astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    # Derivative along the outward normal, signed so the edge is a positive peak.
    grad = -sign * np.diff(samples, axis=1)
    searched = grad[:, MAX_TAIL : grad.shape[1] - MAX_TAIL]
    k = np.argmax(searched, axis=1)
    peak = searched[np.arange(len(side)), k]
    ok = (k > 0) & (k < searched.shape[1] - 1) & (peak > MIN_DROP)
    at = _drops_centroid(grad, k + MAX_TAIL, peak)
    # The difference of samples j and j+1 sits half-way between them.
    off = offsets[0] + (at + 0.5) * STEP_PX
    edge = base + off[:, None] * normal[side]

    lines = _fit_lines(edge, side, ok, n, measurable)
    if lines is None:
        return None
    centre, direction, rms = lines
    # A measured line far from the side it started from locked onto another edge.
    mid = a + 0.5 * d
    rel = mid - centre
    off_line = np.abs(rel[:, 0] * direction[:, 1] - rel[:, 1] * direction[:, 0]) > 1.5
    coarse = ~measurable | off_line
    centre[coarse] = mid[coarse]
    direction[coarse] = u[coarse]
    out = _intersections(centre, direction)
    if out is None:
        return None
    # A refined corner far from its start means the edges were not found.
    if np.max(np.hypot(*(out - corners).T)) > search_px + 1.5:
        return None
    return out, rms


def _drops_centroid(drops: np.ndarray, best: np.ndarray, peak: np.ndarray) -> np.ndarray:
    """Per row of ``drops``, where (in its indices) the centroid of the drops around
    ``best`` (the steepest, ``peak``) lies, as `pipeline.edge_kernels` places a pose's
    edges: the drops over ``WEIGHT_FLOOR`` of the steepest weigh by their excess, out to
    where they fall to ``TAIL_SHARE`` of it, ``MAX_TAIL`` at most each side; taken
    twice, the second time around the first's centroid."""
    index = np.arange(drops.shape[1])[None, :]
    tail = drops <= TAIL_SHARE * peak[:, None]
    centre = best
    at = best.astype(np.float64)
    for _ in range(2):
        c = centre[:, None]
        first = np.where(tail & (index < c), index, -1).max(axis=1) + 1
        last = np.where(tail & (index > c), index, drops.shape[1]).min(axis=1) - 1
        first, last = np.maximum(first, centre - MAX_TAIL), np.minimum(last, centre + MAX_TAIL)
        inside = (index >= first[:, None]) & (index <= last[:, None])
        weight = np.where(inside, np.maximum(drops - WEIGHT_FLOOR * peak[:, None], 0.0), 0.0)
        mass = weight.sum(axis=1)
        at = np.where(mass > 0.0, (weight * index).sum(axis=1) / np.maximum(mass, 1e-12), at)
        centre = np.clip(np.rint(at).astype(int), 0, drops.shape[1] - 1)
    return at


def _fit_lines(edge: np.ndarray, side: np.ndarray, ok: np.ndarray, n: int, measured: np.ndarray):
    """Total-least-squares line per measured side, with one pass dropping outliers."""
    keep = ok.copy()
    if np.count_nonzero(measured) < 2:
        return None
    for _ in range(2):
        w = keep.astype(np.float64)
        cnt = np.bincount(side, w, n)
        if np.any(cnt[measured] < 3):
            return None
        cnt = np.maximum(cnt, 1.0)
        cx = np.bincount(side, w * edge[:, 0], n) / cnt
        cy = np.bincount(side, w * edge[:, 1], n) / cnt
        dx, dy = edge[:, 0] - cx[side], edge[:, 1] - cy[side]
        sxx = np.bincount(side, w * dx * dx, n)
        syy = np.bincount(side, w * dy * dy, n)
        sxy = np.bincount(side, w * dx * dy, n)
        theta = 0.5 * np.arctan2(2 * sxy, sxx - syy)
        direction = np.stack([np.cos(theta), np.sin(theta)], axis=1)
        dist = -dx * direction[side, 1] + dy * direction[side, 0]
        spread = np.sqrt(np.bincount(side, w * dist * dist, n) / cnt)
        inlier = keep & (np.abs(dist) <= np.maximum(0.75, 2.5 * spread[side]))
        if np.array_equal(inlier, keep):
            break
        keep = inlier
    rms = float(np.sqrt(np.sum(dist[keep] ** 2) / max(np.count_nonzero(keep), 1)))
    return np.stack([cx, cy], axis=1), direction, rms


def _intersections(centre: np.ndarray, direction: np.ndarray) -> np.ndarray | None:
    """Corner i where side i-1 meets side i."""
    p, r = np.roll(centre, 1, axis=0), np.roll(direction, 1, axis=0)
    q, s = centre, direction
    cross = r[:, 0] * s[:, 1] - r[:, 1] * s[:, 0]
    if np.any(np.abs(cross) < 0.2):  # sides within ~11 degrees of parallel
        return None
    w = q - p
    t = (w[:, 0] * s[:, 1] - w[:, 1] * s[:, 0]) / cross
    return p + t[:, None] * r
