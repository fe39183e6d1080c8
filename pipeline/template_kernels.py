"""The pattern comparison's pixel statistics, compiled (``pipeline.jit``).

``pipeline.template.compare`` reads a patch of about 96 x 96 pixels a dozen
ways (masked means, two percentiles, the board's and the paint's pixels, each
board pixel against its nearest paint, medians); written as numpy expressions,
each was a few calls on arrays of a few thousand pixels whose overhead took
half the comparison's time. The arithmetic is numpy's: float32 where numpy's
was float32 (each result rounded to float32 as numpy's operation rounds it),
the same order statistics, the same medians.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.jit import column_medians, compiled


@compiled
def masked_ncc(a, b, mask):
    """Normalised cross-correlation of two float32 images over ``mask`` (nan when
    either is flat there), summed in float64."""
    h, w = mask.shape
    n = 0
    sa = 0.0
    sb = 0.0
    for y in range(h):
        for x in range(w):
            if mask[y, x]:
                n += 1
                sa += a[y, x]
                sb += b[y, x]
    if n == 0:
        return math.nan
    ma, mb = sa / n, sb / n
    aa = 0.0
    bb = 0.0
    ab = 0.0
    for y in range(h):
        for x in range(w):
            if mask[y, x]:
                da = a[y, x] - ma
                db = b[y, x] - mb
                aa += da * da
                bb += db * db
                ab += da * db
    den = math.sqrt(aa * bb)
    return ab / den if den > 1e-9 else math.nan


@compiled
def board_and_paint(pick, around, near, low_q, high_q, share):
    """Which pixels are board and which paint, by the reference's own levels
    (``pick``): the board those of ``around`` within ``share`` of the levels'
    spread above their ``low_q`` percentile (linear, as ``np.percentile``), the paint
    those of ``near`` within it below their ``high_q`` percentile. Returns the two
    masks and the paint's complement as uint8 (1 off the paint, what a distance
    transform measures from)."""
    h, w = pick.shape
    values = np.empty(h * w, np.float32)
    n = 0
    for y in range(h):
        for x in range(w):
            if around[y, x]:
                values[n] = pick[y, x]
                n += 1
    low, high = _percentiles(values[:n], low_q, high_q)
    spread = high - low
    top_of_board = low + share * spread
    foot_of_paint = high - share * spread
    board = np.zeros((h, w), np.bool_)
    paint = np.zeros((h, w), np.bool_)
    off_paint = np.ones((h, w), np.uint8)
    for y in range(h):
        for x in range(w):
            v = float(pick[y, x])
            if around[y, x] and v <= top_of_board:
                board[y, x] = True
            if near[y, x] and v >= foot_of_paint:
                paint[y, x] = True
                off_paint[y, x] = 0
    return board, paint, off_paint


@compiled
def _percentiles(values, q_low, q_high):
    """``np.percentile(values, (q_low, q_high))`` (linear) of float32 values (n >= 1),
    in float64, from one partial sort."""
    n = len(values)
    pos = np.array([q_low, q_high]) / 100.0 * (n - 1)
    lo = np.floor(pos).astype(np.int64)
    hi = np.minimum(lo + 1, n - 1)
    part = np.partition(values, np.array([lo[0], hi[0], lo[1], hi[1]]))
    out = np.empty(2)
    for k in range(2):
        step = np.float32(float(part[hi[k]]) - float(part[lo[k]]))  # (numpy's float32 difference)
        out[k] = float(part[lo[k]]) + float(step) * (pos[k] - lo[k])
    return out[0], out[1]


@compiled
def board_levels(frame_px, ref_px, lumas, board, paint, labels, max_pixels):
    """The board's and the paint's colours and the board's brightness relative to its
    nearest paint, in the frame and on the reference.

    ``frame_px`` (N x 3) and ``ref_px`` (N x 4: B, G, R, channel) are the patch's
    pixels (float32) in raster order, ``lumas`` (N x 2) their lumas in the frame and
    on the reference, ``board``/``paint`` (N) the masks, ``labels`` (N) the label of
    each pixel's nearest paint pixel (``cv2.distanceTransformWithLabels``'s per pixel,
    numbered from 1 in raster order). Returns the board's median B, G, R in the frame
    (over at most ``max_pixels`` of its pixels, evenly strided) and on the reference,
    the paint's in the frame, and the median over the board of its luma over the
    brighter of it and its nearest paint, in the frame and on the reference.
    """
    on_board = np.flatnonzero(board)
    on_paint = np.flatnonzero(paint)
    stride = max(1, -(-len(on_board) // max_pixels))
    some = on_board[::stride]
    colours = np.empty((len(some), 6), np.float32)
    for k in range(len(some)):
        i = some[k]
        for c in range(3):
            colours[k, c] = frame_px[i, c]
            colours[k, 3 + c] = ref_px[i, c]
    board_bgr = column_medians(colours)
    paint_rows = np.empty((len(on_paint), 3), np.float32)
    for k in range(len(on_paint)):
        for c in range(3):
            paint_rows[k, c] = frame_px[on_paint[k], c]
    paint_bgr = column_medians(paint_rows)
    # A shadow across the pad darkens a board pixel and its paint alike.
    ratios = np.empty((len(on_board), 2), np.float32)
    one = np.float32(1.0)
    for k in range(len(on_board)):
        i = on_board[k]
        j = on_paint[labels[i] - 1]
        for c in range(2):
            b, p = lumas[i, c], lumas[j, c]
            brighter = max(max(b, p), one)
            ratios[k, c] = np.float32(float(b) / float(brighter))
    relative = column_medians(ratios)
    return board_bgr[:3], board_bgr[3:], paint_bgr, relative[0], relative[1]
