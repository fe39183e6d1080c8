"""A pad photographed in perspective, made into a top-down reference picture.

Two pure functions: :func:`suggest_outline` finds where the pad probably is (its
outline as a quadrilateral, and as an ellipse for round pads: the largest convex
shape around the most H-like region), as the starting guess the operator corrects;
:func:`rectify` maps the four outer corners the operator confirmed onto a square (or
a rectangle of the pad's proportions) with a homography.

Corners are ``(x, y)`` pixels in the order top-left, top-right, bottom-right,
bottom-left of the pad as it should appear in the reference (its top edge becomes the
picture's top edge).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

#: Longest side the search works at (the photo is shrunk to it, the answer scaled back).
WORK_SIDE = 800
#: Regions smaller than this share of the working image are not looked at.
MIN_AREA_FRACTION = 2e-4


@dataclass(frozen=True)
class Outline:
    """The suggested pad outline in the photo's pixels.

    ``quad``: four corners (TL, TR, BR, BL) of the largest convex quadrilateral found
    around the H, or of the box around the H when none was. ``ellipse``: the four
    corners of the square circumscribing a round pad, seen in perspective (the corners
    of the rotated box around the fitted ellipse), or None. ``kind``: which of the two
    fits the pad better (``"quad"``, ``"ellipse"``, ``"h_box"``). ``h_box``: the H-like
    region's box (x, y, w, h), None when no H-like region was found.
    """

    quad: np.ndarray
    ellipse: np.ndarray | None
    kind: str
    h_box: tuple[int, int, int, int] | None

    def to_dict(self) -> dict[str, object]:
        return {
            "quad": np.round(self.quad, 1).tolist(),
            "ellipse": None if self.ellipse is None else np.round(self.ellipse, 1).tolist(),
            "kind": self.kind,
            "h_box": None if self.h_box is None else list(self.h_box),
        }


def order_corners(points: np.ndarray) -> np.ndarray:
    """Four points in the order TL, TR, BR, BL (by angle about their centre).

    >>> order_corners(np.array([[10, 10], [0, 0], [10, 0], [0, 10]], float)).tolist()
    [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]
    """
    pts = np.asarray(points, float).reshape(4, 2)
    centre = pts.mean(axis=0)
    angles = np.arctan2(pts[:, 1] - centre[1], pts[:, 0] - centre[0])
    ordered = pts[np.argsort(angles)]  # from the left, clockwise on screen (y down)
    # start at the one nearest the top-left: smallest x + y
    start = int(np.argmin(ordered.sum(axis=1)))
    return np.roll(ordered, -start, axis=0)


def _binaries(image_bgr: np.ndarray) -> list[np.ndarray]:
    """Foreground masks of both polarities, in gray and in the two colour axes."""
    gray = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)
    lab = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2LAB)
    hsv = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2HSV)
    masks = []
    for channel in (gray, lab[:, :, 1], lab[:, :, 2], hsv[:, :, 1]):
        blurred = cv2.GaussianBlur(channel, (5, 5), 0)
        _, m = cv2.threshold(blurred, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        masks += [m, cv2.bitwise_not(m)]
    block = max(15, (min(gray.shape) // 16) | 1)
    adaptive = cv2.adaptiveThreshold(
        cv2.GaussianBlur(gray, (5, 5), 0),
        255,
        cv2.ADAPTIVE_THRESH_MEAN_C,
        cv2.THRESH_BINARY,
        block,
        -5,
    )
    masks += [adaptive, cv2.bitwise_not(adaptive)]
    return masks


def _h_likeness(contour: np.ndarray) -> float | None:
    """How H-like a region is (higher is better), None when it is no H.

    An H is a convex outline with exactly two deep notches (above and below the
    crossbar), of about equal depth, on opposite sides of its centre, and nothing else
    cut out of it; seen in perspective it keeps all of that.
    """
    hull_area = cv2.contourArea(cv2.convexHull(contour))
    if hull_area <= 0:
        return None
    solidity = cv2.contourArea(contour) / hull_area
    if not 0.25 <= solidity <= 0.9:
        return None
    try:
        found = cv2.convexityDefects(contour, cv2.convexHull(contour, returnPoints=False))
    except cv2.error:  # a self-touching outline
        return None
    if found is None:
        return None
    defects = np.asarray(found).reshape(-1, 4)
    order = np.argsort(-defects[:, 3])
    side = math.sqrt(hull_area)
    depths = defects[order, 3] / 256.0 / side
    if len(depths) < 2 or depths[1] < 0.15 or depths[1] < 0.5 * depths[0]:
        return None
    rest = float(depths[2]) if len(depths) > 2 else 0.0
    if rest > 0.05:
        return None
    pts = contour.reshape(-1, 2).astype(float)
    m = cv2.moments(contour)
    centre = np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])
    # The notches' mouths (hull edges over them) lie on opposite sides of the centre.
    mouths = [(pts[defects[k, 0]] + pts[defects[k, 1]]) / 2 - centre for k in order[:2]]
    if float(np.dot(mouths[0], mouths[1])) >= 0:
        return None
    return float(depths[1] / depths[0]) - rest


def _refine(quad: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Corners from lines fitted to the outline's points along each side of ``quad``."""
    lines = []
    for i in range(4):
        p, q = quad[i], quad[(i + 1) % 4]
        d = q - p
        length = float(np.hypot(*d))
        if length < 4:
            return quad
        n = np.array([-d[1], d[0]]) / length
        along = (points - p) @ (d / length)
        near = points[
            (np.abs((points - p) @ n) < max(2.0, 0.03 * length))
            & (along > 0.15 * length)
            & (along < 0.85 * length)
        ]
        if len(near) < 5:
            return quad
        vx, vy, x0, y0 = cv2.fitLine(near.astype(np.float32), cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
        lines.append((np.array([x0, y0], float), np.array([vx, vy], float)))
    out = []
    for i in range(4):
        (p1, d1), (p2, d2) = lines[i - 1], lines[i]
        m = np.array([d1, -d2]).T
        if abs(np.linalg.det(m)) < 1e-6:
            return quad
        t = np.linalg.solve(m, p2 - p1)
        out.append(p1 + t[0] * d1)
    refined = np.array(out)
    return (
        refined
        if np.abs(refined - quad).max() < 0.1 * cv2.arcLength(quad.astype(np.float32), True)
        else quad
    )


def _quad_of(hull: np.ndarray, outline: np.ndarray) -> np.ndarray | None:
    """The hull as a quadrilateral, when four corners describe it well (its sides fitted
    to the outline's points)."""
    perimeter = cv2.arcLength(hull, True)
    for eps in (0.01, 0.02, 0.03, 0.05):
        approx = cv2.approxPolyDP(hull, eps * perimeter, True)
        if len(approx) == 4:
            quad = approx.reshape(4, 2).astype(float)
            if cv2.contourArea(quad.astype(np.float32)) >= 0.85 * cv2.contourArea(hull):
                return _refine(quad, outline.reshape(-1, 2).astype(float))
            return None
        if len(approx) < 4:
            return None
    return None


def _ellipse_of(hull: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, float] | None:
    """Box corners of the ellipse fitted to the hull (points on the image edge left out),
    and how well it fits (hull area / ellipse area)."""
    pts = hull.reshape(-1, 2)
    h, w = shape
    inside = pts[(pts[:, 0] > 1) & (pts[:, 0] < w - 2) & (pts[:, 1] > 1) & (pts[:, 1] < h - 2)]
    if len(inside) < 6:
        return None
    dense = cv2.approxPolyDP(inside.reshape(-1, 1, 2).astype(np.int32), 1.0, False)
    if len(dense) < 5:
        dense = inside.reshape(-1, 1, 2).astype(np.int32)
    (cx, cy), (a, b), angle = cv2.fitEllipse(dense)
    if a <= 0 or b <= 0:
        return None
    fit = cv2.contourArea(hull) / (math.pi * a * b / 4)
    # The ellipse is the unit circle through A; the square around the circle whose image
    # has its right edge's middle straight right of the centre reads most upright.
    t = math.radians(angle)
    A = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]) @ np.diag(
        [a / 2, b / 2]
    )
    u = np.linalg.solve(A, [1.0, 0.0])
    phi = math.atan2(u[1], u[0])
    R = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    square = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    corners = (A @ R @ square.T).T + np.array([cx, cy])
    return corners, float(fit)


def _contains(contour: np.ndarray, point: tuple[float, float]) -> bool:
    return cv2.pointPolygonTest(contour, point, False) > 0


def suggest_outline(image_bgr: np.ndarray) -> Outline:
    """The pad's outline in a perspective photo: a starting guess for the operator.

    Finds the most H-like region (the largest with an H's two facing notches) in
    several binarisations, then the largest convex region around it
    that is not the whole picture, and fits it with a quadrilateral and an ellipse.
    When nothing surrounds the H, the box around the H grown by half its size is the
    guess; with no H-like region at all, the middle half of the picture.

    Parameters
    ----------
    image_bgr : (H, W, 3) uint8 array
        The photo.

    Returns
    -------
    Outline

    Examples
    --------
    >>> from pipeline.render import make_pad_image
    >>> pad = make_pad_image(200)
    >>> photo = cv2.copyMakeBorder(pad, 100, 100, 100, 100, cv2.BORDER_CONSTANT, value=(90, 90, 90))
    >>> outline = suggest_outline(photo)
    >>> outline.kind
    'quad'
    >>> bool(np.abs(outline.quad - [[100, 100], [299, 100], [299, 299], [100, 299]]).max() < 4)
    True
    """
    image = np.asarray(image_bgr)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError("image_bgr must be an (H, W, 3) uint8 array")
    height, width = image.shape[:2]
    if min(height, width) < 32:
        raise ValueError(f"image_bgr is too small ({width}x{height}); it needs 32 px a side")
    scale = min(1.0, WORK_SIDE / max(height, width))
    small = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    sh, sw = small.shape[:2]
    min_area = MIN_AREA_FRACTION * sh * sw
    masks = _binaries(small)

    # The largest H-like region (noise makes small H-ish specks; the pad's H is big).
    best_h: tuple[float, np.ndarray] | None = None
    for mask in masks:
        contours, _ = cv2.findContours(mask, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
        for c in contours:
            area = cv2.contourArea(c)
            if area < min_area or _h_likeness(c) is None:
                continue
            if best_h is None or area > best_h[0]:
                best_h = (area, c)

    def scaled(points: np.ndarray) -> np.ndarray:
        return np.asarray(points, float) / scale

    if best_h is None:
        quad = np.array([[sw / 4, sh / 4], [3 * sw / 4, sh / 4], [3 * sw / 4, 3 * sh / 4],
                         [sw / 4, 3 * sh / 4]])  # fmt: skip
        return Outline(scaled(quad), None, "h_box", None)

    h_contour = best_h[1]
    hx, hy, hw, hh = cv2.boundingRect(h_contour)
    h_area = cv2.contourArea(cv2.convexHull(h_contour))
    moments = cv2.moments(h_contour)
    centre = (moments["m10"] / moments["m00"], moments["m01"] / moments["m00"])

    quad_best: tuple[float, np.ndarray] | None = None
    ellipse_best: tuple[float, np.ndarray] | None = None
    # The outline from the global thresholds only: a local threshold draws a halo
    # outside every strong edge, which would pass for a larger outline.
    for mask in masks[:-2]:
        contours, _ = cv2.findContours(mask, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
        for c in contours:
            hull = cv2.convexHull(c)
            area = cv2.contourArea(hull)
            if area < 1.5 * h_area or area > 0.9 * sh * sw or not _contains(hull, centre):
                continue
            # A pad is a solid shape: a region that ran into the floor around it is not.
            if cv2.contourArea(c) < 0.9 * area:
                continue
            quad = _quad_of(hull, c)
            if quad is not None and (quad_best is None or area > quad_best[0]):
                quad_best = (area, quad)
            fitted = _ellipse_of(hull, (sh, sw))
            if (
                fitted is not None
                and fitted[1] > 0.9
                and (ellipse_best is None or area > ellipse_best[0])
            ):
                ellipse_best = (area, fitted[0])

    h_box = tuple(round(v / scale) for v in (hx, hy, hw, hh))
    ellipse = None if ellipse_best is None else scaled(order_corners(ellipse_best[1]))
    if quad_best is not None and (ellipse_best is None or quad_best[0] >= 0.95 * ellipse_best[0]):
        return Outline(scaled(order_corners(quad_best[1])), ellipse, "quad", h_box)  # type: ignore[arg-type]
    if ellipse is not None:
        return Outline(ellipse, ellipse, "ellipse", h_box)  # type: ignore[arg-type]
    rect = cv2.minAreaRect(h_contour)
    grown = (rect[0], (rect[1][0] * 1.5, rect[1][1] * 1.5), rect[2])
    quad = order_corners(cv2.boxPoints(grown))
    return Outline(scaled(quad), None, "h_box", h_box)  # type: ignore[arg-type]


def rectify(
    image_bgr: np.ndarray, corners_px: np.ndarray, *, size_px: int = 600, aspect: float = 1.0
) -> np.ndarray:
    """The pad seen from straight above: ``corners_px`` (TL, TR, BR, BL) mapped onto a
    ``size_px`` wide picture of the pad's proportions (``aspect`` = width / height).

    Examples
    --------
    >>> img = np.zeros((100, 100, 3), np.uint8); img[20:80, 30:70] = 255
    >>> out = rectify(img, np.array([[30, 20], [70, 20], [70, 80], [30, 80]]), size_px=40,
    ...               aspect=40 / 60)
    >>> out.shape, int(out.min())
    ((60, 40, 3), 255)
    """
    image = np.asarray(image_bgr)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError("image_bgr must be an (H, W, 3) uint8 array")
    src = np.asarray(corners_px, np.float64)
    if src.shape != (4, 2) or not np.all(np.isfinite(src)):
        raise ValueError("corners_px must be 4 finite (x, y) points: TL, TR, BR, BL")
    if not isinstance(size_px, int) or not 32 <= size_px <= 4096:
        raise ValueError(f"size_px must be an int in 32..4096, got {size_px!r}")
    if not (isinstance(aspect, int | float) and math.isfinite(aspect) and 0.1 <= aspect <= 10):
        raise ValueError(f"aspect must be a number in 0.1..10, got {aspect!r}")
    quad = src.astype(np.float32).reshape(-1, 1, 2)
    if not cv2.isContourConvex(quad) or cv2.contourArea(quad) < 16.0:
        raise ValueError(
            "corners_px must outline a convex quadrilateral (TL, TR, BR, BL) of some size"
        )
    w = size_px
    h = max(8, round(size_px / aspect))
    dst = np.array([[0, 0], [w, 0], [w, h], [0, h]], np.float32)
    H = cv2.getPerspectiveTransform(src.astype(np.float32), dst)
    return cv2.warpPerspective(image, H, (w, h), flags=cv2.INTER_AREA, borderValue=(0, 0, 0))
