"""Does the frame look like the reference picture where the H was located?

The reference's learned channel, around its H (a margin of a quarter of the
H's size: the board between and beside the strokes, the start of any ring),
is warped into the frame by the located homography and compared with the
frame's channel by normalised cross-correlation, which ignores exposure and
contrast. A look-alike that fits the H's outline but not what surrounds it
(paint on a floor, a letter on a sign) scores low; the real pad scores high
whatever its design, since the reference supplies the design.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from pipeline.homography_fit import apply_h

MARGIN = 0.15  # of the H's size, around its bounding box
MIN_SIDE_PX = 6  # frame patches smaller than this are not compared


def reference_pyramid(channel: np.ndarray, levels: int = 6) -> tuple[np.ndarray, ...]:
    """The reference channel at halving resolutions (float32)."""
    out = [channel.astype(np.float32)]
    while len(out) < levels and min(out[-1].shape[:2]) >= 32:
        out.append(cv2.pyrDown(out[-1]))
    return tuple(out)


def template_ncc(
    frame_channel: np.ndarray,
    pyramid: tuple[np.ndarray, ...],
    px_per_m: float,
    corners_m: np.ndarray,
    H: np.ndarray,
) -> float:
    """NCC of the frame's channel with the reference's around the located H (-1..1).

    ``pyramid``: the reference channel's pyramid (level 0 at ``px_per_m``
    pixels per metre, pad centre at the picture's centre). ``H``: pad metres ->
    frame pixels. The patch is the H's bounding box grown by ``MARGIN``. nan
    when the patch is too small or off the frame.
    """
    lo, hi = corners_m.min(axis=0), corners_m.max(axis=0)
    grow = MARGIN * float((hi - lo).max())
    lo, hi = lo - grow, hi + grow
    box_m = np.array([[lo[0], hi[1]], [hi[0], hi[1]], [hi[0], lo[1]], [lo[0], lo[1]]])
    box_px = apply_h(H, box_m)
    fh, fw = frame_channel.shape[:2]
    x0, y0 = np.floor(box_px.min(axis=0)).astype(int)
    x1, y1 = np.ceil(box_px.max(axis=0)).astype(int) + 1
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, fw), min(y1, fh)
    if x1 - x0 < MIN_SIDE_PX or y1 - y0 < MIN_SIDE_PX:
        return math.nan
    # The pyramid level about as fine as the frame's view of it.
    frame_span = float(np.ptp(box_px, axis=0).max())
    ref_span = float((hi - lo).max()) * px_per_m
    level = int(
        np.clip(
            math.floor(math.log2(max(ref_span / max(frame_span, 1.0), 1.0))), 0, len(pyramid) - 1
        )
    )
    ref = pyramid[level]
    rh, rw = ref.shape[:2]
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
    shift = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
    M = shift @ H @ to_m
    size = (x1 - x0, y1 - y0)
    warped = cv2.warpPerspective(ref, M, size, flags=cv2.INTER_LINEAR, borderValue=0.0)
    inside = cv2.warpPerspective(
        np.ones((rh, rw), np.float32), M, size, flags=cv2.INTER_LINEAR, borderValue=0.0
    )
    patch = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.fillConvexPoly(patch, np.round((box_px - [x0, y0]) * 16).astype(np.int32), 1, shift=4)
    use = (inside > 0.999) & (patch > 0)
    if np.count_nonzero(use) < MIN_SIDE_PX * MIN_SIDE_PX:
        return math.nan
    a = frame_channel[y0:y1, x0:x1].astype(np.float32)[use]
    b = warped[use]
    a = a - a.mean()
    b = b - b.mean()
    den = math.sqrt(float(np.dot(a, a)) * float(np.dot(b, b)))
    return float(np.dot(a, b) / den) if den > 1e-9 else math.nan
