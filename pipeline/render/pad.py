"""The landing pad's picture and its look-alikes, drawn with exact area coverage.

The seed's pad (section 4.1): a 55 cm square board painted black, white bars along
two of its sides, a white block 'H' in the middle. Shapes are drawn by the fraction of
each pixel they cover, so the picture is anti-aliased and its edges sit exactly where
the geometry says, at any size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

PAD_SIZE_M = 0.55
"""The seed's board: 55 cm square."""

BOARD_BGR = (28, 27, 30)
"""Black paint on the board (not a perfect black: paint reflects a little)."""

PAINT_BGR = (236, 238, 238)
"""White paint of the H and the side bars."""

# Proportions, as fractions of the board's side. At 6 m with a 60 deg HFOV 640x480
# camera a 0.55 m board spans ~51 px, so a 0.12 leg is ~6 px and a 0.10 bar ~5 px.
H_WIDTH = 0.50
H_HEIGHT = 0.50
H_LEG_WIDTH = 0.12
H_CROSSBAR_HEIGHT = 0.10
SIDE_BAR_WIDTH = 0.08
SIDE_BAR_LENGTH = 0.84
SIDE_BAR_INSET = 0.05

LOOKALIKE_KINDS: tuple[str, ...] = (
    "rectangle",
    "letter",
    "II",
    "broken_h",
    "wide_h",
    "cross",
    "h_no_bar",
)
"""Shapes that resemble parts of the pad but are not it (negatives and clutter)."""

# Capitals that share strokes with an H but are not one.
_LETTERS = "AEFKLNTXZYMUVW"


@dataclass(frozen=True)
class PadGeometry:
    """Where the pad's white marks are, in the pad frame (metres).

    Pad frame: origin at the board's centre, +x toward the picture's right edge, +y
    toward its top edge. All proportions are fractions of ``size_m``.

    The H's 12 corners (``h_corners_m``) run clockwise as seen in the picture,
    starting at the top-left outer corner of the left leg; corner ``i`` and corner
    ``(i + 6) % 12`` swap places under a 180 degree turn, which maps the H onto itself.

    Examples
    --------
    >>> g = PadGeometry()
    >>> g.h_corners_m.shape
    (12, 2)
    >>> [round(float(v), 4) for v in g.h_corners_m[0]]
    [-0.1375, 0.1375]
    """

    size_m: float = PAD_SIZE_M
    h_width: float = H_WIDTH
    h_height: float = H_HEIGHT
    leg_width: float = H_LEG_WIDTH
    crossbar_height: float = H_CROSSBAR_HEIGHT
    side_bar_width: float = SIDE_BAR_WIDTH
    side_bar_length: float = SIDE_BAR_LENGTH
    side_bar_inset: float = SIDE_BAR_INSET

    def __post_init__(self) -> None:
        for name in (
            "size_m",
            "h_width",
            "h_height",
            "leg_width",
            "crossbar_height",
            "side_bar_width",
            "side_bar_length",
            "side_bar_inset",
        ):
            value = getattr(self, name)
            if not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if self.h_width >= 1 or self.h_height >= 1:
            raise ValueError("h_width and h_height must be below 1 (fractions of the board)")
        if 2 * self.leg_width >= self.h_width:
            raise ValueError("leg_width must be under half of h_width (the legs would merge)")
        if self.crossbar_height >= self.h_height:
            raise ValueError("crossbar_height must be below h_height")
        if self.side_bar_length >= 1:
            raise ValueError("side_bar_length must be below 1")
        bar_end = self.side_bar_inset + self.side_bar_width
        if bar_end >= (1 - self.h_width) / 2:
            raise ValueError(
                "side_bar_inset + side_bar_width must leave a gap between the side bars and the H"
            )

    def _h_rects(self) -> list[tuple[float, float, float, float]]:
        """The H as three disjoint rectangles (x0, y0, x1, y1), board fractions from centre."""
        a, b = self.h_width / 2, self.h_height / 2
        w, c = self.leg_width, self.crossbar_height / 2
        return [(-a, -b, -a + w, b), (a - w, -b, a, b), (-a + w, -c, a - w, c)]

    def _bar_rects(self) -> list[tuple[float, float, float, float]]:
        x0 = 0.5 - self.side_bar_inset - self.side_bar_width
        x1 = 0.5 - self.side_bar_inset
        y = self.side_bar_length / 2
        return [(-x1, -y, -x0, y), (x0, -y, x1, y)]

    @property
    def h_corners_m(self) -> np.ndarray:
        """The H's 12 corners (12 x 2, metres), clockwise in the picture from top-left."""
        a, b = self.h_width / 2, self.h_height / 2
        w, c = self.leg_width, self.crossbar_height / 2
        pts = [
            (-a, b),
            (-a + w, b),
            (-a + w, c),
            (a - w, c),
            (a - w, b),
            (a, b),
            (a, -b),
            (a - w, -b),
            (a - w, -c),
            (-a + w, -c),
            (-a + w, -b),
            (-a, -b),
        ]
        return np.array(pts, dtype=np.float64) * self.size_m

    @property
    def side_bars_m(self) -> np.ndarray:
        """The two side bars' corners (2 x 4 x 2, metres), left bar first, clockwise."""
        out = []
        for x0, y0, x1, y1 in self._bar_rects():
            out.append([(x0, y1), (x1, y1), (x1, y0), (x0, y0)])
        return np.array(out, dtype=np.float64) * self.size_m

    @property
    def board_corners_m(self) -> np.ndarray:
        """The board's outer corners (4 x 2, metres), clockwise from top-left."""
        s = self.size_m / 2
        return np.array([(-s, s), (s, s), (s, -s), (-s, -s)], dtype=np.float64)

    @property
    def h_area_m2(self) -> float:
        """The H's area in square metres."""
        return sum((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in self._h_rects()) * self.size_m**2


def make_pad_image(
    size_px: int = 1100,
    *,
    h_width: float = H_WIDTH,
    h_height: float = H_HEIGHT,
    leg_width: float = H_LEG_WIDTH,
    crossbar_height: float = H_CROSSBAR_HEIGHT,
    board_bgr: tuple[int, int, int] = BOARD_BGR,
    paint_bgr: tuple[int, int, int] = PAINT_BGR,
) -> np.ndarray:
    """The seed's pad, seen straight from above and cropped to the board's edge.

    Parameters
    ----------
    size_px : side of the square picture in pixels (>= 32).
    h_width, h_height, leg_width, crossbar_height : the H's proportions, as fractions of
        the board's side (see `PadGeometry`).
    board_bgr, paint_bgr : colours of the board and of the white marks.

    Returns
    -------
    BGR uint8 image, ``size_px`` x ``size_px``.

    Examples
    --------
    >>> img = make_pad_image(220)
    >>> img.shape, img.dtype.name, int(img[110, 110, 0]) > 200
    ((220, 220, 3), 'uint8', True)
    """
    if isinstance(size_px, bool) or not isinstance(size_px, int | np.integer) or size_px < 32:
        raise ValueError(f"size_px must be an integer >= 32, got {size_px!r}")
    geom = PadGeometry(
        h_width=h_width, h_height=h_height, leg_width=leg_width, crossbar_height=crossbar_height
    )
    board = _check_bgr(board_bgr, "board_bgr")
    paint = _check_bgr(paint_bgr, "paint_bgr")
    # Board fractions from the centre (y up) -> unit square (y down) for the rasteriser.
    rects = [(x0 + 0.5, 0.5 - y1, x1 + 0.5, 0.5 - y0) for x0, y0, x1, y1 in geom._h_rects()]
    rects += [(x0 + 0.5, 0.5 - y1, x1 + 0.5, 0.5 - y0) for x0, y0, x1, y1 in geom._bar_rects()]
    cover = rect_coverage(rects, int(size_px))
    img = board[None, None, :] + (paint - board)[None, None, :] * cover[..., None]
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def rect_coverage(rects: list[tuple[float, float, float, float]], size_px: int) -> np.ndarray:
    """Fraction of each pixel covered by disjoint axis-aligned rectangles.

    ``rects`` hold (x0, y0, x1, y1) in the unit square (x right, y down, 0..1 over the
    picture). Returns a float64 ``size_px`` x ``size_px`` array in [0, 1].
    """
    edges = np.arange(size_px + 1, dtype=np.float64)
    lo, hi = edges[:-1], edges[1:]
    cover = np.zeros((size_px, size_px), dtype=np.float64)
    for x0, y0, x1, y1 in rects:
        cx = np.clip(np.minimum(hi, x1 * size_px) - np.maximum(lo, x0 * size_px), 0.0, 1.0)
        cy = np.clip(np.minimum(hi, y1 * size_px) - np.maximum(lo, y0 * size_px), 0.0, 1.0)
        cover += np.outer(cy, cx)
    return np.minimum(cover, 1.0)


def make_lookalike(kind: str, size_px: int, rng: np.random.Generator) -> np.ndarray:
    """A white shape that resembles (part of) the pad's marks but is not the pad's H.

    Parameters
    ----------
    kind : one of `LOOKALIKE_KINDS`.
    size_px : side of the square mask (>= 16).
    rng : source of the shape's random proportions.

    Returns
    -------
    uint8 mask, ``size_px`` x ``size_px``, 255 inside the shape, anti-aliased edges.

    Examples
    --------
    >>> m = make_lookalike("cross", 64, np.random.default_rng(0))
    >>> m.shape, int(m[32, 32])
    ((64, 64), 255)
    """
    if kind not in LOOKALIKE_KINDS:
        raise ValueError(f"kind must be one of {LOOKALIKE_KINDS}, got {kind!r}")
    if isinstance(size_px, bool) or not isinstance(size_px, int | np.integer) or size_px < 16:
        raise ValueError(f"size_px must be an integer >= 16, got {size_px!r}")
    if not isinstance(rng, np.random.Generator):
        raise ValueError("rng must be a numpy.random.Generator")
    size_px = int(size_px)
    if kind == "letter":
        return _letter_mask(size_px, rng)
    u = rng.uniform
    if kind == "rectangle":
        w, h = u(0.25, 0.9), u(0.25, 0.9)
        rects = [_centred(w, h)]
    elif kind == "II":
        h, w, gap = u(0.5, 0.9), u(0.08, 0.2), u(0.08, 0.4)
        rects = _bars(w, h, gap)
    elif kind == "h_no_bar":
        # The true H's legs, nothing between them: the hardest negative.
        scale = 0.9 / H_HEIGHT
        w = H_LEG_WIDTH * scale
        rects = _bars(w, 0.9, H_WIDTH * scale - 2 * w)
    elif kind == "cross":
        arm, t = u(0.6, 0.9), u(0.1, 0.25)
        rects = [_centred(arm, t), _centred(t, (arm - t) / 2, dy=-(arm + t) / 4)]
        rects.append(_centred(t, (arm - t) / 2, dy=(arm + t) / 4))
    elif kind == "wide_h":
        rects = _h_rects(*_wide_h_proportions(rng))
    else:  # broken_h
        rects = _broken_h(rng)
    return np.rint(rect_coverage(rects, size_px) * 255).astype(np.uint8)


def _check_bgr(value: tuple[int, int, int], name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64).ravel()
    if arr.size != 3 or not np.all(np.isfinite(arr)) or arr.min() < 0 or arr.max() > 255:
        raise ValueError(f"{name} must be three values in 0..255, got {value!r}")
    return arr


def _centred(w: float, h: float, dx: float = 0.0, dy: float = 0.0) -> tuple[float, ...]:
    return (0.5 + dx - w / 2, 0.5 + dy - h / 2, 0.5 + dx + w / 2, 0.5 + dy + h / 2)


def _bars(w: float, h: float, gap: float) -> list[tuple[float, ...]]:
    off = (gap + w) / 2
    return [_centred(w, h, dx=-off), _centred(w, h, dx=off)]


def _h_rects(width: float, height: float, leg: float, bar: float) -> list[tuple[float, ...]]:
    """An H centred in the unit square as three disjoint rectangles."""
    inner = width - 2 * leg
    off = (width - leg) / 2
    return [_centred(leg, height, dx=-off), _centred(leg, height, dx=off), _centred(inner, bar)]


def _wide_h_proportions(rng: np.random.Generator) -> tuple[float, float, float, float]:
    """An H whose proportions are clearly not the pad's (fat bar, short or thin legs)."""
    style = rng.integers(3)
    if style == 0:  # fat crossbar
        width, height = rng.uniform(0.6, 0.9), rng.uniform(0.6, 0.9)
        return width, height, rng.uniform(0.12, 0.2) * width, rng.uniform(0.35, 0.5) * height
    if style == 1:  # short legs: much wider than tall
        width = rng.uniform(0.8, 0.95)
        height = width * rng.uniform(0.35, 0.55)
        return width, height, 0.2 * width, 0.25 * height
    width, height = rng.uniform(0.5, 0.9), rng.uniform(0.7, 0.9)  # thin legs and bar
    return width, height, rng.uniform(0.03, 0.06), rng.uniform(0.03, 0.05)


def _broken_h(rng: np.random.Generator) -> list[tuple[float, ...]]:
    """A pad-like H with a gap cut right through one leg or through the crossbar."""
    scale = 0.9 / H_HEIGHT * rng.uniform(0.85, 1.0)
    width, height = H_WIDTH * scale, H_HEIGHT * scale
    leg, bar = H_LEG_WIDTH * scale, H_CROSSBAR_HEIGHT * scale
    rects = _h_rects(width, height, leg, bar)
    gap = rng.uniform(0.06, 0.12)
    where = rng.integers(3)
    if where == 2:  # a vertical gap through the crossbar
        x0, y0, x1, y1 = rects.pop()
        cut = rng.uniform(x0 + 0.02, x1 - gap - 0.02) if x1 - x0 > gap + 0.04 else x0
        rects += [(x0, y0, cut, y1), (cut + gap, y0, x1, y1)]
        return [r for r in rects if r[2] > r[0]]
    x0, y0, x1, y1 = rects.pop(int(where))  # a horizontal gap through a leg
    cut = rng.uniform(y0 + 0.05, y1 - gap - 0.05)
    return [*rects, (x0, y0, x1, cut), (x0, cut + gap, x1, y1)]


def _letter_mask(size_px: int, rng: np.random.Generator) -> np.ndarray:
    """A random capital other than H in a thick Hershey font, fitted into the square."""
    letter = _LETTERS[int(rng.integers(len(_LETTERS)))]
    font = (cv2.FONT_HERSHEY_SIMPLEX, cv2.FONT_HERSHEY_DUPLEX)[int(rng.integers(2))]
    thickness = int(rng.integers(14, 26))
    canvas = np.zeros((320, 320), np.uint8)
    cv2.putText(canvas, letter, (40, 260), font, 8.0, 255, thickness, cv2.LINE_AA)
    ys, xs = np.nonzero(canvas)
    crop = canvas[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]
    fit = 0.85 * size_px / max(crop.shape)
    h = max(1, round(crop.shape[0] * fit))
    w = max(1, round(crop.shape[1] * fit))
    small = cv2.resize(crop, (w, h), interpolation=cv2.INTER_AREA)
    out = np.zeros((size_px, size_px), np.uint8)
    y0, x0 = (size_px - h) // 2, (size_px - w) // 2
    out[y0 : y0 + h, x0 : x0 + w] = small
    return out
