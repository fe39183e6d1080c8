"""Shapes in a binary mask: candidate regions and their polygon corners."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from pipeline.css import css_corners
from pipeline.edges import signed_area


@dataclass(frozen=True, eq=False)
class Region:
    """One white region's boundary, oriented with positive signed area."""

    contour: np.ndarray  # (N, 2) int32, x y
    area: float

    @cached_property
    def solidity(self) -> float:
        """Its area over its convex hull's (asked for of the regions wide enough to be
        an H: a textured floor's many small ones are turned down by their span first)."""
        hull_area = cv2.contourArea(cv2.convexHull(self.contour))
        return self.area / hull_area if hull_area > 0 else 0.0

    @cached_property
    def box(self) -> tuple[int, int, int, int]:
        """x, y, width, height of the pixels it covers (its extreme points included)."""
        x, y, w, h = cv2.boundingRect(self.contour)  # (cheaper than numpy on a contour)
        return x, y, w, h

    @property
    def span(self) -> float:
        """The larger side across (pixels between its extreme points)."""
        return float(max(self.box[2], self.box[3]) - 1)


def regions(
    mask: np.ndarray, *, min_area: float, max_area: float, holes: list[Region] | None = None
) -> list[Region]:
    """Boundaries of white regions with area in [min_area, max_area].

    Every boundary is listed (RETR_LIST): the H sits inside the dark board,
    which may itself sit inside a bright floor region. Hole boundaries are
    told by their orientation and appended to ``holes`` when it is given
    (positively oriented too), else dropped.
    """
    contours, _ = cv2.findContours(mask, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    min_len = max(8, int(2 * np.sqrt(min_area)))
    out = []
    for c in contours:
        if len(c) < min_len:
            continue
        signed = cv2.contourArea(c, oriented=True)
        area = abs(signed)
        if not min_area <= area <= max_area:
            continue
        # findContours traces outer boundaries one way and holes the other;
        # an outer boundary of a white region has negative oriented area here.
        if signed > 0:
            if holes is not None:
                holes.append(Region(c.reshape(-1, 2).copy(), area))
            continue
        pts = c.reshape(-1, 2)[::-1].copy()  # flip to positive orientation
        out.append(Region(pts, area))
    return out


def ellipse_misfit(points: np.ndarray, ellipse: tuple) -> float:
    """How far 90 % of ``points`` (N x 2) lie from ``ellipse`` (`cv2.fitEllipse`'s: centre,
    full axes, degrees), as a share of its radius: each point read on the unit circle
    the ellipse maps to."""
    (cx, cy), (a, b), angle = ellipse
    t = np.deg2rad(angle)
    u, v = np.array([np.cos(t), np.sin(t)]), np.array([-np.sin(t), np.cos(t)])
    off = np.asarray(points, np.float64).reshape(-1, 2) - [cx, cy]
    radii = np.hypot(off @ u / (a / 2.0), off @ v / (b / 2.0))
    return float(np.percentile(np.abs(radii - 1.0), 90))


def css_polygon(contour: np.ndarray, count: int) -> np.ndarray | None:
    """The ``count`` curvature-scale-space corners of a closed contour, in contour
    order, when it finds that many and their polygon is positively oriented; else None."""
    pts = np.asarray(contour).reshape(-1, 2)
    sigma = min(max(len(pts) / 120.0, 1.0), 3.0)
    idx = css_corners(pts, True, sigma=sigma, fewest=count)
    if len(idx) != count:
        return None
    out = pts[np.sort(idx)].astype(np.float64)
    return out if signed_area(out) > 0 else None


def douglas_peucker(pts: np.ndarray, count: int) -> np.ndarray | None:
    """A positively oriented polygon of exactly ``count`` vertices, by bisection on
    the tolerance, or None."""
    curve = np.asarray(pts).reshape(-1, 1, 2).astype(np.int32)
    length = cv2.arcLength(curve, True)
    lo, hi = 0.002 * length, 0.08 * length
    for _ in range(12):
        eps = 0.5 * (lo + hi)
        approx = cv2.approxPolyDP(curve, eps, True).reshape(-1, 2)
        if len(approx) == count:
            out = approx.astype(np.float64)
            return out if signed_area(out) > 0 else None
        if len(approx) > count:
            lo = eps
        else:
            hi = eps
    return None


def upsampled_contour(
    smooth: np.ndarray, mask: np.ndarray, region: Region, factor: int = 4
) -> tuple[np.ndarray, np.ndarray] | None:
    """The region's boundary traced again on a ``factor`` times finer grid.

    A small H (strokes of 4-6 px) has too few boundary pixels for its corners;
    interpolating the gray image and thresholding it again, half-way between
    the region's own gray level and its surroundings', gives a boundary that
    follows the true edge between pixels. Returns the fine-grid integer points
    (positively oriented) and the offset such that a fine point p lies at
    ``(p + 0.5) / factor - 0.5 + offset`` in the frame.
    """
    x, y, w, h = cv2.boundingRect(region.contour.reshape(-1, 1, 2).astype(np.int32))
    pad = 3
    x0, y0 = max(x - pad, 0), max(y - pad, 0)
    x1, y1 = min(x + w + pad, smooth.shape[1]), min(y + h + pad, smooth.shape[0])
    crop = smooth[y0:y1, x0:x1]
    inside = mask[y0:y1, x0:x1] > 0
    if inside.all() or not inside.any():
        return None
    threshold = 0.5 * (float(crop[inside].mean()) + float(crop[~inside].mean()))
    big = cv2.resize(crop, None, fx=factor, fy=factor, interpolation=cv2.INTER_LINEAR)
    fine = np.where(big > threshold, 255, 0).astype(np.uint8)
    contours, _ = cv2.findContours(fine, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    # The region under a global threshold may be eroded or swollen by uneven
    # light; the local threshold redraws it, so take the fine contour that
    # holds the region's centre and is of a comparable size.
    want = region.area * factor * factor
    cx, cy = (region.contour.mean(axis=0) - np.array([x0, y0]) + 0.5) * factor - 0.5
    inside_centre = [
        c for c in contours if cv2.pointPolygonTest(c, (float(cx), float(cy)), False) >= 0
    ]
    pool = inside_centre or contours
    best = max(pool, key=cv2.contourArea)
    if not 0.5 * want <= cv2.contourArea(best) <= 2.0 * want:
        return None
    return best.reshape(-1, 2)[::-1].copy(), np.array([x0, y0], np.float64)


def corner_angles(poly: np.ndarray) -> np.ndarray:
    """Interior angles of a positively oriented polygon, degrees (concave > 180)."""
    prev = np.roll(poly, 1, axis=0) - poly
    nxt = np.roll(poly, -1, axis=0) - poly
    a = np.degrees(np.arctan2(prev[:, 1], prev[:, 0]) - np.arctan2(nxt[:, 1], nxt[:, 0]))
    return np.mod(a, 360.0)
