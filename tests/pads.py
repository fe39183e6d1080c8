"""Pad pictures more than one test file draws: references to take or refuse."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.render import make_pad_image

HELIPAD_BLUE = (170, 60, 20)  # the HELIPAD pad's paint, on a light grey board


def helipad(with_h: bool = True) -> np.ndarray:
    """A blue H over the word HELIPAD on a light board (800 px, for 1 m: 1.25 mm a pixel)."""
    pad = np.full((800, 800, 3), 235, np.uint8)
    if with_h:
        w, h, leg, bar = 380, 460, 95, 90
        x, y = 400 - w / 2, 360 - h / 2
        for rect in ((x, y, leg, h), (x + w - leg, y, leg, h), (x, 360 - bar / 2, w, bar)):
            x0, y0, rw, rh = (round(v) for v in rect)
            pad[y0 : y0 + rh, x0 : x0 + rw] = HELIPAD_BLUE
    cv2.putText(
        pad, "HELIPAD", (170, 720), cv2.FONT_HERSHEY_SIMPLEX, 2.6, HELIPAD_BLUE, 9, cv2.LINE_AA
    )
    return pad


def h_in_a_ring(ring: str) -> np.ndarray:
    """A white block H (340 x 440 px, legs 85) on a dark 800 px board, with a white
    ring or frame: "crossed" by the H's legs, "touching" its corners, "frame" a square
    frame at its legs' ends, "clear" a ring with a gap of board all round."""
    picture = np.full((800, 800, 3), 50, np.uint8)
    white = (245, 245, 245)
    if ring == "crossed":
        cv2.circle(picture, (400, 400), 280, white, 30, cv2.LINE_AA)
    elif ring == "touching":
        cv2.circle(picture, (400, 400), 282, white, 26, cv2.LINE_AA)  # (corners at 276 px)
    elif ring == "frame":
        cv2.rectangle(picture, (120, 170), (680, 630), white, 24)  # (inside 182-618; legs 180-620)
    else:
        cv2.circle(picture, (400, 400), 330, white, 26, cv2.LINE_AA)
    picture[180:621, 230:316] = picture[180:621, 485:571] = picture[360:441, 230:571] = white
    return picture


def seen_at_a_slant(degrees: float, axis: str = "x") -> np.ndarray:
    """The default pad's picture as a camera a pad's width above it sees it, turned
    ``degrees`` off the vertical about the picture's ``axis`` (cropped to the pad)."""
    f = 800.0
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    tilt = np.array(
        [[1, 0, 0], [0, c, -s], [0, s, c]] if axis == "x" else [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    )
    lens = np.array([[f, 0, 400], [0, f, 400], [0, 0, 1.0]])
    warp = lens @ tilt @ [[1, 0, -400], [0, 1, -400], [0, 0, f]]
    square = np.array([[[0, 0], [800, 0], [800, 800], [0, 800]]], float)
    corners = cv2.perspectiveTransform(square, warp)[0]
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    shift = np.array([[1, 0, -lo[0]], [0, 1, -lo[1]], [0, 0, 1.0]])
    size = tuple(int(v) for v in np.ceil(hi - lo))
    return cv2.warpPerspective(make_pad_image(800), shift @ warp, size, borderValue=(60, 60, 60))
