"""Does the frame look like the reference picture where the H was located?

The reference picture (its colours and its learned channel) is warped into
the frame by the located homography, around the H, and compared in two ways:

- pattern: normalised cross-correlation of the channels over the H and a
  margin around it, which ignores exposure and contrast. A shape that fits
  the H's outline but differs inside or right around it scores low.
- whole pad: correlation of the channels over the pad's outline, for an H too
  small to find the pad's other marks by their edges.
- board: the colour of the board around the H, out to a good part of the H's
  size, against the reference's at the same places: its brightness relative
  to the H's paint nearest it (or to its own, whichever is brighter) and its
  hue. Read pixel by pixel against the nearest paint, the brightness holds
  under a shadow across the pad, which dims board and paint alike. The
  same H painted on a floor, or cut out of another pad, has floor around it:
  grass, asphalt, tiles, not the pad's black paint or orange fabric. Printing
  and light change the H's own shade far more than the board's relation to
  it, so the H's colour is not compared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.homography_fit import apply_h, span_of
from pipeline.jit import plain
from pipeline.template_kernels import board_and_paint, board_levels, masked_ncc

MARGIN = 0.15  # pattern: the H's bounding box grown by this much of its size
BOARD_REACH = 0.4  # board: out to this much of the H's size around its bounding box
MIN_SIDE_PX = 6  # frame patches smaller than this are not compared
MAX_SIDE_PX = 96  # larger ones are compared at this size
DARK_LUMA = 40.0  # a board this dark has no reliable hue
MAX_HUE_PIXELS = 1024  # the board's hue: its median over at most this many of its pixels
# A camera's response curve (a gamma) scales a colour's log-chromaticity, its hue kept:
# the frame's board is read through the curve, within this range, that makes it as
# saturated as the reference's. A board under this saturation (the log-chromaticity's
# length) has no hue for a curve to turn. On the shared photos' orange pads seen through
# the photos bench's exposures (gamma 0.6-1.6), boards came out 0.4-1.7 times as
# saturated as their references, their hue 0-18 degrees off (the camera's white balance);
# the floors that reached the comparison, grey or of another hue (160-170 degrees off).
EXPOSURE_CURVES = (0.5, 2.0)
MIN_SATURATION = 0.3
# A camera's pixel integrates light: the reference warped point by point is sharper
# than any frame, which matters to a pattern a few pixels across.
FRAME_BLUR_PX = 0.6
PICK_BLUR_PX = 1.0  # where the board's and the H's levels are read: pixels this blur leaves pure
PAIR_BLUR_PX = 1.0  # the levels read pixel by pixel, smoothed this much for the noise
_LUMA = np.array([0.114, 0.587, 0.299])
_LUMA_ROW = _LUMA[None].astype(np.float32)  # (cv2.transform's B, G, R -> luma)
_LUMA_ROW4 = np.append(_LUMA, 0.0)[None].astype(np.float32)  # (the 4th: the channel)


@dataclass(frozen=True)
class Comparison:
    """``ncc``: pattern correlation (-1..1). ``board``/``reference_board``: the
    board's luma over the brighter of it and the H's paint nearest it (median
    over the board), in the frame and on the reference. ``hue``: L1 distance of
    the board's chromaticity (r, g, b summing to 1) between frame and reference,
    the frame's exposure curve undone (see `_hue`), nan when either board is too
    dark to have one. ``paint``: the H's luma in the frame (0-255). All nan when
    the patch is too small or off the frame."""

    ncc: float
    board: float
    reference_board: float
    hue: float
    paint: float = math.nan


NOTHING = Comparison(math.nan, math.nan, math.nan, math.nan)


def reference_pyramid(image_bgr: np.ndarray, channel: np.ndarray, levels: int = 6):
    """The reference picture (B, G, R and its learned channel) at halving resolutions."""
    out = [np.dstack([image_bgr, channel]).astype(np.float32)]
    while len(out) < levels and min(out[-1].shape[:2]) >= 32:
        out.append(cv2.pyrDown(out[-1]))
    return tuple(out)


def compare(
    frame_bgr: np.ndarray,
    frame_channel: np.ndarray,
    pyramid: tuple[np.ndarray, ...],
    px_per_m: float,
    corners_m: np.ndarray,
    H: np.ndarray,
    enlarged: float = 1.0,
) -> Comparison:
    """Compare the frame with the reference around the located H.

    ``pyramid``: from `reference_pyramid` (level 0 at ``px_per_m`` pixels per
    metre, the pad's centre at the picture's centre). ``H``: pad metres ->
    frame pixels. ``frame_channel``: the frame on the reference's channel.
    ``enlarged``: how many of these pixels a camera pixel became (an enlarged
    view of the frame: its blur is as many pixels wide).
    """
    lo, hi = corners_m.min(axis=0), corners_m.max(axis=0)
    size = float((hi - lo).max())
    outer = _box(lo - BOARD_REACH * size, hi + BOARD_REACH * size)
    inner = pattern_box(corners_m)
    outer_px, inner_px = apply_h(H, outer), apply_h(H, inner)
    fh, fw = frame_channel.shape[:2]
    x0, y0 = np.floor(outer_px.min(axis=0)).astype(int)
    x1, y1 = np.ceil(outer_px.max(axis=0)).astype(int) + 1
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, fw), min(y1, fh)
    if x1 - x0 < MIN_SIDE_PX or y1 - y0 < MIN_SIDE_PX:
        return NOTHING
    # Large views are compared at most MAX_SIDE_PX across: enough for a pattern.
    f = min(1.0, MAX_SIDE_PX / max(x1 - x0, y1 - y0))
    frame_span = f * span_of(outer_px)
    ref_span = (1.0 + 2.0 * BOARD_REACH) * size * px_per_m
    shift = np.array([[f, 0.0, -f * x0], [0.0, f, -f * y0], [0.0, 0.0, 1.0]])
    dsize = (max(1, round(f * (x1 - x0))), max(1, round(f * (y1 - y0))))
    warped, seen = _warp(pyramid, px_per_m, ref_span / max(frame_span, 1.0), shift @ H, dsize)
    near = _polygon_mask(f * (inner_px - [x0, y0]), dsize) & seen
    around = _polygon_mask(f * (outer_px - [x0, y0]), dsize) & seen
    if np.count_nonzero(near) < MIN_SIDE_PX * MIN_SIDE_PX:
        return NOTHING
    ch_frame = _crop(frame_channel, x0, y0, x1, y1, dsize)
    ncc = masked_ncc(ch_frame, plain(warped[..., 3], np.float32), near)
    # The reference's own levels say which pixels are H and which are board
    # (the quarter nearest each end, leaving out the blurred edges between).
    if not around.any():  # a degenerate outline (a fuzzed or odd reference)
        return Comparison(ncc, math.nan, math.nan, math.nan)
    # Taken on the reference blurred as a camera's frame is, so that on a small view
    # they are the pixels that blur leaves pure (a board a few pixels wide between
    # the H and the pad's bars takes the paint's light a pixel out). A camera pixel
    # is ``f * enlarged`` of these pixels, and its blur as wide.
    camera_blur = PICK_BLUR_PX * f * enlarged
    pick = plain(_blurred(warped[..., 3], seen, camera_blur), np.float32)
    board, paint, off_paint = board_and_paint(pick, around, near, 5.0, 95.0, 0.25)
    if np.count_nonzero(board) < 8 or np.count_nonzero(paint) < 4:
        return Comparison(ncc, math.nan, math.nan, math.nan)
    # The frame's colours beside the reference's (the board's brightness, pixel by
    # pixel against the paint nearest it).
    frame_crop = _crop(frame_bgr, x0, y0, x1, y1, dsize)
    frame_luma = cv2.transform(frame_crop, _LUMA_ROW)
    reference_luma = cv2.transform(warped, _LUMA_ROW4)
    if camera_blur <= PAIR_BLUR_PX:
        lumas = _blurred(cv2.merge([frame_luma, reference_luma]), seen, PAIR_BLUR_PX)
    else:
        # An enlarged view's paint, a few pixels wide, is dimmed by the camera's blur
        # and its board lit by it: the reference is read as blurred, or its board reads
        # darker against its paint than any frame's (on the altitude sweep's 1280 x 720
        # frames at 28-40 m, 0.16 against 0.40-0.45, their pads turned down).
        lumas = cv2.merge(
            [_blurred(frame_luma, seen, PAIR_BLUR_PX), _blurred(reference_luma, seen, camera_blur)]
        )
    _, labels = cv2.distanceTransformWithLabels(
        off_paint, cv2.DIST_L2, 3, labelType=cv2.DIST_LABEL_PIXEL
    )
    b_f, b_r, p_f, level, reference_level = board_levels(
        frame_crop.reshape(-1, 3),
        warped.reshape(-1, 4),
        plain(lumas, np.float32).reshape(-1, 2),
        board.ravel(),
        paint.ravel(),
        labels.ravel(),
        MAX_HUE_PIXELS,
    )
    return Comparison(ncc, level, reference_level, _hue(b_f, b_r), float(p_f @ _LUMA))


def pad_pattern(
    frame_channel: np.ndarray,
    pyramid: tuple[np.ndarray, ...],
    px_per_m: float,
    outline_m: np.ndarray,
    H: np.ndarray,
) -> float:
    """Correlation of the frame's channel with the reference's over the pad's
    outline (``outline_m``: its corners, pad metres), the reference blurred by
    ``FRAME_BLUR_PX``; nan when too little of it is on the frame."""
    outline_px = apply_h(H, outline_m)
    fh, fw = frame_channel.shape[:2]
    x0, y0 = np.maximum(np.floor(outline_px.min(axis=0)).astype(int) - 1, 0)
    x1, y1 = np.ceil(outline_px.max(axis=0)).astype(int) + 2
    x1, y1 = min(x1, fw), min(y1, fh)
    if x1 - x0 < MIN_SIDE_PX or y1 - y0 < MIN_SIDE_PX or x1 - x0 > 4 * MAX_SIDE_PX:
        return math.nan
    ref_span = span_of(outline_m) * px_per_m
    frame_span = span_of(outline_px)
    shift = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
    dsize = (int(x1 - x0), int(y1 - y0))
    warped, seen = _warp(pyramid, px_per_m, ref_span / max(frame_span, 1.0), shift @ H, dsize)
    inside = _polygon_mask(outline_px - [x0, y0], dsize) & seen
    if np.count_nonzero(inside) < MIN_SIDE_PX * MIN_SIDE_PX:
        return math.nan
    ch_ref = _blurred(warped[..., 3], seen, FRAME_BLUR_PX)
    ch_frame = frame_channel[y0:y1, x0:x1].astype(np.float32)
    return masked_ncc(ch_frame, plain(ch_ref, np.float32), inside)


def _warp(
    pyramid: tuple[np.ndarray, ...], px_per_m: float, ratio: float, M: np.ndarray, dsize
) -> tuple[np.ndarray, np.ndarray]:
    """The reference warped by ``M`` (pad metres -> output pixels) from the pyramid
    level about as fine as the output (``ratio``: reference over output pixels at
    level 0), and where it is inside the reference picture."""
    level = min(max(math.floor(math.log2(max(ratio, 1.0))), 0), len(pyramid) - 1)
    k = 2.0**level
    h0, w0 = pyramid[0].shape[:2]
    # Level pixel (u, v) is level-0 pixel (k u, k v) (pyrDown centres its kernel on
    # even pixels) -> pad metres (y up, origin at the picture's centre).
    to_m = np.array(
        [
            [k / px_per_m, 0.0, (0.5 - w0 / 2.0) / px_per_m],
            [0.0, -k / px_per_m, (h0 / 2.0 - 0.5) / px_per_m],
            [0.0, 0.0, 1.0],
        ]
    )
    warped = cv2.warpPerspective(
        pyramid[level], M @ to_m, dsize, flags=cv2.INTER_LINEAR, borderValue=(-1,) * 4
    )
    return warped, warped[..., 3] >= 0


def _blurred(channel: np.ndarray, seen: np.ndarray, sigma: float) -> np.ndarray:
    """A warped channel (or channels, H x W x C) blurred by ``sigma`` pixels within the
    reference picture (what lies outside it is no colour to blur in); only its pixels
    in the picture (``seen``) are meaningful, the only ones the comparison reads."""
    if sigma < 0.2:
        return channel
    if seen.all():  # (the weights all one: a plain blur)
        return cv2.GaussianBlur(channel, (0, 0), sigma)
    w = seen.astype(np.float32)
    den = np.maximum(cv2.GaussianBlur(w, (0, 0), sigma), 1e-6)
    if channel.ndim == 3:  # (channels side by side)
        w, den = w[..., None], den[..., None]
    return cv2.GaussianBlur(channel * w, (0, 0), sigma) / den


def _crop(image: np.ndarray, x0: int, y0: int, x1: int, y1: int, dsize) -> np.ndarray:
    crop = image[y0:y1, x0:x1].astype(np.float32)
    if crop.shape[1] != dsize[0] or crop.shape[0] != dsize[1]:
        crop = cv2.resize(crop, dsize, interpolation=cv2.INTER_AREA)
    return crop


def pattern_box(corners_m: np.ndarray, margin: float = MARGIN) -> np.ndarray:
    """Where the pattern is compared: the H's bounding box grown by ``margin`` of its
    size (4 x 2, pad metres)."""
    lo, hi = corners_m.min(axis=0), corners_m.max(axis=0)
    size = float((hi - lo).max())
    return _box(lo - margin * size, hi + margin * size)


def _box(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.array([[lo[0], hi[1]], [hi[0], hi[1]], [hi[0], lo[1]], [lo[0], lo[1]]])


def _polygon_mask(poly: np.ndarray, dsize: tuple[int, int]) -> np.ndarray:
    m = np.zeros((dsize[1], dsize[0]), np.uint8)
    cv2.fillConvexPoly(m, np.round(poly * 16).astype(np.int32), 1, shift=4)
    return m > 0


def _hue(frame_bgr: np.ndarray, ref_bgr: np.ndarray) -> float:
    """L1 distance of the chromaticities of the frame's board colour and the
    reference's, the frame's read through the exposure curve (``EXPOSURE_CURVES``)
    that brings its saturation to the reference's; nan for a board too dark."""
    if frame_bgr @ _LUMA < DARK_LUMA or ref_bgr @ _LUMA < DARK_LUMA:
        return math.nan
    seen, wanted = _log_chromaticity(frame_bgr), _log_chromaticity(ref_bgr)
    saturation = float(np.linalg.norm(wanted))
    if saturation >= MIN_SATURATION:
        curve = float(np.linalg.norm(seen)) / saturation
        seen = seen / min(max(curve, EXPOSURE_CURVES[0]), EXPOSURE_CURVES[1])
    a, b = np.exp(seen), np.exp(wanted)
    return float(np.abs(a / a.sum() - b / b.sum()).sum())


def _log_chromaticity(bgr: np.ndarray) -> np.ndarray:
    """The colour's logarithm less its mean: what a gain leaves alone and a gamma scales."""
    log = np.log(np.maximum(bgr.astype(np.float64), 1.0))
    return log - log.mean()
