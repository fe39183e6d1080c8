"""One gray channel per pad: the colour projection that best separates its H from its board.

A white H on an orange disc has nearly the luma of the disc's bright edge; a
red H on black is darker than most floors; a dark H on paper is the opposite
polarity of the seed's pad. Each reference learns, from its own picture, a
linear map of B, G, R to one channel in which its H is bright and its board
dark: Fisher's discriminant between the H's pixels and the board's around it,
regularised toward the plain difference of their mean colours so that it
carries over to other cameras, white balances and light. The pipeline then
works on that channel exactly as it would on gray.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

_CUBE = np.array([[b, g, r] for b in (0, 255) for g in (0, 255) for r in (0, 255)], np.float64)
REGULARISATION = 1.0  # ridge on the pooled covariance, in units of its mean variance


@dataclass(frozen=True)
class Projection:
    """``p = (weights . bgr - low) * 255 / (high - low)``: uint8, never clipped.

    ``low``/``high`` are the extremes of ``weights . bgr`` over the whole colour
    cube, so any frame maps into 0..255 whatever its exposure.

    Examples
    --------
    >>> img = np.zeros((2, 2, 3), np.uint8); img[0, 0] = (255, 255, 255)
    >>> GRAY.apply(img).tolist()
    [[255, 0], [0, 0]]
    >>> GRAY.inverted().apply(img).tolist()
    [[0, 255], [255, 255]]
    """

    weights: tuple[float, float, float]  # B, G, R

    @property
    def _range(self) -> tuple[float, float]:
        v = _CUBE @ np.asarray(self.weights)
        return float(v.min()), float(v.max())

    @cached_property
    def matrix(self) -> np.ndarray:
        """1 x 4 matrix for ``cv2.transform`` (scale folded into the weights, then offset)."""
        lo, hi = self._range
        k = 255.0 / (hi - lo)
        return np.array([[*(np.asarray(self.weights) * k), -lo * k]], np.float32)

    @cached_property
    def is_gray(self) -> bool:
        """Whether this is BT.601 luma or its inverse (colour plays no part)."""
        w = np.asarray(self.weights) / np.abs(np.sum(self.weights))
        return bool(np.allclose(np.abs(w), np.asarray(GRAY.weights), atol=0.02))

    @property
    def inverted_luma(self) -> bool:
        """Whether this is inverted luma (a dark H made bright): its light is 255 minus it."""
        return self.is_gray and self.polarity == "dark"

    @property
    def polarity(self) -> str:
        """ "bright" when the H is lighter than its board in plain gray, else "dark"."""
        return "bright" if float(np.dot(self.weights, GRAY.weights)) >= 0 else "dark"

    def inverted(self) -> Projection:
        return Projection(tuple(-float(w) for w in self.weights))  # type: ignore[arg-type]

    def apply(self, image_bgr: np.ndarray) -> np.ndarray:
        """The channel (uint8, same height and width) of a BGR uint8 image."""
        if image_bgr.ndim == 2:
            return self.apply_gray(image_bgr)
        if self.is_gray:  # plain or inverted luma: OpenCV's own conversion is faster
            gray = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)
            return gray if self.polarity == "bright" else cv2.bitwise_not(gray)
        out = cv2.transform(image_bgr, self.matrix)
        return out.reshape(image_bgr.shape[:2])

    def apply_gray(self, gray: np.ndarray) -> np.ndarray:
        """The channel of a picture that has no colour (all three channels equal ``gray``).

        Only the sign of the weights' sum survives: a colour-only contrast is
        invisible in gray, and then the luma contrast's polarity is the best guess.
        """
        proj = GRAY if self.polarity == "bright" else GRAY.inverted()
        return cv2.transform(cv2.merge([gray, gray, gray]), proj.matrix).reshape(gray.shape)

    def to_dict(self) -> dict:
        return {"weights_bgr": [float(w) for w in self.weights], "polarity": self.polarity}


GRAY = Projection((0.114, 0.587, 0.299))
"""BT.601 luma: the seed's gray (a white H on a dark board)."""


def learn_projection(
    image_bgr: np.ndarray, h_mask: np.ndarray, board_mask: np.ndarray
) -> Projection:
    """The projection in which the pixels of ``h_mask`` are bright and ``board_mask``'s dark.

    Examples
    --------
    >>> img = np.zeros((40, 40, 3), np.uint8); img[:] = (30, 110, 230)  # orange
    >>> img[10:30, 10:30] = (245, 245, 245)  # white
    >>> h = np.zeros((40, 40), bool); h[12:28, 12:28] = True
    >>> p = learn_projection(img, h, ~np.pad(np.ones((24, 24), bool), 8))
    >>> int(p.apply(img)[20, 20]) - int(p.apply(img)[2, 2]) > 100
    True
    """
    pix = image_bgr.reshape(-1, 3).astype(np.float64)
    fg = pix[np.asarray(h_mask, bool).ravel()]
    bg = pix[np.asarray(board_mask, bool).ravel()]
    if len(fg) < 10 or len(bg) < 10:
        raise ValueError("learn_projection needs at least 10 pixels of the H and of its board")
    diff = fg.mean(axis=0) - bg.mean(axis=0)
    if np.linalg.norm(diff) < 1e-6:
        raise ValueError("the H and its board have the same mean colour")
    pooled = 0.5 * (np.cov(fg.T) + np.cov(bg.T))
    ridge = REGULARISATION * max(float(np.trace(pooled)) / 3.0, 1.0)
    w = np.linalg.solve(pooled + ridge * np.eye(3), diff)
    if np.dot(w, diff) <= 0:  # cannot happen with a positive-definite matrix; keep it safe
        w = diff
    w = w / np.abs(w).sum()
    if np.all(np.abs(w - np.sign(w[0]) / 3.0) < 0.1):
        # Achromatic: plain (or inverted) luma separates it as well, and every
        # camera, colour or not, sees the same.
        return GRAY if w[0] > 0 else GRAY.inverted()
    return Projection(tuple(float(v) for v in w))  # type: ignore[arg-type]


def contrast(channel: np.ndarray, h_mask: np.ndarray, board_mask: np.ndarray) -> float:
    """Mean of the H minus mean of the board on a projected channel (0..255 units)."""
    c = channel.astype(np.float64)
    return float(c[np.asarray(h_mask, bool)].mean() - c[np.asarray(board_mask, bool)].mean())
