"""Affine-invariant comparison of a frame's region with the reference's H.

A region's centroid and second moments fix an affine map up to a rotation:
whitened (centred and scaled so that its covariance is the identity), any
affine view of the H becomes the reference's whitened H turned by some angle.
Rasterised on a small grid, the region is compared with the reference turned
by every angle at once (one matrix product); the best angle's overlap (IoU)
says how much the region looks like the H whatever the view's tilt, scale and
rotation, and together with the moments it gives the affine map from the pad
plane to the frame that starts the edge fit. Unlike Hu's invariants it does
not collapse for thin strokes or H's of unusual proportions, and unlike
corners it does not need the stroke ends to survive blur.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.jit import compiled, compiled_ieee, popcount

GRID = 40  # raster cells a side
EXTENT = 2.6  # whitened units from the centre to the grid's edge
STEPS = 120  # rotations tried over a full turn (3 degrees)
_SHIFT = 4  # fillPoly's sub-pixel bits
_FLIP = np.diag([1.0, -1.0])  # pad metres (y up) -> picture-like (y down)


@dataclass(frozen=True, eq=False)
class ShapeMatch:
    """``iou``: best overlap of the whitened shapes; ``affine``: 2 x 3 map from pad
    metres to frame pixels under the best rotation."""

    iou: float
    affine: np.ndarray


@dataclass(frozen=True, eq=False)
class ShapeMatcher:
    mean_m: np.ndarray
    whiten: np.ndarray  # picture-like metres -> whitened units
    angles: np.ndarray  # (STEPS,) radians
    bits: np.ndarray  # (STEPS, words) uint64: the H turned by each angle, a bit a cell
    areas: np.ndarray  # (STEPS,) cells

    @classmethod
    def from_polygon(cls, poly_m: np.ndarray, *, symmetric: bool = False) -> ShapeMatcher:
        """The matcher for a polygon given in pad metres (y up).

        Examples
        --------
        >>> from pipeline.render import PadGeometry
        >>> poly = PadGeometry().h_corners_m
        >>> m = ShapeMatcher.from_polygon(poly)
        >>> A = np.array([[900.0, 150.0, 320.0], [-100.0, -700.0, 240.0]])  # any affine view
        >>> px = poly @ A[:, :2].T + A[:, 2]
        >>> hit = m.match(px)
        >>> back = poly @ hit.affine[:, :2].T + hit.affine[:, 2]
        >>> hit.iou > 0.9, bool(np.abs(back - px).max() < 3)
        (True, True)
        """
        poly = np.asarray(poly_m, np.float64).reshape(-1, 2) @ _FLIP
        mean, cov = _polygon_moments(poly)
        whiten = _inv_sqrt(cov)
        base = (poly - mean) @ whiten.T
        # A half-turn symmetric H only needs half a turn of angles, but the
        # other half costs one matrix row each and keeps one code path.
        angles = np.linspace(0.0, 2 * np.pi, STEPS, endpoint=False)
        rasters = np.stack([_raster(base @ _rot(a).T) for a in angles]).reshape(STEPS, -1)
        return cls(mean, whiten, angles, _bits(rasters), rasters.sum(axis=1, dtype=np.int64))

    def match(self, contour_px: np.ndarray, min_iou: float = 0.0) -> ShapeMatch | None:
        """Compare a region's boundary (N x 2 frame pixels) with the H; None when
        the best overlap is under ``min_iou``."""
        return self.match_many([contour_px], min_iou)[0]

    def match_many(
        self, contours_px: list[np.ndarray], min_iou: float = 0.0, *, top: int | None = None
    ) -> list[ShapeMatch | None]:
        """`match` for many regions at once: every region's cells against every turn's
        in one compiled pass over their bits (a cluttered frame has a thousand
        regions). ``top``: only the best this many overlaps get their match, the rest
        None."""
        out: list[ShapeMatch | None] = [None] * len(contours_px)
        listed = [np.asarray(c, np.float64).reshape(-1, 2) for c in contours_px]
        index = np.array([i for i, p in enumerate(listed) if len(p) >= 6], int)
        if not len(index):
            return out
        centres, whiten, cells = _whitened_rasters([listed[i] for i in index])
        if not len(cells):
            return out
        rastered = np.nonzero(np.isfinite(whiten).all(axis=(1, 2)))[0]
        iou = _overlaps(self.bits, self.areas, _bits(cells.reshape(len(cells), -1)))
        order, ious, affine = _best_maps(
            iou,
            self.angles,
            whiten[rastered],
            centres[rastered],
            len(rastered) if top is None else top,
            min_iou,
            self.whiten @ _FLIP,
            self.mean_m @ _FLIP,
        )
        for q, j in enumerate(order):
            out[int(index[rastered[j]])] = ShapeMatch(float(ious[q]), affine[q])
        return out


@compiled
def _best_maps(iou, angles, whiten, centres, top, min_iou, ref_map, ref_mean):
    """Of the regions (``iou``'s columns, S turns x K), the ``top`` best overlaps
    (stably, best first) of at least ``min_iou``: their columns, overlaps and affine
    maps from pad metres to frame pixels (m x 2 x 3), the turn refined between its
    neighbours: frame = mean + W_c^-1 R(angle) ``ref_map`` (m - mean_r), ``ref_map``
    the reference's whitening of pad metres, ``ref_mean`` its mean there. The float32
    steps are rounded as numpy's float32 operations round them."""
    n, k = iou.shape
    best = np.empty(k, np.int64)
    best_iou = np.empty(k, np.float32)
    for j in range(k):
        b = 0
        for i in range(1, n):
            if iou[i, j] > iou[b, j]:
                b = i
        best[j], best_iou[j] = b, iou[b, j]
    order = np.argsort(-best_iou, kind="mergesort")[:top]
    order = order[best_iou[order] >= min_iou]
    step = angles[1] - angles[0]
    affine = np.empty((len(order), 2, 3))
    for q in range(len(order)):
        j = order[q]
        b = best[j]
        lo, mid, hi = iou[(b - 1) % n, j], iou[b, j], iou[(b + 1) % n, j]
        angle = angles[b] + float(_peak_offset(lo, mid, hi)) * step
        cos, sin = np.cos(angle), np.sin(angle)
        w = whiten[j]
        det = w[0, 0] * w[1, 1] - w[0, 1] * w[1, 0]
        inv = np.array([[w[1, 1] / det, -w[0, 1] / det], [-w[1, 0] / det, w[0, 0] / det]])
        turned = np.empty((2, 2))
        for r in range(2):
            turned[r, 0] = inv[r, 0] * cos + inv[r, 1] * sin
            turned[r, 1] = inv[r, 0] * -sin + inv[r, 1] * cos
        for r in range(2):
            for c in range(2):
                affine[q, r, c] = turned[r, 0] * ref_map[0, c] + turned[r, 1] * ref_map[1, c]
            affine[q, r, 2] = centres[j, r] - (
                affine[q, r, 0] * ref_mean[0] + affine[q, r, 1] * ref_mean[1]
            )
    return order, best_iou[order], affine


@compiled
def _peak_offset(a, b, c):
    """The sub-step offset of a maximum ``b`` between its neighbours ``a`` and ``c``
    (float32: a parabola through the three)."""
    den = np.float32(np.float32(a - np.float32(2.0 * b)) + c)
    if not abs(den) > 1e-12:
        return np.float32(0.0)
    off = np.float32(np.float32(0.5 * np.float32(a - c)) / den)
    return min(max(off, np.float32(-0.5)), np.float32(0.5))


def _bits(cells: np.ndarray) -> np.ndarray:
    """Rows of 0/1 cells (K x N uint8) as bits (K x ceil(N / 64) uint64)."""
    packed = np.packbits(cells, axis=1)
    if packed.shape[1] % 8:  # (np.pad costs even when it pads nothing)
        packed = np.pad(packed, ((0, 0), (0, -packed.shape[1] % 8)))
    return np.ascontiguousarray(packed).view(np.uint64)


@compiled
def _overlaps(turns, areas, regions):
    """The overlap (IoU) of each turn's cells (bits, S x W) with each region's (K x W),
    S x K float32: intersections and unions counted exactly, their quotient rounded to
    float32 (what the float32 product of the cells gave: the same numbers). The turns'
    bits are 24 KB against the float32 cells' 768 KB, which a frame read from memory."""
    s, words = turns.shape
    iou = np.empty((s, regions.shape[0]), np.float32)
    for j in range(regions.shape[0]):
        area = 0
        for q in range(words):
            area += popcount(regions[j, q])
        for i in range(s):
            inter = 0
            for q in range(words):
                inter += popcount(turns[i, q] & regions[j, q])
            iou[i, j] = np.float32(inter / max(areas[i] + area - inter, 1e-9))
    return iou


def _whitened_rasters(polygons: list[np.ndarray]):
    """Every closed polygon (N_k x 2) whitened and filled on the GRID x GRID cells
    (as `_raster` fills one), in one pass over all their points: their centroids
    (K x 2), whitening maps (K x 2 x 2, nan for a degenerate polygon) and the
    rasters of those that are not degenerate (in order)."""
    counts = np.array([len(p) for p in polygons], np.int64)
    start = np.concatenate([[0], counts.cumsum()[:-1]]).astype(np.int64)
    mean, whiten, ok, grid = _whiten(np.concatenate(polygons), start, counts)
    cells = np.zeros((int(ok.sum()), GRID, GRID), np.uint8)
    for k, i in enumerate(np.flatnonzero(ok)):
        poly = grid[start[i] : start[i] + counts[i]].reshape(-1, 1, 2)
        cv2.fillPoly(cells[k], [poly], 1, lineType=cv2.LINE_8, shift=_SHIFT)
    return mean, whiten, cells


@compiled_ieee  # (a degenerate polygon's divisions give nan, then it is not rastered)
def _whiten(pts, start, counts):
    """`_whitened_rasters`' arithmetic: per polygon its centroid, whitening map (the
    inverse square root of its covariance in closed form, see `_inv_sqrt`; nan when
    degenerate) and whether it is not degenerate; per point, its fillPoly coordinates
    on the grid (whitened, ``_SHIFT`` sub-pixel bits)."""
    k = len(counts)
    mean = np.full((k, 2), np.nan)
    whiten = np.full((k, 2, 2), np.nan)
    ok = np.zeros(k, np.bool_)
    grid = np.empty((len(pts), 2), np.int32)
    to_grid = GRID / (2.0 * EXTENT)
    unit = float(1 << _SHIFT)
    for j in range(k):
        s, n = start[j], counts[j]
        # Green's theorem: the moments of the area inside the polygon.
        m00 = m10 = m01 = m20 = m02 = m11 = 0.0
        for q in range(n):
            x, y = pts[s + q, 0], pts[s + q, 1]
            nq = s + q + 1 if q + 1 < n else s  # (each polygon closes on its first point)
            x1, y1 = pts[nq, 0], pts[nq, 1]
            cross = x * y1 - x1 * y
            m00 += cross
            m10 += (x + x1) * cross
            m01 += (y + y1) * cross
            m20 += (x * x + x * x1 + x1 * x1) * cross
            m02 += (y * y + y * y1 + y1 * y1) * cross
            m11 += (x * y1 + 2.0 * x * y + 2.0 * x1 * y1 + x1 * y) * cross
        m00 /= 2.0
        cx, cy = 0.0, 0.0
        w00, w01, w11 = 0.0, 0.0, 0.0
        if abs(m00) >= 1e-12:
            cx, cy = m10 / 6.0 / m00, m01 / 6.0 / m00
            a = m20 / 12.0 / m00 - cx * cx
            b = m11 / 24.0 / m00 - cx * cy
            d = m02 / 12.0 / m00 - cy * cy
            mean[j, 0], mean[j, 1] = cx, cy
            if math.isfinite(a + b + d) and a * d - b * b > 1e-9:
                sq = math.sqrt(a * d - b * b)
                t = math.sqrt(a + d + 2.0 * sq)
                p, q_, r = (a + sq) / t, b / t, (d + sq) / t
                det = p * r - q_ * q_
                w00, w01, w11 = r / det, -q_ / det, p / det
                if math.isfinite(w00) and math.isfinite(w01) and math.isfinite(w11):
                    ok[j] = True
                    whiten[j, 0, 0], whiten[j, 0, 1] = w00, w01
                    whiten[j, 1, 0], whiten[j, 1, 1] = w01, w11
                else:
                    w00, w01, w11 = 0.0, 0.0, 0.0
        for q in range(n):
            x, y = pts[s + q, 0] - cx, pts[s + q, 1] - cy
            grid[s + q, 0] = _grid_coordinate(w00 * x + w01 * y, to_grid, unit)
            grid[s + q, 1] = _grid_coordinate(w01 * x + w11 * y, to_grid, unit)
    return mean, whiten, ok, grid


@compiled
def _grid_coordinate(v, to_grid, unit):
    g = np.rint(((v + EXTENT) * to_grid - 0.5) * unit)
    return np.int32(min(max(g, -float(1 << 20)), float(1 << 20)))


def _polygon_moments(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroid and covariance of the area inside a closed polygon."""
    m = cv2.moments(poly.astype(np.float32).reshape(-1, 1, 2))
    a = m["m00"]
    if abs(a) < 1e-12:
        return np.zeros(2), np.full((2, 2), np.nan)
    mean = np.array([m["m10"] / a, m["m01"] / a])
    cov = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / a
    return mean, cov


def _inv_sqrt(cov: np.ndarray) -> np.ndarray:
    """The inverse square root of a 2 x 2 covariance, in closed form:
    for s = sqrt(det) and t = sqrt(trace + 2 s), sqrt(C) = (C + s I) / t."""
    a, b, d = float(cov[0, 0]), float(cov[0, 1]), float(cov[1, 1])
    s = math.sqrt(max(a * d - b * b, 1e-24))
    t = math.sqrt(a + d + 2.0 * s)
    return _inv2(np.array([[a + s, b], [b, d + s]]) / t)


def _inv2(m: np.ndarray) -> np.ndarray:
    """The inverse of a 2 x 2 matrix (numpy's general inverse costs more per call)."""
    a, b, c, d = float(m[0, 0]), float(m[0, 1]), float(m[1, 0]), float(m[1, 1])
    det = a * d - b * c
    return np.array([[d / det, -b / det], [-c / det, a / det]])


def _rot(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def _raster(whitened: np.ndarray) -> np.ndarray:
    """The polygon filled on the GRID x GRID cells covering [-EXTENT, EXTENT]^2."""
    g = (whitened + EXTENT) * (GRID / (2 * EXTENT)) - 0.5
    pts = np.round(g * (1 << _SHIFT)).astype(np.int32).reshape(-1, 1, 2)
    img = np.zeros((GRID, GRID), np.uint8)
    cv2.fillPoly(img, [pts], 1, lineType=cv2.LINE_8, shift=_SHIFT)
    return img
