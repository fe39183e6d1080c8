"""A window of the frame at some scale: where, and how finely, the pipeline looks.

The search looks at the whole frame at a working width, tracking at a window
around where the pad was, and the measurement at a window around where it is,
as finely as the frame allows but no finer than it needs. Every view keeps the
same pixel-centre convention as `pipeline.preprocess.subsample`: view pixel
``u = (x - x0 + 0.5) * scale - 0.5`` for frame pixel ``x``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.preprocess import Halvings, shrink

MAX_ENLARGEMENT = 2.0  # interpolating further adds cost, not shape: a leg needs 4-6 px


def enlargement(frame_shape: tuple[int, ...], width: int) -> float:
    """How much a frame is enlarged to look at it ``width`` pixels wide: 1 (not at all)
    to ``MAX_ENLARGEMENT``."""
    return min(MAX_ENLARGEMENT, max(1.0, width / frame_shape[1]))


@dataclass(frozen=True)
class View:
    """Frame pixels [x0, x1) x [y0, y1), resized by ``scale`` (above 1: enlarged, for
    a pad too small to be found at the frame's own resolution)."""

    x0: int
    y0: int
    x1: int
    y1: int
    scale: float

    @classmethod
    def around(
        cls,
        box: np.ndarray,
        frame_shape: tuple[int, ...],
        grow: float,
        scale: float,
        max_scale: float = 1.0,
    ) -> View | None:
        """The view of a box (x0, y0, x1, y1 in frame pixels) grown by ``grow`` pixels on
        each side and clipped to the frame, or None when nothing of it is in the frame;
        ``scale`` at most ``max_scale`` (above 1: the window enlarged)."""
        h, w = frame_shape[:2]
        x0 = max(0, math.floor(box[0] - grow))
        y0 = max(0, math.floor(box[1] - grow))
        x1 = min(w, math.ceil(box[2] + grow) + 1)
        y1 = min(h, math.ceil(box[3] + grow) + 1)
        if x1 - x0 < 16 or y1 - y0 < 16:
            return None
        scale = float(min(max_scale, max(scale, 16.0 / min(x1 - x0, y1 - y0))))
        if scale < 0.5:  # sides that halve evenly (`shrink`): a few pixels more room
            step = 2 ** (math.floor(math.log2(1.0 / scale)) + 1)
            x0, x1 = _aligned(x0, x1, w, step)
            y0, y1 = _aligned(y0, y1, h, step)
        return cls(x0, y0, x1, y1, scale)

    @classmethod
    def whole(cls, frame_shape: tuple[int, ...], max_width: int) -> View:
        h, w = frame_shape[:2]
        return cls(0, 0, w, h, min(1.0, max_width / w))

    @classmethod
    def enlarged(cls, frame_shape: tuple[int, ...], width: int) -> View:
        """The whole frame interpolated toward ``width`` (see `enlargement`)."""
        return cls(0, 0, frame_shape[1], frame_shape[0], enlargement(frame_shape, width))

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the view's image."""
        w, h = self.x1 - self.x0, self.y1 - self.y0
        if self.scale == 1.0:
            return w, h
        return max(1, round(w * self.scale)), max(1, round(h * self.scale))

    @property
    def matrix(self) -> np.ndarray:
        """3 x 3: frame pixels -> view pixels."""
        w, h = self.x1 - self.x0, self.y1 - self.y0
        sx, sy = self.size[0] / w, self.size[1] / h
        return np.array(
            [
                [sx, 0.0, -sx * self.x0 + 0.5 * sx - 0.5],
                [0.0, sy, -sy * self.y0 + 0.5 * sy - 0.5],
                [0.0, 0.0, 1.0],
            ]
        )

    @property
    def to_frame(self) -> np.ndarray:
        """3 x 3: view pixels -> frame pixels (`matrix`'s inverse, written out: a
        general inverse costs a frame more than all its arithmetic)."""
        m = self.matrix
        sx, sy = m[0, 0], m[1, 1]
        return np.array(
            [[1.0 / sx, 0.0, -m[0, 2] / sx], [0.0, 1.0 / sy, -m[1, 2] / sy], [0.0, 0.0, 1.0]]
        )

    def image(self, frame: np.ndarray, halvings: Halvings | None = None) -> np.ndarray:
        """The view's pixels of ``frame``; ``halvings``: the whole frame's made before
        (`pipeline.preprocess.shrink`), used and added to by a view of the whole frame."""
        crop = frame[self.y0 : self.y1, self.x0 : self.x1]
        if self.size == (crop.shape[1], crop.shape[0]):
            return crop
        if self.scale < 1.0:
            whole = crop.shape[:2] == frame.shape[:2]
            return shrink(crop, self.size, halvings if whole else None)
        return cv2.resize(crop, self.size, interpolation=cv2.INTER_CUBIC)

    def camera(self, camera: Camera) -> Camera:
        """The frame's camera (``camera`` at the frame's size) for this view."""
        cam = camera.cropped(self.x0, self.y0, self.x1 - self.x0, self.y1 - self.y0)
        w, h = self.size
        return cam if (w, h) == (cam.width, cam.height) else cam.scaled(w, h)


def _aligned(lo: int, hi: int, limit: int, step: int) -> tuple[int, int]:
    """[lo, hi) grown to a multiple of ``step`` long, within [0, limit) where it fits."""
    hi = lo + -(-(hi - lo) // step) * step
    if hi > limit:
        lo, hi = max(0, lo - (hi - limit)), limit
    return lo, hi
