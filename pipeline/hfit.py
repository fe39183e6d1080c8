"""The H's underlying block shape, fitted to a region of a top-down picture.

Real pads draw their H in many ways: thin or bold strokes, serifs or flared
stroke ends, legs of unequal width, a crossbar off centre, any rotation. The
pipeline needs the same 12 corners from all of them: those of the block H
underneath (two legs and a crossbar, three rectangles). The region is turned
upright along its minimum-area rectangle (both ways: legs along either side),
the legs are the columns the region fills over (nearly) its whole height,
their ends and the crossbar come from row profiles, and the block H drawn from
those numbers must cover the region (intersection over union): serifs only
widen a few rows, so they change neither the legs nor the corners.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.homography_fit import Deformation

LEG_FILL = 0.6  # a column belongs to a leg when the region fills this much of its height
MIN_IOU = 0.7  # block H against the region: serif H's ~0.85, block H's > 0.95
# An italic H's fit, leaning, must cover it this much better than upright: a lean of
# 0.1-0.3 of its height covered 0.93-0.84 of it upright, 0.99 leaning.
LEAN_GAIN = 0.01
_PAD = 2  # canvas margin, pixels


@dataclass(frozen=True, eq=False)
class HFit:
    """A block H fitted to a region.

    ``corners``: the 12 corners in image pixels, clockwise on screen from the
    top-left outer corner of the left leg (``pipeline.render.PadGeometry``'s
    order), with "up" the H's own up nearest the picture's up. ``iou``: how
    well the block H covers the region. Proportions are fractions of the H's
    width (legs, ``height``) and height (crossbar).
    """

    corners: np.ndarray
    iou: float
    width_px: float
    height_px: float
    leg_widths: tuple[float, float]
    crossbar: tuple[float, float]  # top and bottom of the crossbar, fractions of the height

    @property
    def leg_fraction(self) -> float:
        """The thinner leg's width over the H's width."""
        return min(self.leg_widths) / self.width_px


def fit_h(mask: np.ndarray) -> HFit | None:
    """Fit a block H to the white region of a binary ``mask`` (one region), or None.

    Examples
    --------
    >>> m = np.zeros((120, 140), np.uint8)
    >>> m[10:110, 20:40] = m[10:110, 100:120] = m[50:65, 40:100] = 255
    >>> fit = fit_h(m)
    >>> np.round(fit.corners[:4], 2).tolist(), round(fit.iou, 2)
    ([[19.5, 9.5], [39.5, 9.5], [39.5, 49.5], [99.5, 49.5]], 1.0)
    """
    contours, _ = cv2.findContours(
        (mask > 0).astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
    )
    if not contours:
        return None
    pts = max(contours, key=cv2.contourArea)
    if len(pts) < 12:
        return None
    box = cv2.boxPoints(cv2.minAreaRect(pts))
    e1, e2 = box[1] - box[0], box[2] - box[1]
    best = None
    for lean in (None, "rows", "legs"):
        for along in (e1, e2):  # the legs run along this side of the rectangle
            fit = _fit_upright(mask, pts.reshape(-1, 2).astype(np.float64), along, lean)
            # (an upright H's outline, a little uneven, leans a little: no better)
            margin = 0.0 if lean is None or best is None else LEAN_GAIN
            if fit is not None and (best is None or fit.iou > best.iou + margin):
                best = fit
    return best if best is not None and best.iou >= MIN_IOU else None


def _fit_upright(
    mask: np.ndarray, pts: np.ndarray, along: np.ndarray, lean: str | None
) -> HFit | None:
    """The block H with its legs along ``along``; an italic H's (its legs lean, its
    crossbar and ends stay level) with ``lean``: its "rows" sheared level first (its
    legs' minimum-area rectangle stands along the leaning legs), or its "legs" upright
    (a wide H's stands along its ends)."""
    v = np.asarray(along, np.float64)
    if np.hypot(*v) < 1e-9:
        return None
    v = v / np.hypot(*v)
    if v[1] < 0 or (v[1] == 0 and v[0] < 0):
        v = -v  # the H's down points down the picture
    u = np.array([v[1], -v[0]])  # x right of y down, as on screen
    R = np.stack([u, v])  # image offsets -> upright offsets
    centre = np.round(pts.mean(axis=0))  # integer: an upright H is not resampled
    if lean is not None:
        # An H mirrors itself across its legs' or its crossbar's middle, so its
        # outline's second moment across the two is nil upright; sheared, it is the
        # shear times the spread across the sheared lines.
        m = cv2.moments(((pts - centre) @ R.T).astype(np.float32))
        spread = m["mu20"] if lean == "rows" else m["mu02"]
        if spread < 1e-9 or abs(m["mu11"]) < 1e-3 * spread:
            return None  # (no lean: the upright fit is the one)
        shear = np.eye(2)
        shear[(1, 0) if lean == "rows" else (0, 1)] = -m["mu11"] / spread
        R = shear @ R
    q = (pts - centre) @ R.T
    lo = np.floor(q.min(axis=0)) - _PAD
    hi = np.ceil(q.max(axis=0)) + _PAD + 1
    size = (int(hi[0] - lo[0]), int(hi[1] - lo[1]))
    A = np.hstack([R, (-R @ centre - lo)[:, None]])  # image -> canvas
    canvas = cv2.warpAffine(
        (mask > 0).astype(np.float32), A, size, flags=cv2.INTER_LINEAR, borderValue=0.0
    )
    shape = _h_in_canvas(canvas)
    if shape is None:
        return None
    xl0, xl1, xr0, xr1, y0, y1, b0, b1 = shape
    cover = _h_cover(canvas.shape, shape)
    iou = float(np.minimum(cover, canvas).sum() / max(np.maximum(cover, canvas).sum(), 1e-9))
    corners_c = np.array(
        [
            (xl0, y0),
            (xl1, y0),
            (xl1, b0),
            (xr0, b0),
            (xr0, y0),
            (xr1, y0),
            (xr1, y1),
            (xr0, y1),
            (xr0, b1),
            (xl1, b1),
            (xl1, y1),
            (xl0, y1),
        ]
    )
    # Profiles put edges between cells (cell k spans [k, k + 1)); pixel centres
    # are integers in both the canvas and the picture.
    back = R if lean is None else np.linalg.inv(R).T  # (upright, R is a rotation)
    corners = (corners_c - 0.5 + lo) @ back + centre
    width, height = xr1 - xl0, y1 - y0
    return HFit(
        corners=corners,
        iou=iou,
        width_px=float(width),
        height_px=float(height),
        leg_widths=(float(xl1 - xl0), float(xr1 - xr0)),
        crossbar=(float((b0 - y0) / height), float((b1 - y0) / height)),
    )


def _h_in_canvas(c: np.ndarray):
    """(xl0, xl1, xr0, xr1, y0, y1, b0, b1) of a block H in an upright canvas, or None."""
    rows = np.flatnonzero(c.max(axis=1) > 0.5)
    if len(rows) < 5:
        return None
    height = float(c.sum(axis=0).max())
    if height < 5:
        return None
    col = c.sum(axis=0) / height
    legs = _runs(col >= LEG_FILL)
    if len(legs) < 2:
        return None
    (a0, a1), (c0, c1) = legs[0], legs[-1]
    if any(col[a1:c0] >= LEG_FILL):  # a third tall stroke between the legs: not an H
        return None
    xl0, xl1 = _edge(col, a0, -1), _edge(col, a1 - 1, +1)
    xr0, xr1 = _edge(col, c0, -1), _edge(col, c1 - 1, +1)
    gap = xr0 - xl1
    width = xr1 - xl0
    if gap < 0.15 * width or xl1 - xl0 < 1.0 or xr1 - xr0 < 1.0:
        return None
    # The legs' ends, from the rows of their inner columns.
    leg_rows = np.concatenate(
        [
            c[:, a0 + (a1 - a0) // 4 : a1 - (a1 - a0) // 4 or None].T,
            c[:, c0 + (c1 - c0) // 4 : c1 - (c1 - c0) // 4 or None].T,
        ]
    )
    prof = leg_rows.mean(axis=0) if len(leg_rows) else c[:, a0:a1].mean(axis=1)
    tall = _runs(prof >= 0.5)
    if not tall:
        return None
    t0, t1 = max(tall, key=lambda r: r[1] - r[0])
    y0, y1 = _edge(prof, t0, -1), _edge(prof, t1 - 1, +1)
    # The crossbar, from the middle of the gap between the legs.
    m0 = int(np.ceil(xl1 + 0.2 * gap))
    m1 = int(np.floor(xr0 - 0.2 * gap))
    if m1 <= m0:
        m0, m1 = round(xl1), round(xr0)
    if m1 <= m0:
        return None
    mid = c[:, m0:m1].mean(axis=1)
    bars = [r for r in _runs(mid >= 0.5) if r[1] > t0 and r[0] < t1]
    if not bars:
        return None
    r0, r1 = max(bars, key=lambda r: r[1] - r[0])
    b0, b1 = _edge(mid, r0, -1), _edge(mid, r1 - 1, +1)
    h = y1 - y0
    if h < 3 or b0 - y0 < 0.05 * h or y1 - b1 < 0.05 * h or b1 - b0 > 0.7 * h:
        return None  # the bar must leave the legs' ends free: else a 'U', a block or a slab
    return xl0, xl1, xr0, xr1, y0, y1, b0, b1


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of True."""
    f = np.concatenate([[False], flags, [False]]).astype(np.int8)
    d = np.diff(f)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def _edge(profile: np.ndarray, i: int, direction: int) -> float:
    """Sub-pixel edge of a run whose last cell (stepping by ``direction``) is ``i``.

    Cell k spans [k, k + 1). The next cell is taken as partly covered, in
    proportion to where its value lies between the run's and the one after it
    (a leg's column next to the crossbar's is not a partial leg).
    """
    n = len(profile)
    j, k = i + direction, i + 2 * direction
    full = float(profile[i])
    partial = float(profile[j]) if 0 <= j < n else 0.0
    outside = float(profile[k]) if 0 <= k < n else 0.0
    outside = min(outside, partial)
    if full - outside <= 1e-9:
        return float(i if direction < 0 else i + 1)
    frac = float(np.clip((partial - outside) / (full - outside), 0.0, 1.0))
    return float(i - frac) if direction < 0 else float(i + 1 + frac)


def _h_cover(shape: tuple[int, ...], h) -> np.ndarray:
    """Fractional coverage of the canvas by the block H's three rectangles."""
    xl0, xl1, xr0, xr1, y0, y1, b0, b1 = h
    rects = [(xl0, y0, xl1, y1), (xr0, y0, xr1, y1), (xl1, b0, xr0, b1)]
    ys = np.arange(shape[0], dtype=np.float64)
    xs = np.arange(shape[1], dtype=np.float64)
    out = np.zeros(shape, np.float64)
    for x0, ry0, x1, ry1 in rects:
        cx = np.clip(np.minimum(xs + 1, x1) - np.maximum(xs, x0), 0, 1)
        cy = np.clip(np.minimum(ys + 1, ry1) - np.maximum(ys, ry0), 0, 1)
        out += np.outer(cy, cx)
    return np.minimum(out, 1.0)


H_STROKE_SPREAD = 0.3  # how much the H in view may differ, of each stroke's width


def h_deformation(corners_m: np.ndarray) -> Deformation | None:
    """How the H in view may differ from the reference's, for `fit_homography`: its
    strokes bolder or lighter (one parameter, metres: each stroke's width grows by
    it, the legs inward from their outer edges, the crossbar on both of its edges,
    held within about ``H_STROKE_SPREAD`` of the strokes' mean width). A picture of
    a pad is rarely exact: printing, fabric, a synthetic drawing or a rectified
    photo change the strokes' weight by a few percent of the H, its outer box much
    less. All strokes alike, as a bolder lettering draws them: legs narrowing while
    the crossbar thickens would turn an H into a letter I on its side, and one leg
    narrowing against the other is the view's perspective, the homography's. None
    when the 12 corners are not an H's (its four concave corners are the
    crossbar's, in two adjacent pairs six apart).

    >>> from pipeline.render import PadGeometry
    >>> d = h_deformation(PadGeometry().h_corners_m)
    >>> d.a.shape, round(float(d.sigma[0]), 4)
    ((12, 2, 1), 0.0187)
    """
    c = np.asarray(corners_m, np.float64).reshape(-1, 2)
    if len(c) != 12:
        return None
    prev, nxt = np.roll(c, 1, axis=0), np.roll(c, -1, axis=0)
    u, v = c - prev, nxt - c
    turn = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    area = float(np.sum(c[:, 0] * nxt[:, 1] - c[:, 1] * nxt[:, 0]))
    concave = set(np.nonzero(turn * area < 0)[0].tolist())
    for r in range(12):
        if concave == {(r + k) % 12 for k in (2, 3, 8, 9)}:
            break
    else:
        return None
    i = [(r + k) % 12 for k in range(12)]  # i[k]: the corner in position k of the H

    def unit(v: np.ndarray) -> np.ndarray:
        return v / max(float(np.hypot(*v)), 1e-12)

    def length(a: int, b: int) -> float:
        return float(np.hypot(*(c[i[a]] - c[i[b]])))

    up = unit(c[i[0]] - c[i[11]])  # along the legs
    basis = np.zeros((12, 2, 1))
    left, right = unit(c[i[1]] - c[i[0]]), unit(c[i[4]] - c[i[5]])  # across the legs, inward
    for k, move in (
        (1, left), (10, left), (4, right), (7, right),  # the legs' ends' inner corners
        (2, left + 0.5 * up), (9, left - 0.5 * up),  # the crossbar's corners on the left
        (3, right + 0.5 * up), (8, right - 0.5 * up),  # and on the right
    ):  # fmt: skip
        basis[i[k], :, 0] = move
    strokes = (length(1, 0), length(5, 4), 0.5 * (length(2, 9) + length(3, 8)))
    sigma = H_STROKE_SPREAD * np.array([float(np.mean(strokes))])
    return Deformation(basis, np.roll(basis, -1, axis=0), sigma)
