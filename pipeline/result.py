"""What the pipeline returns for a frame: frozen dataclasses, JSON-serialisable."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np


def yaw_of(R_pad_cam: np.ndarray) -> float:
    """The camera's yaw in the pad frame, degrees in (-180, 180].

    The angle, counter-clockwise about pad +z, from pad +x to the camera's x axis
    (image right) projected on the pad plane. A camera looking straight down that
    sees the pad as in the reference picture has yaw 0.
    """
    x_axis = np.asarray(R_pad_cam)[:, 0]
    return math.degrees(math.atan2(x_axis[1], x_axis[0]))


@dataclass(frozen=True, eq=False)
class Pose:
    """The camera's pose over the pad.

    ``position_m``: camera centre in the pad frame (origin at the pad centre, +x to
    the reference picture's right edge, +y to its top edge, +z up out of the pad).
    ``R_pad_cam``: rotation mapping camera-frame vectors (OpenCV: x right, y down,
    z forward) into the pad frame. ``symmetric``: this pose and its turned twin
    fit the frame equally well (the pad looks the same after a 180 degree turn, or
    the marks that tell its heading were not seen in this frame); ``yaw_hint``
    decides between them. ``ambiguous``: the pixels fit another
    pose, tilted the other way, as well as this one, or show the tilt too little
    to tell it within a few degrees (a small pad seen nearly head on, an H with
    no other mark found, with no ``gravity_hint`` to tell them apart), or no pose
    fits them within a hundredth of the pad's span (edges of something else taken).
    ``lean_rotation``: with a ``gravity_hint``, how the pad's pixels alone lean it
    from the level the hint gives: the rotation (camera frame, a rotation vector in
    radians) that turns down as the hint gives it onto down as the pixels give it;
    ``lean_deg``: its angle (degrees). Both None without the hint. The pose is held
    near that level; frame to frame the lean is the pixels' noise, a degree or two,
    but one that stays, frame after frame, says the hint is off (the camera's mount is
    not the one the caller assumed) or the pad is not level.
    """

    position_m: np.ndarray
    R_pad_cam: np.ndarray
    reprojection_px: float
    symmetric: bool
    ambiguous: bool = False
    lean_deg: float | None = None
    lean_rotation: np.ndarray | None = None

    @property
    def yaw_deg(self) -> float:
        return yaw_of(self.R_pad_cam)

    @property
    def altitude_m(self) -> float:
        return float(self.position_m[2])

    def to_dict(self) -> dict:
        return {
            "position_m": [float(v) for v in self.position_m],
            "R_pad_cam": np.asarray(self.R_pad_cam, float).tolist(),
            "yaw_deg": self.yaw_deg,
            "reprojection_px": float(self.reprojection_px),
            "symmetric": bool(self.symmetric),
            "ambiguous": bool(self.ambiguous),
            "lean_deg": None if self.lean_deg is None else float(self.lean_deg),
            "lean_rotation": None
            if self.lean_rotation is None
            else [float(v) for v in self.lean_rotation],
        }


@dataclass(frozen=True, eq=False)
class FrameResult:
    """The pipeline's findings on one frame.

    ``corners_px``: the H's corners (N x 2, x then y, pixels of the input image),
    in the reference's corner order under the reported pose. ``hu``: Hu's seven
    invariants of the H's region (NaN, JSON null, when nothing was found).
    ``timings_ms``: wall time per stage. ``contour_px``: the H's boundary.
    ``score``: the share of the pad's edges found where the pose puts them
    (0..1). ``reason``: why nothing was detected. ``found_by``: "follow" (the
    H's sides fitted again where they were in the last frame), "track" (searched
    in a window around where the pad was), "search" (the whole frame) or "board"
    (the whole frame, a pad too far for its H found by its board's outline).
    ``homography``: pad metres -> frame pixels, for tracking the pad in the next
    frame. ``mask``: the threshold mask the pipeline searched with (uint8, 0/255,
    at its search size: frames wider than 640 px are searched subsampled), for
    showing; made by ``mask_source`` when first asked for (a followed pad is
    fitted without thresholding its window). ``motion``: how the pad moved on the
    frame since the ``prior`` it was found in (frame pixels -> frame pixels), for
    predicting where it is next. None of the last four is part of :meth:`to_dict`.
    """

    detected: bool
    corners_px: np.ndarray
    hu: tuple[float, ...]
    orientation_deg: float
    eccentricity: float
    pose: Pose | None
    timings_ms: dict[str, float]
    contour_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    score: float = 0.0
    reason: str = ""
    found_by: str = ""
    homography: np.ndarray | None = field(default=None, repr=False)
    mask_source: Callable[[], np.ndarray] | None = field(default=None, repr=False)
    motion: np.ndarray | None = field(default=None, repr=False)

    @cached_property
    def mask(self) -> np.ndarray | None:
        return None if self.mask_source is None else self.mask_source()

    def to_dict(self) -> dict:
        return {
            "detected": bool(self.detected),
            "corners_px": np.asarray(self.corners_px, float).reshape(-1, 2).tolist(),
            "hu": [_finite(v) for v in self.hu],
            "orientation_deg": _finite(self.orientation_deg),
            "eccentricity": _finite(self.eccentricity),
            "pose": None if self.pose is None else self.pose.to_dict(),
            "timings_ms": {k: float(v) for k, v in self.timings_ms.items()},
            "contour_px": np.asarray(self.contour_px, float).reshape(-1, 2).tolist(),
            "score": _finite(self.score),
            "reason": self.reason,
            "found_by": self.found_by,
        }


def _finite(value: float) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None
