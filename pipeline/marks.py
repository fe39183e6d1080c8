"""The pad's other marks: every edge of the reference picture beyond the H.

Side bars, rings, a disc's rim, an octagon's or a hexagon's frame, stars, a
triangle, the board's outer edge: all are edges a frame can show where the
pose puts them, several times farther apart than the H's, which pins the
pose's tilt; and the marks that break the H's half-turn symmetry (a triangle,
stars above the H) tell which of the two headings the pad is seen at.

Each mark is a closed polygon in the picture (curves become polygons with
short sides), with the side it is bright on: a mark of the H's paint is
bright inside; the board's rim against a lighter floor, or a ring's hole, is
dark inside.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.edgefit import CURVE_VERTICES
from pipeline.edges import refine_polygon
from pipeline.preprocess import border_pixels
from pipeline.shapes import ellipse_misfit

MIN_MARK_AREA = 0.0005  # of the picture: smaller specks are texture, not marks
MAX_MARKS = 16
# A half turn maps a mark onto one whose centre lies this near (of the H's size) and whose
# area is within a tenth of its own.
HALF_TURN_TOL = 0.03
FLATNESS = 0.0005  # Douglas-Peucker tolerance, of a mark's perimeter (>= 0.5 px)
MAX_SIDES = 96
REPEATED_PX = 0.5  # a vertex this near the one before it is the same corner
# Beyond a board's rim, a band of another colour (a fabric pad's hem) this narrow, of
# the pad's size at most, is looked for: the band's far edge then lies beside the rim.
MAX_BAND = 0.1
BAND_STEP = 30.0  # a colour step beyond the rim: this far in BGR at least ...
BAND_STEP_SHARE = 0.5  # ... and this share of the rim's own step
RIM_STEP = 0.25  # a rim: the board steps to what lies beyond by this share of the paint's step
FAINT_RIM_STEP = 0.5  # ... a faint one, under this share
BOARD_OVER_H = 1.5  # a board is this many times the H's area at least
RIM_BAND_PX = 4  # what lies right beyond a rim: this wide a band (picture pixels)
MIN_RIM_CHROMA = 20.0  # a coloured board's rim steps this far on its chroma (BGR levels)
# A board touching the picture's edge is a disc cropped to its width when this share
# of its outline lies off the edge, 90 % of it this near an ellipse (of its radius), and
# the ellipse runs beyond the edge by a pixel and this share of its width at most.
DISC_SHARE, DISC_FIT, DISC_CROP, DISC_VERTICES = 0.6, 0.01, 0.02, 64
_FRINGE = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))  # an edge's blur, 3 px each way


@dataclass(frozen=True, eq=False)
class Mark:
    """A closed polygon in pad metres and whether the polygon is brighter than
    its surroundings on the reference's channel."""

    corners_m: np.ndarray
    bright: bool
    rim: bool = False  # the board's outer edge: the floor lies beyond it
    band_m: float = 0.0  # a rim's: the band of another colour right beyond it (`band_beyond`)
    faint: bool = False  # a rim stepping under half as far as the H's paint (`find_marks`)
    # a rim lighter than the band right beyond it and darker than the floor, or the
    # other way round: its edge is the band's, lost where the band is (`find_marks`)
    banded: bool = False

    def to_dict(self) -> dict:
        return {
            "corners_m": self.corners_m.tolist(),
            "bright": bool(self.bright),
            "rim": bool(self.rim),
            "band_m": float(self.band_m),
            "faint": bool(self.faint),
            "banded": bool(self.banded),
        }


def find_marks(
    smooth: np.ndarray,
    level: float,
    board_level: float,
    h_region: np.ndarray,
    chroma: tuple[np.ndarray, float] | None = None,
) -> list[tuple[np.ndarray, bool, bool, bool, bool]]:
    """Polygons (picture pixels) of the marks on a smoothed channel, with their brightness,
    whether each is the board's rim, whether that rim is faint and whether it is banded
    (`Mark`).

    ``level``: half-way between the H's paint and its board; ``board_level``:
    the board's. Boundaries of the paint-coloured regions other than the H
    (outer edges and holes), then the board's own rim against whatever lies
    beyond it when that differs from the board: by ``RIM_STEP`` of the paint's step from
    the board at least (a black H on a yellow disc printed on white: on the learned
    channel the disc's rim steps 27 levels, a third of the H's step, and with it the
    pad's poses came 0.67 % off the altitude, not 1.14 %). Such a rim, under
    ``FAINT_RIM_STEP``, is faint: from afar, on a view enlarged by interpolation, its
    edge is no longer found.

    ``chroma``: the picture read on the board's colour (`chroma_levels`) and the board's
    level there, for a coloured board. Where the channel tells no rim, the board's rim
    is looked for there too (stepping ``MIN_RIM_CHROMA`` at least): on the learned
    channel of a real orange disc on concrete the disc stepped 18 levels, its shading
    as much, and the cut ran into the floor; a synthetic one on dark grey stepped none.
    On the disc's chroma both stepped over 95.
    """
    h, w = smooth.shape
    area = float(h * w)
    # (area, polygon, bright, rim, faint, banded)
    out: list[tuple[float, np.ndarray, bool, bool, bool, bool]] = []
    paint = (smooth > level).astype(np.uint8)
    # Every paint region that touches the H is the H (the H was found at
    # another threshold than this one).
    _, labels = cv2.connectedComponents(paint)
    h_labels = np.unique(labels[h_region & (paint > 0)])
    others = paint.copy()
    others[np.isin(labels, h_labels[h_labels > 0]) | h_region] = 0
    out += [
        (*b, False, False, False) for b in _boundaries(others, smooth, area, bright_inside=True)
    ]
    # What lies beyond the board (a floor around a disc, the paper around a
    # card) is told by the picture's rim.
    beyond = float(np.median(border_pixels(smooth, 1)))
    step = abs(level - board_level)
    rims: list[tuple[float, np.ndarray, bool]] = []
    faint = abs(beyond - board_level) < FAINT_RIM_STEP * step

    def around_the_marks(found: list[tuple[float, np.ndarray, bool]]) -> list:
        # (a floor all round the board made its rim a hole's outline already;
        # and the marks lie on the board: an outline inside one of them, a ring's
        # hole cut at a level near the board's, is none of its rim)
        return [
            r
            for r in found
            if not any(_same_outline(r, o[:3]) for o in out)
            and all(_encloses(r[1], o[1]) for o in out)
        ]

    if abs(beyond - board_level) > RIM_STEP * step:
        on_board = paint
        if (beyond > board_level) == (level > board_level):
            # A floor as light as the paint (a grey floor around a black disc, on a red
            # channel) is no mark on the board: the paint that reaches the picture's
            # edge is left out, or the board would run into the floor.
            on_board = _off_the_edge(paint)
        rims = around_the_marks(_rim(smooth, beyond, board_level, on_board, h_region))
    # (on the board's colour, what lies beyond may differ where the channel says not)
    differs = abs(beyond - board_level) > RIM_STEP * step
    if not rims and chroma is not None:
        levels, board_chroma = chroma
        beyond_chroma = float(np.median(border_pixels(levels, 1)))
        if board_chroma - beyond_chroma > MIN_RIM_CHROMA:
            differs = True
            found = _rim(levels, beyond_chroma, board_chroma, _off_the_edge(paint), h_region)
            rims = around_the_marks(found)
    # A rim is bright inside where the board is lighter than what lies right beyond it
    # on the channel: a real orange disc (57) darker than the concrete beyond (75) is
    # lighter than the black hem between them (38), whose edge with it the rim is.
    # Where the floor beyond it lies the other side of the board's level, the rim's edge
    # is the band's: from afar, the band under a pixel, it is lost.
    for a, poly, _ in rims:
        bright = _level_beyond(smooth, poly) < board_level
        out.append((a, poly, bright, True, faint, bright != (beyond < board_level)))
    if not differs:
        # The board fills the picture to its edge: the edge is the board's rim.
        rect = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
        out.append((area, rect, False, True, False, False))
    out.sort(key=lambda item: -item[0])
    return [item[1:] for item in out[:MAX_MARKS]]


def _level_beyond(smooth: np.ndarray, poly: np.ndarray) -> float:
    """The median level of a band ``RIM_BAND_PX`` wide right outside a polygon (of the
    picture's pixels; the polygon's own level where none lies outside)."""
    inside = np.zeros(smooth.shape, np.uint8)
    cv2.fillPoly(inside, [np.round(poly).astype(np.int32)], 1)
    band = cv2.dilate(inside, np.ones((2 * RIM_BAND_PX + 1,) * 2, np.uint8)) > inside
    return float(np.median(smooth[band])) if band.any() else float(np.median(smooth[inside > 0]))


def _rim(
    levels: np.ndarray,
    beyond: float,
    board_level: float,
    on_board: np.ndarray,
    h_region: np.ndarray,
) -> list[tuple[float, np.ndarray, bool]]:
    """The board's outline (area, polygon, bright inside) on ``levels``, cut half-way
    between the board's level and what lies beyond it, with the marks ``on_board`` and
    the H joined to it; none where the board runs along the picture's edge."""
    h, w = levels.shape
    cut = 0.5 * (beyond + board_level)
    board = ((levels < cut) if beyond > board_level else (levels > cut)).astype(np.uint8)
    # The board component around the H, holes filled: its outer edge is the pad's rim.
    # The H's blurred edge, between the paint's level and the cut, is neither board
    # nor paint: the H grown over it joins the board (without, a cut near the board's
    # level left the H alone, and its own outline was taken for the rim).
    grown = cv2.dilate(h_region.astype(np.uint8), _FRINGE)
    _, labels = cv2.connectedComponents(board | on_board | grown)
    ys, xs = np.nonzero(h_region)
    k = int(np.bincount(labels[ys, xs]).argmax())
    comp = (labels == k).astype(np.uint8)
    if k == 0 or np.count_nonzero(comp) <= BOARD_OVER_H * np.count_nonzero(grown):
        return []
    bright_inside = beyond < board_level
    # A disc cropped to its width touches the picture's edge at four points; a board
    # that runs along it has no rim in the picture, unless the rest of its outline is
    # an ellipse: a disc cropped to a little less than its width.
    if np.mean(border_pixels(comp, 1)) < 0.1:
        return _boundaries(
            comp, levels, float(h * w), bright_inside=bright_inside, holes=False, rim=True
        )
    disc = _cropped_disc(comp)
    return [] if disc is None else [(abs(_area(disc)), disc, bright_inside)]


def _cropped_disc(comp: np.ndarray) -> np.ndarray | None:
    """The ellipse (a polygon of ``DISC_VERTICES``) that the outline of a board touching
    the picture's edge follows away from it (``DISC_FIT`` of its radius, ``DISC_SHARE``
    of it at least), where the ellipse lies within the picture but for ``DISC_CROP``: a
    disc cropped to its width or a little tighter. None for anything else."""
    h, w = comp.shape
    contours, _ = cv2.findContours(comp, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    pts = max(contours, key=cv2.contourArea).reshape(-1, 2)
    inner = (pts[:, 0] > 1) & (pts[:, 1] > 1) & (pts[:, 0] < w - 2) & (pts[:, 1] < h - 2)
    if inner.mean() < DISC_SHARE or inner.sum() < 5:
        return None
    ellipse = cv2.fitEllipse(pts[inner].reshape(-1, 1, 2).astype(np.float32))
    (cx, cy), (a, b), angle = ellipse
    t = np.linspace(0.0, 2.0 * np.pi, DISC_VERTICES, endpoint=False)
    rot = np.deg2rad(angle)
    local = np.stack([0.5 * a * np.cos(t), 0.5 * b * np.sin(t)], axis=1)
    turn = np.array([[np.cos(rot), -np.sin(rot)], [np.sin(rot), np.cos(rot)]])
    poly = local @ turn.T + [cx, cy]
    reach = 1.0 + DISC_CROP * max(a, b)  # (beyond the picture's edge, at -0.5)
    if (poly < -0.5 - reach).any() or (poly > np.array([w, h]) - 0.5 + reach).any():
        return None
    return None if ellipse_misfit(pts[inner], ellipse) > DISC_FIT else poly


def band_beyond(picture: np.ndarray, rim: np.ndarray) -> float:
    """The width (picture pixels) of a band of another colour right beyond a board's
    rim (``rim``: its polygon on ``picture``, BGR), or 0 when there is none.

    The rim of a fabric pad is often a hem: a dark band a few centimetres wide between
    the board and the floor. In a frame, that band's far edge lies a pixel or two beyond
    the rim, and a blurred edge is pushed away from an edge beside it that steps the
    other way: the rim reads too far out (on the bench's hemmed orange pad at 2-12 m,
    the altitude came 0.3-0.6 % short). Along the rim's
    outward normals, the colour just beyond it is followed until it steps by
    ``BAND_STEP`` (and ``BAND_STEP_SHARE`` of the rim's own step); where the picture
    ends first, that point tells nothing. A band is one found at half the points or
    more, within ``MAX_BAND`` of the picture's size."""
    h, w = picture.shape[:2]
    smooth = cv2.GaussianBlur(picture.astype(np.float32), (0, 0), 1.0)
    a = rim.astype(np.float64)
    b = np.roll(a, -1, axis=0)
    pts, normals = [], []
    inside = a.reshape(-1, 1, 2).astype(np.float32)
    for p, q in zip(a, b, strict=True):
        d = q - p
        length = float(np.hypot(*d))
        if length < 1e-9:
            continue
        k = max(1, int(length // 2.0))
        t = (np.arange(k) + 0.5) / k
        n = np.array([d[1], -d[0]]) / length
        probe = p + 0.5 * d + 2.0 * n
        if cv2.pointPolygonTest(inside, (float(probe[0]), float(probe[1])), False) > 0:
            n = -n  # (outward)
        pts.append(p + t[:, None] * d)
        normals.append(np.repeat(n[None], k, axis=0))
    if not pts:
        return 0.0
    p_all, n_all = np.vstack(pts), np.vstack(normals)
    reach = MAX_BAND * max(h, w)
    # Every half pixel from 2 px within the rim (the board) to 2 px beyond it (the band)
    # and on from there.
    steps = np.arange(-2.0, reach + 0.25, 0.5)
    at_band = 8
    xs = (p_all[:, None, 0] + steps[None] * n_all[:, None, 0]).astype(np.float32)
    ys = (p_all[:, None, 1] + steps[None] * n_all[:, None, 1]).astype(np.float32)
    colours = cv2.remap(smooth, xs, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    board, band = colours[:, 0], colours[:, at_band]
    rim_step = np.linalg.norm(band - board, axis=1)
    xs, ys, steps = xs[:, at_band + 1 :], ys[:, at_band + 1 :], steps[at_band + 1 :]
    away = np.linalg.norm(colours[:, at_band + 1 :] - band[:, None], axis=2)
    beyond = (xs < 0) | (ys < 0) | (xs > w - 1) | (ys > h - 1)  # (the picture has ended)
    stepped = away > np.maximum(BAND_STEP, BAND_STEP_SHARE * rim_step)[:, None]
    stepped &= ~beyond
    first = np.where(stepped.any(axis=1), stepped.argmax(axis=1), -1)
    ended = np.where(beyond.any(axis=1), beyond.argmax(axis=1), beyond.shape[1])
    told = (first >= 0) & (first < ended)
    # (points where the picture ended first tell nothing; the rest must mostly agree)
    plain_floor = (first < 0) & (ended == beyond.shape[1])
    if not told.any() or told.sum() < 0.5 * (told.sum() + plain_floor.sum()):
        return 0.0
    # The band's far edge: where the colour has come half way to what lies beyond it.
    rows = np.flatnonzero(told)
    change = away[rows]
    plateau = change[np.arange(len(rows)), np.minimum(first[rows] + 4, change.shape[1] - 1)]
    k = np.maximum((change > 0.5 * plateau[:, None]).argmax(axis=1), 1)
    lo, hi = change[np.arange(len(rows)), k - 1], change[np.arange(len(rows)), k]
    frac = np.clip((0.5 * plateau - lo) / np.maximum(hi - lo, 1e-6), 0.0, 1.0)
    return float(np.median(steps[k - 1] + 0.5 * frac))


def _same_outline(a: tuple[float, np.ndarray, bool], b: tuple[float, np.ndarray, bool]) -> bool:
    """Whether two (area, polygon, bright) outlines are one: alike in brightness and
    area, about the same centre (within a pixel and 2 % of the size)."""
    if a[2] != b[2] or abs(a[0] - b[0]) > 0.02 * max(a[0], b[0]):
        return False
    size = float(np.sqrt(max(a[0], b[0])))
    return bool(np.hypot(*(a[1].mean(axis=0) - b[1].mean(axis=0))) <= 1.0 + 0.02 * size)


def _encloses(outer: np.ndarray, inner: np.ndarray) -> bool:
    """Whether the polygon ``outer`` holds every vertex of ``inner`` (to a pixel)."""
    poly = outer.reshape(-1, 1, 2).astype(np.float32)
    return all(cv2.pointPolygonTest(poly, (float(x), float(y)), True) >= -1.0 for x, y in inner)


def _off_the_edge(mask: np.ndarray) -> np.ndarray:
    """``mask`` without its components that touch the picture's edge."""
    _, labels = cv2.connectedComponents(mask)
    edge = np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])
    out = mask.copy()
    out[np.isin(labels, np.unique(edge[edge > 0]))] = 0
    return out


def _boundaries(
    mask: np.ndarray,
    smooth: np.ndarray,
    area: float,
    *,
    bright_inside: bool,
    holes: bool = True,
    rim: bool = False,
) -> list[tuple[float, np.ndarray, bool]]:
    mode = cv2.RETR_CCOMP if holes else cv2.RETR_EXTERNAL
    contours, hierarchy = cv2.findContours(mask, mode, cv2.CHAIN_APPROX_NONE)
    out = []
    h, w = mask.shape
    for i, c in enumerate(contours):
        a = abs(cv2.contourArea(c))
        if a < MIN_MARK_AREA * area or a > 0.95 * area:
            continue
        x, y, cw, ch = cv2.boundingRect(c)
        if not rim and (x == 0 or y == 0 or x + cw == w or y + ch == h):
            continue  # cut by the picture's edge: not a whole mark of the pad
        is_hole = hierarchy is not None and hierarchy[0][i][3] >= 0
        poly = _polygon(c)
        if poly is None:
            continue
        if len(poly) <= 8:  # straight-sided: its sides measured on the gray edges
            refined = refine_polygon(smooth, poly, bright_inside=bright_inside != is_hole)
            if refined is not None:
                poly = _without_repeats(refined[0])
        if len(poly) >= 3:
            out.append((a, poly, bool(bright_inside != is_hole)))
    return out


def _without_repeats(poly: np.ndarray) -> np.ndarray:
    """The polygon without the vertices that repeat the one before them: a corner traced
    cut off (a hole's outline) has its two ends refined onto one point, and a side of no
    length has no direction to measure its edge along."""
    keep = np.hypot(*(poly - np.roll(poly, 1, axis=0)).T) > REPEATED_PX
    return poly[keep]


def _polygon(contour: np.ndarray) -> np.ndarray | None:
    """The contour as a polygon: few vertices when its sides are straight (a bar, a
    star, a frame), else up to MAX_SIDES following a curve within half a pixel."""
    c = contour.reshape(-1, 1, 2)
    pts = c.reshape(-1, 2).astype(np.float64)
    straight = cv2.approxPolyDP(c, 0.01 * cv2.arcLength(c, True), True).reshape(-1, 2)
    if 3 <= len(straight) <= CURVE_VERTICES and _deviation(pts, straight) < 1.5:
        return straight.astype(np.float64)
    eps = max(0.5, FLATNESS * cv2.arcLength(c, True))
    for _ in range(8):
        approx = cv2.approxPolyDP(c, eps, True).reshape(-1, 2).astype(np.float64)
        if len(approx) <= MAX_SIDES:
            return approx if len(approx) >= 3 else None
        eps *= 1.5
    return None


def _deviation(pts: np.ndarray, poly: np.ndarray) -> float:
    """The largest distance from the contour's points to the polygon's sides."""
    a = poly.astype(np.float64)
    b = np.roll(a, -1, axis=0)
    d = b - a
    len2 = np.maximum(np.sum(d * d, axis=1), 1e-12)
    t = np.clip(((pts[:, None, :] - a[None]) * d[None]).sum(axis=2) / len2, 0.0, 1.0)
    near = a[None] + t[..., None] * d[None]
    return float(np.sqrt(np.sum((pts[:, None, :] - near) ** 2, axis=2)).min(axis=1).max())


def symmetric_marks(corners_m: np.ndarray, marks: tuple[Mark, ...]) -> bool:
    """Whether a half turn about the pad centre maps the H's corners and every mark
    (by its centre, area and brightness) onto one."""
    tol = HALF_TURN_TOL * float(np.ptp(corners_m, axis=0).max())
    d = np.linalg.norm(-corners_m[:, None, :] - corners_m[None, :, :], axis=2)
    if not np.all(d.min(axis=1) < tol):
        return False
    return not any(moved_by_half_turn(np.zeros(2), marks, tol))


def moved_by_half_turn(centre_m: np.ndarray, marks: tuple[Mark, ...], tol_m: float) -> list[bool]:
    """For each mark, whether a half turn about ``centre_m`` moves it onto no mark (by
    its centre, within ``tol_m``, its area and brightness): the marks that tell which
    way round the pad lies."""
    stats = [(_centre(m.corners_m), _area(m.corners_m), m.bright) for m in marks]
    return [
        not any(
            b == bright
            and np.linalg.norm(2.0 * centre_m - c - c2) < tol_m
            and abs(a - a2) <= 0.1 * max(a, a2)
            for c2, a2, b in stats
        )
        for c, a, bright in stats
    ]


def _area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))


def _centre(poly: np.ndarray) -> np.ndarray:
    m = cv2.moments(poly.astype(np.float32).reshape(-1, 1, 2))
    if abs(m["m00"]) < 1e-12:
        return poly.mean(axis=0)
    return np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])
