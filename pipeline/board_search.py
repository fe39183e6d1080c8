"""A far pad found by its board: the H too small to place, the board around it not.

From some 15 m on a 640 px frame the H spans under a dozen pixels with legs of
two: `pipeline.candidates` can no longer place its corners, while its board (the
square the H is painted on, a sheet of paper) is two to four times wider, and its
outline is four long straight edges. Around every small mark of the H's polarity
the board is grown: the pixels nearer the level right around the mark than the
floor's level around the board (a board lighter or darker than its floor alike),
as far as they reach; a board that does not stand out of its floor's noise is none.
Where they make a quadrilateral of the pad's proportions, the whole pad (H and
marks) is fitted to the edges inside it from each of its four turns, taken affine
(so small, its perspective is noise), and kept when most of its H's sides are
found where the fit puts them and the picture inside matches the reference's.

Only a pad whose picture is its board (every border pixel of the reference the
same level: `Reference.board_is_outline`) is looked for so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.homography_fit import affine_part, fit_homography
from pipeline.measure import pad_box_m
from pipeline.preprocess import border_pixels
from pipeline.reference import RELIABLE_H_PX, Reference
from pipeline.shapes import Region
from pipeline.template import pad_pattern

MIN_BOARD_PX = 12.0  # a board narrower than this (frame pixels) holds too few for its pattern
MIN_SEED_PX = 3.0  # the H's mark, at least this wide on the view
MIN_BOARD_CONTRAST = 8.0  # the board against its floor, levels of 0..255
# ... and against the floor's noise (robust spread around the board, over the contrast):
# 0.10-0.20 on the bench's far views (15-30 dB), 0.62 grown from a real photo's noise.
MAX_FLOOR_NOISE = 0.35
MAX_SEEDS = 48  # marks a board is grown around per frame at most
MAX_BOARDS = 6  # quadrilaterals fitted per frame at most, the most contrasted first
# A fitted pad counts when its pattern matches the reference's (NCC) and half its H's
# sides are found where the fit puts them: on the bench's far views (16-22 m, 565
# quadrilaterals), no other quadrilateral found over 0.51 of them (their NCC up to
# 0.81); true pads found 0.55-0.9 at NCC 0.61-0.75 where their H was too small to place.
MIN_BOARD_NCC = 0.6
MIN_H_FOUND = 0.5
# Its pose counts when the pad's edges are found where it puts them: the bench's far
# boards posed within 3 % of the altitude found 0.22-0.5 of them, those 10-40 % off, 0.07-0.13.
MIN_BOARD_SUPPORT = 0.2
MIN_BOARD_SHARE = 0.3  # of the quadrilateral, at the board's level (not the mark's)
_QUAD_EPS = 0.06  # Douglas-Peucker tolerance, of the hull's perimeter
_FILL = (0.75, 1.15)  # the grown board's area over its quadrilateral's
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))


@dataclass(frozen=True)
class Board:
    """A quadrilateral (view pixels, 4 x 2, clockwise on screen) and how far its
    level stands from the floor's."""

    quad: np.ndarray
    contrast: float


def find_boards(
    levels: np.ndarray, shapes: list[Region], reference: Reference, enlarged: float
) -> list[np.ndarray]:
    """Homographies (pad metres -> view pixels) of the pads found by their boards,
    best pattern first, on a view's smoothed channel (``levels``) and around its
    regions of the H's polarity (``shapes``, `pipeline.find.search`'s); ``enlarged``:
    view pixels per frame pixel."""
    if not reference.board_is_outline:
        return []
    ratio = reference.pad_size_m / float(np.ptp(reference.corners_m, axis=0).max())
    # The marks of the H's polarity small enough for their H to be missed, and large
    # enough for a board the size of MIN_BOARD_PX around them; on a textured floor
    # (a thousand of them) the largest first, MAX_SEEDS of them.
    most = RELIABLE_H_PX * enlarged
    least = max(MIN_SEED_PX, MIN_BOARD_PX * enlarged / (2.0 * ratio))
    seeds = []
    for region in shapes:
        size = float(np.ptp(region.contour, axis=0).max())
        if least <= size <= most:
            seeds.append(region)
    seeds.sort(key=lambda r: -r.area)
    boards: list[Board] = []
    for seed in seeds[:MAX_SEEDS]:
        board = _grow_board(levels, seed.contour, ratio, MIN_BOARD_PX * enlarged)
        if board is not None and not any(_same(board.quad, b.quad) for b in boards):
            boards.append(board)
    boards.sort(key=lambda b: -b.contrast)
    found = []
    for board in boards[:MAX_BOARDS]:
        fitted = _fit_board(levels, reference, board.quad)
        if fitted is not None:
            found.append(fitted)
    found.sort(key=lambda f: -f[0])
    return [H for _, H in found]


def _grow_board(
    levels: np.ndarray, contour: np.ndarray, ratio: float, min_px: float
) -> Board | None:
    """The board around a mark, when it is a quadrilateral the pad's size for it."""
    lo, hi = contour.min(axis=0), contour.max(axis=0)
    size = float(np.max(hi - lo)) + 1.0
    if size < MIN_SEED_PX:
        return None
    # A window with room for the whole pad around its H, and some floor.
    half = int(0.75 * ratio * size) + 4
    cx, cy = (int(v) for v in 0.5 * (lo + hi))
    x0, y0 = cx - half, cy - half
    if x0 < 0 or y0 < 0 or cx + half >= levels.shape[1] or cy + half >= levels.shape[0]:
        return None
    win = levels[y0 : cy + half + 1, x0 : cx + half + 1]
    seed = np.zeros(win.shape, np.uint8)
    cv2.fillPoly(seed, [(contour - [x0, y0]).astype(np.int32).reshape(-1, 1, 2)], 1)
    ring = cv2.dilate(seed, np.ones((5, 5), np.uint8)) & (1 - seed)
    border = border_pixels(win, 2)
    floor = float(np.median(border))
    # The board's level: its core's, beyond the H's blur (the ring's median, the
    # H's light blurred into it, would set the threshold toward the floor's and
    # grow the board by a blur's width all round).
    around = win[ring > 0]
    darker = float(np.median(around)) < floor
    board = float(np.percentile(around, 10 if darker else 90))
    contrast = abs(board - floor)
    noise = 1.4826 * float(np.median(np.abs(border - floor)))
    if contrast < MIN_BOARD_CONTRAST or noise > MAX_FLOOR_NOISE * contrast:
        return None
    grown = (np.abs(win - floor) > 0.5 * contrast).astype(np.uint8)
    # (opened: the floor's noise joins a low-contrast board by threads a pixel wide)
    grown = cv2.morphologyEx(grown, cv2.MORPH_OPEN, _CROSS) | seed
    count, labels = cv2.connectedComponents(grown, connectivity=8)
    votes = np.bincount(labels[ring > 0], minlength=count)
    votes[0] = 0
    part = (labels == int(np.argmax(votes))).astype(np.uint8)
    if part[0].any() or part[-1].any() or part[:, 0].any() or part[:, -1].any():
        return None  # it runs into the floor: no board's edge all round
    outlines, _ = cv2.findContours(part, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(outlines, key=cv2.contourArea)
    hull = cv2.convexHull(outline)
    quad = cv2.approxPolyDP(hull, _QUAD_EPS * cv2.arcLength(hull, True), True)
    if len(quad) != 4:
        return None
    quad_area = max(cv2.contourArea(quad), 1e-9)
    fill = cv2.contourArea(outline) / quad_area
    # The board itself, beside the mark: an H's own outline is a quadrilateral too.
    board_share = np.count_nonzero(part & (1 - seed)) / quad_area
    quad = quad.reshape(4, 2).astype(np.float64)
    span = float(np.ptp(quad, axis=0).max())
    if not _FILL[0] <= fill <= _FILL[1] or board_share < MIN_BOARD_SHARE:
        return None
    if span < min_px or not _pad_sized(span, size, ratio):
        return None
    return Board(_clockwise(quad) + np.array([x0, y0], np.float64), contrast)


def _pad_sized(span: float, mark: float, ratio: float) -> bool:
    """Whether a board this wide can hold an H of the mark's size (a mark may be
    the whole H, a leg of it or, blurred, the H with a bar)."""
    return 0.5 * ratio * mark <= span <= 2.0 * ratio * mark


def _fit_board(
    levels: np.ndarray, reference: Reference, quad: np.ndarray
) -> tuple[float, np.ndarray] | None:
    """The pad fitted from the quadrilateral in each of its four turns: the best
    pattern's (NCC, homography), when it is the pad's."""
    box = pad_box_m(reference).astype(np.float32)
    n_h = len(reference.corners_m)
    best: tuple[float, np.ndarray] | None = None
    for turn in range(4):
        start = cv2.getPerspectiveTransform(box, np.roll(quad, -turn, axis=0).astype(np.float32))
        fit = fit_homography(
            levels, reference.edge_model, start.astype(np.float64), iterations=3, search_px=3.0,
            sides_alike=False,
        )  # fmt: skip
        if fit is None:
            continue
        h_found = fit.side_found[:n_h]
        h_found = h_found[np.isfinite(h_found)]
        if not len(h_found) or float(h_found.mean()) < MIN_H_FOUND:
            continue  # (an H too small for any of its sides to be told is no evidence)
        # So small a pad shows no perspective: the fit's is its noise, which skewed
        # the pose by up to 40 % of the altitude. Its affine part is kept.
        H = affine_part(fit.H, np.zeros(2))
        ncc = pad_pattern(
            levels, reference.template_pyramid, reference.channel_px_per_m, pad_box_m(reference), H
        )
        if math.isfinite(ncc) and ncc >= MIN_BOARD_NCC and (best is None or ncc > best[0]):
            best = (ncc, H)
    return best


def _clockwise(quad: np.ndarray) -> np.ndarray:
    """The corners in the pad box's order on screen (y down: clockwise)."""
    c = quad.mean(axis=0)
    return quad[np.argsort(np.arctan2(quad[:, 1] - c[1], quad[:, 0] - c[0]))]


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return (
        float(np.abs(a.mean(axis=0) - b.mean(axis=0)).max()) <= 2.0
        and float(abs(np.ptp(a, axis=0).max() - np.ptp(b, axis=0).max())) <= 2.0
    )
