"""A pad found by its board: the H too small to place, or spoilt, the board around it not.

From some 15 m on a 640 px frame the H spans under a dozen pixels with legs of
two: `pipeline.candidates` can no longer place its corners, while its board (the
square the H is painted on, a sheet of paper) is two to four times wider, and its
outline is four long straight edges. Nearer, a glare on the H or a smear across it
joins it to what is around it, and its outline is no H's; the board's is still four
edges. Around every small mark of the H's polarity, and the few largest,
the board is grown: the pixels nearer the board's level (read around the mark) than
the floor's level around the board (a board lighter or darker than its floor
alike), as far as they reach; a board that does not stand out of its floor's noise
is none. A board whose H is no mark of the threshold at all (strokes under a pixel)
may be a hole of it, the floor right around it read lighter than its local mean:
such a hole is taken for a board as it is, and so is a mark of it where the board
is as light as its H (a white sheet around a dark octagon). Where they make a
quadrilateral of the pad's proportions, the whole pad (H and marks) is fitted to the
edges inside it from each of its four turns (and from each inset border's, where the
board may have stopped), taken affine (so small, its perspective is noise), and kept when
many of its H's sides and some of its board's outline are found where the fit puts
them, and the picture inside matches the reference's, the H telling which of the
board's turns is the pad's. A board of a colour is then placed by its outline on that
colour where it is found there (from afar its H's strokes are too thin and blurred to
place it).

Only a pad whose picture is its board (every border pixel of the reference the
same level: `Reference.board_is_outline`) is looked for so, or one whose H's board is
round (a disc on its floor, an octagon printed on a sheet, the disc a ring holds:
`Reference.round_board`). A circle seen at a slant is an ellipse, whatever its turn: the
pad is fitted from a dozen turns of it, and turned to where its H's pattern matches
best, the H alone telling its turn.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.edgefit import EdgeModel
from pipeline.edges import signed_area
from pipeline.homography_fit import affine_part, apply_h, fit_homography, span_of, support
from pipeline.jit import compiled
from pipeline.measure import pad_box_m
from pipeline.pose import turn_about
from pipeline.reference import Reference
from pipeline.shapes import Region, ellipse_misfit
from pipeline.template import pad_pattern, pattern_box

MIN_BOARD_PX = 12.0  # a board narrower than this (frame pixels) holds too few for its pattern
MIN_SEED_PX = 3.0  # the H's mark, at least this wide on the view
MISSED_H_PX = 28.0  # and at most this wide (frame pixels): an H that small may be missed
MIN_BOARD_CONTRAST = 8.0  # the board against its floor, levels of 0..255
# ... and against the floor's noise (robust spread around the board, over the contrast):
# 0.10-0.20 on the bench's far views (15-30 dB), 0.62 grown from a real photo's noise.
MAX_FLOOR_NOISE = 0.35
MAX_SEEDS = 48  # marks a board is grown around per frame at most
MAX_LARGE_SEEDS = 4  # and at most this many marks larger than a far H (a spoilt H's)
# ... and the marks most alone (the fewest pixels of the mask around them, over a box the
# board's size for them), this many more: on a textured floor the largest marks are the
# floor's. paper_ring's H's 6.5 m away (12 view px, on its plain sheet) ranked 100-160th
# of 300-900 marks by area, 0-2nd by that emptiness.
MAX_LONE_SEEDS = 8
LONE_REACH = 0.4  # the box's half-width, of the mark's size times the board's over the H's
MAX_BOARDS = 6  # quadrilaterals fitted per frame at most, the most contrasted first
# A fitted pad counts when its pattern matches the reference's (NCC), and 40 % of its
# H's sides and 10 % of its board's outline are found where the fit puts them. On the
# bench's far views (14-24 m, seven designs, pad and empty frames, ~2000 fits), no
# other quadrilateral found 0.4 of the H's sides at NCC 0.55 but a dark H painted on
# a light floor, where no board is (its "outline" found 0.0, true boards' up to 1).
MIN_BOARD_NCC = 0.55
MIN_H_FOUND = 0.4
MIN_OUTLINE_FOUND = 0.1
# Or, an H whose strokes are too thin and blurred for their edges to be found (a
# pixel and a half under a blur of one: paper_ring's at 2.5-3 m), when its own
# pattern matches (NCC over its box and a margin): such H's matched at 0.75-0.89 on
# the bench's views, where their pads' whole patterns read 0.2-0.6; of the quadrilaterals
# fitted on the bench's empty frames (today's, the real-world mix and 6-25 m away,
# 550 fits) with some of their board's outline found, none matched above 0.39 (the H's
# painted on floors, up to 0.86, have no board's outline).
MIN_H_NCC = 0.7
# ... and an H whose strokes are under FINE_STROKE_PX (frame pixels), blurred into its
# board, at MIN_FINE_H_NCC: paper_ring's H's of 6-11 px 4-9 m away (strokes of 0.8-1.6)
# matched at 0.6-0.7, thin's of 13 px (strokes of 1.2) at 15-17 m alike; nor did any
# quadrilateral with some outline found match above 0.53 on 2,500 more empty frames
# (the altitude sweep's floors where seven designs span 19-34 px, and both mixes: 77
# such fits, the best a dark H painted on a light floor). A larger H matching so little
# is poorly seen, and so is its pad: paper_ring's of 15 px (strokes of 2.1) at 2.6 m,
# overexposed, matched at 0.6-0.7 and posed 7 % off.
MIN_FINE_H_NCC, FINE_STROKE_PX = 0.6, 1.8
# A square board's four turns look alike but for the H: the turn taken must match the H's
# pattern better than the pad turned a quarter round does, by this much. On the altitude
# sweep's far boards (four designs, 172 found), the one posed turned a quarter round
# (paper_ring at 13 m, an H of 4 px) matched 0.03 better; 4 posed right by 0.05 or less.
QUARTER_MARGIN = 0.08
# Its pose counts when the pad's edges are found where it puts them: the bench's far
# boards posed within 3 % of the altitude found 0.22-0.5 of them, those 10-40 % off, 0.07-0.13.
MIN_BOARD_SUPPORT = 0.2
# ... or, a square board of a colour, when its outline is found where the pose puts it
# on its chroma; there too it is placed by that outline, wherever it is found so
# (CHROMA_PLACED of it). Fitted on the channel, thin's board 15 m away (its H's strokes
# 1.3 px, blurred) posed 8-10 % off and found 0.14-0.18 of its edges; placed by its
# outline on its chroma (stepping 35-55 against the channel's 20), 0.8-2.7 %.
CHROMA_PLACED = 0.8
# ... looked for this far (view pixels) from where the H's fit puts it: on the view
# enlarged twice, 3 px left two of one such board's sides unfound.
CHROMA_SEARCH_PX = 6.0
MIN_BOARD_SHARE = 0.3  # of the quadrilateral, at the board's level (not the mark's)
_QUAD_EPS = 0.06  # Douglas-Peucker tolerance, of the hull's perimeter
_FILL = (0.75, 1.25)  # the grown board's area over its quadrilateral's
_ROUND_FILL = (0.85, 1.15)  # ... over its ellipse's
_ROUND_TOL = 0.12  # 90 % of a round board's outline lies this near its ellipse (of its radius)
ROUND_TURNS = 12  # a round board's pad fitted from this many turns (each 15 degrees near)
ROUND_TURN_REACH = 16.0  # ... then turned to its H's pattern, this far either way at most
_CHROMA_MARGIN = 8  # pixels of the view around a board's outline read on its chroma
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
_NEAR, _CORE = np.ones((5, 5), np.uint8), np.ones((9, 9), np.uint8)  # the rings' reach


@dataclass(frozen=True)
class Board:
    """A quadrilateral (view pixels, 4 x 2, clockwise on screen) and how far its
    level stands from the floor's; for a ``round`` board, the rectangle around its
    ellipse."""

    quad: np.ndarray
    contrast: float
    round: bool = False


def find_boards(
    levels: np.ndarray,
    shapes: list[Region],
    reference: Reference,
    enlarged: float,
    holes: Sequence[Region] = (),
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None = None,
    mask: np.ndarray | None = None,
) -> list[np.ndarray]:
    """Homographies (pad metres -> view pixels) of the pads found by their boards,
    best pattern first, on a view's smoothed channel (``levels``), around its
    regions of the H's polarity (``shapes``, `pipeline.find.search`'s, the marks of
    its ``mask``: the most alone of them as well as the largest) and where
    the threshold left a board whole, a hole of its mask (``holes``) or, a board as
    light as the H, one of the regions itself; ``enlarged``:
    view pixels per frame pixel; ``chroma``: the view's box (x0, y0, x1, y1) read on the
    board's chroma (`pipeline.preprocess.chroma_levels`), made when asked for."""
    rounded = reference.round_board
    if not reference.board_is_outline and rounded is None:
        return []
    # How far around a mark the size of the H each board reaches: the pad's outline, the
    # round board's.
    ratio = reference.pad_over_h if reference.board_is_outline else None
    round_ratio = None if rounded is None else 2.0 * rounded.seen_m / reference.h_size_m
    ratios = [r for r in (ratio, round_ratio) if r is not None]
    # The marks of the H's polarity small enough for their H to be missed, and large
    # enough for a board the size of MIN_BOARD_PX around them; on a textured floor
    # (a thousand of them) the largest first, MAX_SEEDS of them. Then the largest
    # marks whose pad fits in the view, MAX_LARGE_SEEDS of them: an H a glare spoilt
    # (on the real-world mix's views a glare on the H, or a smear joining it to the
    # bars beside it, lost 1-4 of 40 pads per design whose board stood out whole).
    most = MISSED_H_PX * enlarged
    least = max(MIN_SEED_PX, MIN_BOARD_PX * enlarged / (2.0 * max(ratios)))
    widest = min(levels.shape) / (1.5 * min(ratios))
    small, large = [], []
    for region in shapes:
        size = region.span
        if least <= size <= most:
            small.append(region)
        elif most < size <= widest:
            large.append(region)
    small.sort(key=lambda r: -r.area)
    large.sort(key=lambda r: -r.area)
    seeds = small[:MAX_SEEDS] + large[:MAX_LARGE_SEEDS]
    if mask is not None and len(small) > MAX_SEEDS:
        seeds += _lone(small[MAX_SEEDS:], mask, LONE_REACH * min(ratios))[:MAX_LONE_SEEDS]
    least_board = MIN_BOARD_PX * enlarged
    grown = [
        board
        for seed in seeds
        for board in _grow_boards(
            levels, seed, ratio, least_board, round_ratio=round_ratio, chroma=chroma
        )
    ]
    whole = [] if ratio is None else [
        _board_whole(levels, hole, least_board, widest * ratio)
        for hole in sorted(holes, key=lambda r: -r.area)
    ]  # fmt: skip
    if ratio is not None and reference.outline_bright:
        # (serif_octagon's sheet 15 m away: its H, inside the octagon, no region at all)
        whole += [
            _board_whole(levels, shape, least_board, widest * ratio, bright=True)
            for shape in sorted(shapes, key=lambda r: -r.area)
        ]
    boards: list[Board] = []
    for board in grown + [b for b in whole if b is not None]:
        if not any(b.round == board.round and _same(board.quad, b.quad) for b in boards):
            boards.append(board)
    boards.sort(key=lambda b: -b.contrast)
    found = []
    edges = _board_outlines(reference)
    for board in boards[:MAX_BOARDS]:
        if board.round and rounded is not None:
            starts = _round_starts(board.quad, reference, rounded.centre_m, rounded.seen_m)
            outline = rounded.mark
        else:
            starts, outline = _quad_starts(board.quad, edges), _outline_mark(reference)
        fitted = _fit_board(
            levels, reference, starts, outline, enlarged, round_board=board.round, chroma=chroma
        )
        if fitted is not None:
            found.append(fitted)
    found.sort(key=lambda f: -f[0])
    return [H for _, H in found]


def _lone(marks: list[Region], mask: np.ndarray, reach: float) -> list[Region]:
    """``marks`` the most alone first: by the share of ``mask`` set around each, over
    a box ``reach`` times its size from its centre (the mark's own box left out)."""
    counts = cv2.integral(mask)  # (set is 255: the shares' order is the same)
    h_img, w_img = mask.shape
    scored = []
    for mark in marks:
        x, y, w, h = mark.box
        half = reach * mark.span
        x0, y0 = max(int(x + 0.5 * w - half), 0), max(int(y + 0.5 * h - half), 0)
        x1, y1 = min(int(x + 0.5 * w + half), w_img), min(int(y + 0.5 * h + half), h_img)
        around = _box_count(counts, x0, y0, x1, y1) - _box_count(counts, x, y, x + w, y + h)
        cells = (x1 - x0) * (y1 - y0) - w * h
        scored.append((around / max(cells, 1), -mark.area))
    order = sorted(range(len(marks)), key=scored.__getitem__)
    return [marks[i] for i in order]


def _box_count(counts: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> int:
    return int(counts[y1, x1] - counts[y0, x1] - counts[y1, x0] + counts[y0, x0])


def _grow_boards(
    levels: np.ndarray,
    mark: Region,
    ratio: float | None,
    min_px: float,
    *,
    round_ratio: float | None = None,
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None = None,
) -> list[Board]:
    """The board around a mark, grown two ways, where it is a quadrilateral the pad's
    size for the mark (``ratio``: the pad's width over the H's; None: no square board)
    or an ellipse the round board's (``round_ratio``: its width over the H's; see
    `_board_ellipse`); on ``levels``, and on the board's ``chroma`` where it has one
    (see `find_boards`): on grass, thin's blue board 15 m away stood 20-25 levels from
    the floor on its H's channel, under a noise of 16-21, and grew nowhere.

    Between a light H and a dark board (or the reverse) the blur crosses the floor's
    level, so the board is not simply the pixels off the floor's level. It is grown
    from its level right next to the mark (which holds where the board is narrow
    around its H), and from its core's level a little further out, bridged to the
    mark across the blur and its holes filled (which holds where the floor's blotches
    come near the level next to the mark). Either may fail where the other does not.
    """
    x, y, w, h = mark.box
    size = float(max(w, h))
    if size < MIN_SEED_PX:
        return []
    # A window with room for the whole pad around its H, and some floor.
    half = int(0.75 * max(r for r in (ratio, round_ratio) if r is not None) * size) + 4
    cx, cy = (2 * x + w - 1) // 2, (2 * y + h - 1) // 2  # (the box's centre, floored)
    # (cut by the view's edge: a board that reaches it is refused as running into it)
    x0, y0 = max(cx - half, 0), max(cy - half, 0)
    win = levels[y0 : cy + half + 1, x0 : cx + half + 1]
    if min(win.shape) < 2 * MIN_SEED_PX + 4:
        return []
    seed = np.zeros(win.shape, np.uint8)
    cv2.fillPoly(seed, [(mark.contour - [x0, y0]).astype(np.int32).reshape(-1, 1, 2)], 1)
    near = cv2.dilate(seed, _NEAR) & (1 - seed)
    core = cv2.dilate(seed, _CORE) & (1 - seed)
    wins = [win]
    if chroma is not None:
        # (the board's chroma, the floor's greys and other hues 0 and below: a level)
        box = (x0, y0, x0 + win.shape[1], y0 + win.shape[0])
        wins.append(np.clip(chroma(box) + 0.5, 0.0, 255.0).astype(np.uint8))
    at = np.array([x0, y0], np.float64)
    boards = []
    for win in wins:
        boards += _boards_in(win, seed, near, core, size, ratio, round_ratio, min_px, at)
    return boards


def _boards_in(
    win: np.ndarray,
    seed: np.ndarray,
    near: np.ndarray,
    core: np.ndarray,
    size: float,
    ratio: float | None,
    round_ratio: float | None,
    min_px: float,
    at: np.ndarray,
) -> list[Board]:
    """`_grow_boards` on one window of levels (``at``: its corner in the view)."""
    floor, noise = _floor_and_noise(win, 2)
    boards = []
    for ring, percent, bridged in ((near, 10.0, False), (core, 5.0, True)):
        # The board's level: beyond the H's blur (a median, the H's light blurred
        # into it, would set the threshold toward the floor's).
        contrast = _ring_contrast(win, ring, percent, floor)
        if contrast < MIN_BOARD_CONTRAST or noise > MAX_FLOOR_NOISE * contrast:
            continue
        grown = (np.abs(win - floor) > 0.5 * contrast).astype(np.uint8)
        # (opened: the floor's noise joins a low-contrast board by threads a pixel wide)
        grown = cv2.morphologyEx(grown, cv2.MORPH_OPEN, _CROSS)
        if bridged:
            part = _part_with(grown | near | seed, seed, fill=True)
        else:
            part = _part_with(grown | seed, near, fill=False)
        quad = None if ratio is None else _board_quad(part, seed, size, ratio, min_px)
        if quad is not None:
            boards.append(Board(quad + at, contrast))
        ellipse = (
            None if round_ratio is None else _board_ellipse(part, seed, size, round_ratio, min_px)
        )
        if ellipse is not None:
            boards.append(Board(ellipse + at, contrast, round=True))
    return boards


def _board_whole(
    levels: np.ndarray, region: Region, min_px: float, max_px: float, *, bright: bool = False
) -> Board | None:
    """The board a hole of the mask is (or, ``bright``, a region of it), when it is a
    quadrilateral between ``min_px`` and ``max_px`` wide that stands out of the floor
    around it.

    A board darker than its floor on the channel (the H's paint bright) is left
    whole by the local threshold: the floor right around it reads lighter than its
    local mean, a halo with the board for its hole, where the H inside, its strokes a
    pixel wide, is lost (paper_ring's sheet from 5 m on at 640 x 480). A board as
    light as the H (`Reference.outline_bright`) is a region of the mask itself, and
    stands out by its lightest tenth (its dark octagon with the H, most of it, the
    octagon's hole).
    """
    x, y, w, h = region.box
    span = float(max(w, h))
    if not min_px <= span <= max_px:
        return None
    quad = _quad_of(region.contour.reshape(-1, 1, 2).astype(np.int32))
    if quad is None or not _FILL[0] <= region.area / _area(quad) <= _FILL[1]:
        return None
    # Its level against the floor's, in a window with a margin of floor around it.
    m = int(0.25 * span) + 3
    x0, y0 = max(x - m, 0), max(y - m, 0)
    win = levels[y0 : y + h + m, x0 : x + w + m]
    floor, noise = _floor_and_noise(win, 2)
    inside = np.zeros(win.shape, np.uint8)
    cv2.fillPoly(inside, [np.rint(quad - [x0, y0]).astype(np.int32)], 1)
    inside = cv2.erode(inside, _CROSS, iterations=2)
    if not inside.any():
        return None
    if bright:
        contrast = float(np.percentile(win[inside > 0], 90.0)) - floor
    else:
        contrast = abs(float(np.median(win[inside > 0])) - floor)
    if contrast < MIN_BOARD_CONTRAST or noise > MAX_FLOOR_NOISE * contrast:
        return None
    return Board(_clockwise(quad), contrast)


@compiled
def _floor_and_noise(win, width):
    """The floor's level around a window (the median of its border band ``width``
    pixels wide, corners twice) and its noise (1.4826 times the median absolute
    deviation from it): ``np.median``'s numbers, by counting the uint8 levels."""
    h, w = win.shape
    counts = np.zeros(256, np.int64)
    for rows in (range(width), range(h - width, h)):
        for y in rows:
            for x in range(w):
                counts[win[y, x]] += 1
    for y in range(h):
        for cols in (range(width), range(w - width, w)):
            for x in cols:
                counts[win[y, x]] += 1
    n = counts.sum()
    floor = _median_of_counts(counts, n)
    half = n // 2
    mad = _kth_deviation(counts, floor, half)
    if not n % 2:
        mad = (_kth_deviation(counts, floor, half - 1) + mad) / 2.0
    return floor, 1.4826 * mad


@compiled
def _kth_deviation(counts, floor, k):
    """The ``k``-th smallest (from 0) of the counted levels' distances to ``floor``:
    the levels nearest it taken first, from either side."""
    below = math.floor(floor)  # (the nearest level at or under the floor)
    above = below + 1
    seen = 0
    while True:
        d_below = floor - below if below >= 0 else math.inf
        d_above = above - floor if above < len(counts) else math.inf
        if d_below <= d_above:
            seen += counts[below]
            if seen > k:
                return d_below
            below -= 1
        else:
            seen += counts[above]
            if seen > k:
                return d_above
            above += 1


@compiled
def _ring_contrast(win, ring, percent, floor):
    """How far the levels of ``win`` on ``ring`` stand from ``floor``: their
    ``percent`` percentile's distance when their median is darker than the floor,
    else their 100 - ``percent`` percentile's (linear, ``np.percentile``'s numbers);
    0 on an empty ring."""
    h, w = win.shape
    counts = np.zeros(256, np.int64)
    for y in range(h):
        for x in range(w):
            if ring[y, x]:
                counts[win[y, x]] += 1
    n = counts.sum()
    if n == 0:
        return 0.0
    q = percent if _median_of_counts(counts, n) < floor else 100.0 - percent
    # numpy's linear interpolation between the two order statistics around the position
    pos = (n - 1) * (q / 100.0)
    lo = math.floor(pos)
    if lo >= n - 1:
        return abs(float(_kth_of_counts(counts, n - 1)) - floor)
    a = float(_kth_of_counts(counts, lo))
    b = float(_kth_of_counts(counts, lo + 1))
    t = pos - lo
    level = b - (b - a) * (1.0 - t) if t >= 0.5 else a + (b - a) * t
    return abs(level - floor)


@compiled
def _median_of_counts(counts, n):
    """The median of ``n`` uint8 levels counted per level (``np.median``'s number)."""
    half = n // 2
    if n % 2:
        return float(_kth_of_counts(counts, half))
    return (float(_kth_of_counts(counts, half - 1)) + float(_kth_of_counts(counts, half))) / 2.0


@compiled
def _kth_of_counts(counts, k):
    """The ``k``-th smallest (from 0) of the levels counted per level."""
    seen = 0
    for v in range(len(counts)):
        seen += counts[v]
        if seen > k:
            return v
    return len(counts) - 1


def _part_with(grown: np.ndarray, voters: np.ndarray, *, fill: bool) -> np.ndarray:
    """The component of ``grown`` most of the ``voters`` pixels lie in, its holes
    filled when ``fill``."""
    if fill:
        count, labels = cv2.connectedComponents(1 - grown, connectivity=4)
        inside = np.ones(count, bool)
        inside[0] = False
        inside[np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])] = False
        grown = grown | inside[labels].astype(np.uint8)
    count, labels = cv2.connectedComponents(grown, connectivity=8)
    votes = np.bincount(labels[voters > 0], minlength=count)
    votes[0] = 0
    return (labels == int(np.argmax(votes))).astype(np.uint8)


def _board_quad(
    part: np.ndarray, seed: np.ndarray, size: float, ratio: float, min_px: float
) -> np.ndarray | None:
    """The grown board's quadrilateral (window pixels, clockwise), when it is one,
    inside the window, the pad's size for a mark of ``size``."""
    if part[0].any() or part[-1].any() or part[:, 0].any() or part[:, -1].any():
        return None  # it runs into the floor: no board's edge all round
    outlines, _ = cv2.findContours(part, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(outlines, key=cv2.contourArea)
    quad = _quad_of(outline)
    if quad is None:
        return None
    quad_area = _area(quad)
    fill = cv2.contourArea(outline) / quad_area
    # The board itself, beside the mark: an H's own outline is a quadrilateral too.
    board_share = np.count_nonzero(part & (1 - seed)) / quad_area
    span = float(np.ptp(quad, axis=0).max())
    if not _FILL[0] <= fill <= _FILL[1] or board_share < MIN_BOARD_SHARE:
        return None
    if span < min_px or not _pad_sized(span, size, ratio):
        return None
    return _clockwise(quad)


def _board_ellipse(
    part: np.ndarray, seed: np.ndarray, size: float, ratio: float, min_px: float
) -> np.ndarray | None:
    """The rectangle around the grown board's ellipse (window pixels, clockwise), when
    the board is one, inside the window, the round board's size for a mark of ``size``
    (``ratio``: its width over the H's)."""
    if part[0].any() or part[-1].any() or part[:, 0].any() or part[:, -1].any():
        return None  # it runs into the floor: no board's edge all round
    outlines, _ = cv2.findContours(part, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(outlines, key=cv2.contourArea)
    if len(outline) < 5:
        return None
    ellipse = cv2.fitEllipse(outline)
    (cx, cy), (w, h), angle = ellipse
    area = math.pi * w * h / 4.0
    if min(w, h) <= 0.0 or not _ROUND_FILL[0] <= cv2.contourArea(outline) / area <= _ROUND_FILL[1]:
        return None
    # Its outline on the ellipse: a square's corners stand 19 % beyond the ellipse
    # fitted to it, its sides' middles 15 % within.
    if ellipse_misfit(outline, ellipse) > _ROUND_TOL:
        return None
    t = math.radians(angle)
    u = np.array([math.cos(t), math.sin(t)])
    v = np.array([-math.sin(t), math.cos(t)])
    if np.count_nonzero(part & (1 - seed)) / area < MIN_BOARD_SHARE:
        return None
    span = float(max(w, h))
    if span < min_px or not _pad_sized(span, size, ratio):
        return None
    c, u, v = np.array([cx, cy]), u * w / 2.0, v * h / 2.0
    return _clockwise(np.array([c - u - v, c + u - v, c + u + v, c - u + v]))


def _quad_of(outline: np.ndarray) -> np.ndarray | None:
    """The quadrilateral (4 x 2, float) that an outline's (N x 1 x 2 int32) convex hull
    makes, or None when it makes none."""
    hull = cv2.convexHull(outline)
    quad = cv2.approxPolyDP(hull, _QUAD_EPS * cv2.arcLength(hull, True), True)
    return quad.reshape(4, 2).astype(np.float64) if len(quad) == 4 else None


def _area(quad: np.ndarray) -> float:
    """A polygon's area (at least a tiny one: it divides)."""
    return max(float(cv2.contourArea(quad.astype(np.float32))), 1e-9)


def _pad_sized(span: float, mark: float, ratio: float) -> bool:
    """Whether a board this wide can hold an H of the mark's size (a mark may be
    the whole H, a leg of it or, blurred, the H with a bar)."""
    return 0.5 * ratio * mark <= span <= 2.0 * ratio * mark


def _quad_starts(quad: np.ndarray, edges: list[np.ndarray]) -> list[np.ndarray]:
    """The pad put on a quadrilateral board (view pixels, clockwise) in each of its four
    turns, taken for each of the board's ``edges`` (`_board_outlines`)."""
    return [
        cv2.getPerspectiveTransform(
            edge.astype(np.float32), np.roll(quad, -turn, axis=0).astype(np.float32)
        ).astype(np.float64)
        for edge, turn in itertools.product(edges, range(4))
    ]


def _round_starts(
    quad: np.ndarray, reference: Reference, centre_m: np.ndarray, radius_m: float
) -> list[np.ndarray]:
    """The pad put on a round board (``quad``: the rectangle around its ellipse, view
    pixels, clockwise; its circle at ``centre_m``, ``radius_m``) at each of
    ``ROUND_TURNS`` turns: a circle seen at a slant is an ellipse, the same at every
    turn of the pad about its centre."""
    # The ellipse's half axes, its points centre + a cos t + b sin t.
    A = np.column_stack([(quad[1] - quad[0]) / 2.0, (quad[2] - quad[1]) / 2.0])
    # (the pad's box comes out clockwise on screen, as a square board's does)
    if np.sign(np.linalg.det(A)) != np.sign(signed_area(pad_box_m(reference))):
        A = A @ np.diag([1.0, -1.0])
    starts = []
    for k in range(ROUND_TURNS):
        t = 2.0 * math.pi * k / ROUND_TURNS
        turn = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        M = A @ turn / radius_m
        H = np.eye(3)
        H[:2, :2] = M
        H[:2, 2] = quad.mean(axis=0) - M @ centre_m
        starts.append(H)
    return starts


def _fit_board(
    levels: np.ndarray,
    reference: Reference,
    starts: list[np.ndarray],
    outline_mark: int | None,
    enlarged: float = 1.0,
    *,
    round_board: bool = False,
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None = None,
) -> tuple[float, np.ndarray] | None:
    """The pad fitted from each of the board's ``starts`` (homographies, pad metres ->
    view pixels): the best pattern's (NCC, homography), when it is the pad's
    (``enlarged``: view pixels per frame pixel); on a ``round_board``, turned to its
    H's pattern (`_turned_to_pattern`). Some of the board's outline (``outline_mark``,
    of the reference's marks; None: it has none) must be found, on the channel or on
    the board's ``chroma`` (see `find_boards`) where the channel hardly shows it."""
    box = pad_box_m(reference)
    h_sides = np.arange(len(reference.edge_model.polygon)) < len(reference.corners_m)
    outline = None if outline_mark is None else reference.edge_model.polygon == 1 + outline_mark
    best: tuple[float, np.ndarray] | None = None
    for start in starts:
        fit = fit_homography(
            levels, reference.edge_model, start, iterations=3, search_px=3.0, sides_alike=False
        )
        if fit is None:
            continue
        if (
            outline is not None
            and _found_share(fit.side_found[outline]) < MIN_OUTLINE_FOUND
            and not _outline_in_chroma(chroma, reference, fit.H, outline_mark)
        ):
            continue
        # So small a pad shows no perspective: the fit's is its noise, which skewed
        # the pose by up to 40 % of the altitude. Its affine part is kept.
        H = affine_part(fit.H, np.zeros(2))
        ncc = pad_pattern(levels, reference.template_pyramid, reference.channel_px_per_m, box, H)
        if not math.isfinite(ncc):
            continue
        # (an H too small for any of its sides to be told is no evidence)
        sides = _found_share(fit.side_found[h_sides]) >= MIN_H_FOUND and ncc >= MIN_BOARD_NCC
        stroke = reference.leg_fraction * span_of(apply_h(H, reference.corners_m)) / enlarged
        bar = MIN_FINE_H_NCC if stroke < FINE_STROKE_PX else MIN_H_NCC
        if (sides or _h_pattern(levels, reference, H) >= bar) and (best is None or ncc > best[0]):
            best = (ncc, H)
    if best is not None and round_board:
        best = (best[0], _turned_to_pattern(levels, reference, best[1]))
    if best is not None and _turn_untold(levels, reference, best[1]):
        return None
    if best is not None and not round_board:
        best = (best[0], _placed_by_chroma(chroma, reference, best[1]))
    return best


def _turned_to_pattern(levels: np.ndarray, reference: Reference, H: np.ndarray) -> np.ndarray:
    """``H`` turned about the H's centre to where the H's pattern matches best (within
    ``ROUND_TURN_REACH`` degrees, to a degree): on a round board only the H tells the
    pad's turn, and so small its edges hardly do (orange_ring's far poses came 5-12
    degrees off, by up to 14 % of the altitude, where a turn of 8-16 matched better)."""
    centre = reference.h_centre_m
    best, score = 0.0, _h_pattern(levels, reference, H)
    for step in (4.0, 2.0, 1.0):
        reach = ROUND_TURN_REACH if step == 4.0 else step
        for deg in np.arange(best - reach, best + reach + 1e-9, step):
            ncc = _h_pattern(levels, reference, H @ turn_about(centre, float(deg)))
            if ncc > score:  # (nan, too little in view, never wins)
                best, score = float(deg), ncc
    return H @ turn_about(centre, best)


def _turn_untold(levels: np.ndarray, reference: Reference, H: np.ndarray) -> bool:
    """Whether the pad turned a quarter round either way matches the H's pattern about as
    well as ``H`` (within ``QUARTER_MARGIN``): so small, the H does not tell which of
    its board's turns is the pad's (nor, with it, where the camera is over the pad)."""
    own = _h_pattern(levels, reference, H)
    centre = pad_box_m(reference).mean(axis=0)
    return any(
        not _h_pattern(levels, reference, H @ turn_about(centre, 90.0 * sign))
        < own - QUARTER_MARGIN
        for sign in (1.0, -1.0)
    )


def _board_outlines(reference: Reference) -> list[np.ndarray]:
    """Where a board grown around the H may stop (4 x 2 metres, in `pad_box_m`'s order):
    the pad's outer edge, and each mark that is a quadrilateral around the H. A border
    band inset in a margin of the board's colour stops it at the band's inner edge where
    the band stands apart (a glare on it, in 1 of 30 views of a probe pad): taken for
    the pad's outer edge, that edge posed the pad 13 % too far."""
    box = pad_box_m(reference)
    out = [box]
    for mark in reference.marks:
        poly = mark.corners_m.astype(np.float32)
        if mark.rim or len(poly) < 4:
            continue
        quad = cv2.approxPolyDP(poly, _QUAD_EPS * cv2.arcLength(poly, True), True).reshape(-1, 2)
        if (
            len(quad) != 4
            or not _FILL[0] <= cv2.contourArea(poly) / max(cv2.contourArea(quad), 1e-12) <= _FILL[1]
        ):
            continue
        if any(
            cv2.pointPolygonTest(poly, (float(x), float(y)), False) <= 0
            for x, y in reference.corners_m
        ):
            continue
        # (its corners in the box's order: each the one farthest toward the box's corner)
        centred = quad - quad.mean(axis=0)
        order = [int(np.argmax(centred @ corner)) for corner in box]
        if len(set(order)) == 4:
            out.append(quad[order].astype(np.float64))
    return out


def _h_pattern(levels: np.ndarray, reference: Reference, H: np.ndarray) -> float:
    """The correlation of the view with the reference over the H's box and a margin
    (`template.pattern_box`), nan when too little of it is in view."""
    around = pattern_box(reference.corners_m)
    return pad_pattern(levels, reference.template_pyramid, reference.channel_px_per_m, around, H)


def _outline_mark(reference: Reference) -> int | None:
    """The board's outline among the reference's marks: its outermost (of those not
    faint: on the enlarged far view their edges are lost), or None when it has none."""
    spans = [-1.0 if m.faint else float(np.ptp(m.corners_m, axis=0).max()) for m in reference.marks]
    if not spans or max(spans) < 0:
        return None
    return int(np.argmax(spans))


def _outline_in_chroma(
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None,
    reference: Reference,
    H: np.ndarray,
    k: int | None,
) -> bool:
    """Whether the board's outline (mark ``k``) is found (``MIN_OUTLINE_FOUND`` of it)
    where ``H`` puts it on the board's chroma (bright inside the board; see
    `find_boards`): on grass, thin's blue board stepped 20-25 levels on its H's channel
    against a noise of 6-14, and none of its outline was found where, 8.7-10.9 m away,
    its faint H was refused; on its chroma it steps some 60."""
    return k is not None and _chroma_support(chroma, reference, H, k) >= MIN_OUTLINE_FOUND


def chroma_outline_found(
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None,
    reference: Reference,
    H: np.ndarray,
) -> float:
    """The share of a square board's outline found where ``H`` (pad metres -> view
    pixels) puts it on the board's chroma; 0 where it is not read so (no chroma, a
    round board, put off the view)."""
    k = _square_outline(reference)
    return 0.0 if k is None else _chroma_support(chroma, reference, H, k)


def _placed_by_chroma(
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None,
    reference: Reference,
    H: np.ndarray,
) -> np.ndarray:
    """``H`` refitted, affine, to its square board's outline on the board's chroma,
    where it finds ``CHROMA_PLACED`` of it there; else ``H`` itself."""
    k = _square_outline(reference)
    read = None if k is None else _chroma_around(chroma, reference, H, k)
    if k is None or read is None:
        return H
    levels, shift = read
    model = _outline_model(reference, k)
    fit = fit_homography(
        levels, model, shift @ H, iterations=3, search_px=CHROMA_SEARCH_PX, sides_alike=False
    )
    if fit is None:
        return H
    placed = affine_part(fit.H, np.zeros(2))  # (as `_fit_board`'s: so small, no perspective)
    if support(levels, model, placed) < CHROMA_PLACED:
        return H
    return np.linalg.inv(shift) @ placed


def _square_outline(reference: Reference) -> int | None:
    """The board's outline among the reference's marks where the board is square."""
    return None if reference.round_board is not None else _outline_mark(reference)


def _chroma_support(
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None,
    reference: Reference,
    H: np.ndarray,
    k: int,
) -> float:
    """The share of mark ``k``'s outline found where ``H`` puts it on the board's chroma."""
    read = _chroma_around(chroma, reference, H, k)
    if read is None:
        return 0.0
    levels, shift = read
    return support(levels, _outline_model(reference, k), shift @ H)


def _chroma_around(
    chroma: Callable[[tuple[int, int, int, int]], np.ndarray] | None,
    reference: Reference,
    H: np.ndarray,
    k: int,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The board's chroma in a box around where ``H`` puts mark ``k``, and the shift
    from the view's pixels to the box's; None where there is none to read."""
    if chroma is None:
        return None
    px = apply_h(H, reference.marks[k].corners_m)
    if not np.isfinite(px).all():
        return None
    x0, y0 = np.floor(px.min(axis=0)).astype(int) - _CHROMA_MARGIN
    x1, y1 = np.ceil(px.max(axis=0)).astype(int) + _CHROMA_MARGIN
    x0, y0 = max(int(x0), 0), max(int(y0), 0)
    if x1 <= x0 or y1 <= y0:
        return None  # (put off the view)
    levels = chroma((x0, y0, int(x1), int(y1)))
    if min(levels.shape) < 2 * _CHROMA_MARGIN:
        return None
    return levels, np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])


@functools.lru_cache(maxsize=8)
def _outline_model(reference: Reference, k: int) -> EdgeModel:
    """Mark ``k``'s sides alone, bright inside (as the board is on its chroma): one per
    reference, not one per fit."""
    return EdgeModel.from_polygons([(reference.marks[k].corners_m, True)])


def _found_share(found: np.ndarray) -> float:
    """The mean share found of the sides that could be told (NaN: too short or too
    close to another at this size); 0 when none could."""
    told = found[np.isfinite(found)]
    return float(told.mean()) if len(told) else 0.0


def _clockwise(quad: np.ndarray) -> np.ndarray:
    """The corners in the pad box's order on screen (y down: clockwise)."""
    c = quad.mean(axis=0)
    return quad[np.argsort(np.arctan2(quad[:, 1] - c[1], quad[:, 0] - c[0]))]


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return (
        float(np.abs(a.mean(axis=0) - b.mean(axis=0)).max()) <= 2.0
        and float(abs(np.ptp(a, axis=0).max() - np.ptp(b, axis=0).max())) <= 2.0
    )
