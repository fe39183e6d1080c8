"""Fiducial markers of the pad's size, for comparison: ArUco (OpenCV) and AprilTag 3.

Both markers' black squares are as wide as the pad, with a one-cell white quiet
zone, and both poses come from the same solver (``cv2.solvePnP`` IPPE_SQUARE on
the four detected corners), so the comparison is between detectors, not solvers.
"""

from __future__ import annotations

import atexit
import functools
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.pose import to_pose
from pipeline.result import Pose

ARUCO_DICT = cv2.aruco.DICT_4X4_50
APRILTAG_FAMILY = "tag36h11"
APRILTAG_DECIMATE = 1.0  # full resolution: AprilTag's best range (its default, 2.0, halves it)
_MARKER_ID = 0
_TEXTURE_PX = 600


class MarkerDetector(Protocol):
    name: str

    def pose(self, frame: np.ndarray, camera: Camera) -> Pose | None: ...


def marker_texture(kind: str, size_m: float) -> tuple[np.ndarray, float]:
    """The marker's picture (BGR) and its width in metres (black square = ``size_m``)."""
    if kind == "aruco":
        dictionary, cells = cv2.aruco.getPredefinedDictionary(ARUCO_DICT), 6  # 4x4 + border
    elif kind == "apriltag":
        # OpenCV's tag36h11 is AprilTag's: 6x6 bits + the black border = 8 cells.
        dictionary, cells = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11), 8
    else:
        raise ValueError(f"kind must be 'aruco' or 'apriltag', got {kind!r}")
    px = _TEXTURE_PX - _TEXTURE_PX % cells
    marker = cv2.aruco.generateImageMarker(dictionary, _MARKER_ID, px)
    m = px // cells
    tex = cv2.copyMakeBorder(marker, m, m, m, m, cv2.BORDER_CONSTANT, value=255)
    return cv2.cvtColor(tex, cv2.COLOR_GRAY2BGR), size_m * tex.shape[1] / px


def _square(size_m: float) -> np.ndarray:
    """IPPE_SQUARE's corner order: top-left, top-right, bottom-right, bottom-left."""
    h = size_m / 2
    return np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], np.float64)


def _square_pose(corners_px: np.ndarray, size_m: float, camera: Camera) -> Pose | None:
    ok, rvec, tvec = cv2.solvePnP(
        _square(size_m), corners_px, camera.K, camera.dist, flags=cv2.SOLVEPNP_IPPE_SQUARE
    )
    return to_pose(rvec, tvec, 0.0, False) if ok else None


@dataclass
class ArucoDetector:
    """OpenCV's ArUco detector (DICT_4X4_50, sub-pixel corners), as the bench always used."""

    size_m: float
    name: str = "aruco"

    def __post_init__(self) -> None:
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        self._det = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(ARUCO_DICT), params)

    def pose(self, frame: np.ndarray, camera: Camera) -> Pose | None:
        corners, ids, _ = self._det.detectMarkers(frame)
        if ids is None:
            return None
        hits = [c for c, i in zip(corners, ids.ravel(), strict=True) if i == _MARKER_ID]
        if not hits:
            return None
        return _square_pose(hits[0].reshape(4, 2).astype(np.float64), self.size_m, camera)


@dataclass
class AprilTagDetector:
    """AprilTag 3 (``pupil-apriltags``), tag36h11, one thread, full-resolution quads."""

    size_m: float
    name: str = "apriltag"

    def __post_init__(self) -> None:
        self._det = _shared_apriltag_detector()

    def pose(self, frame: np.ndarray, camera: Camera) -> Pose | None:
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
        hits = [d for d in self._det.detect(gray) if d.tag_id == _MARKER_ID]
        if not hits:
            return None
        # pupil-apriltags lists the corners top-right, top-left, bottom-left,
        # bottom-right in the tag's own frame; IPPE_SQUARE wants TL, TR, BR, BL.
        c = np.asarray(hits[0].corners, np.float64)[[1, 0, 3, 2]]
        return _square_pose(c, self.size_m, camera)


@functools.cache
def _shared_apriltag_detector():
    """One detector for the whole process, never destroyed.

    pupil-apriltags 1.0.4 frees the tag family before the detector that still uses
    it (pupil-labs/apriltags PR #65, unreleased): destroying a Detector corrupts the
    heap, which aborted a sweep at random. So the one detector lives until exit and
    is then left to the operating system.
    """
    from pupil_apriltags import Detector

    det = Detector(families=APRILTAG_FAMILY, nthreads=1, quad_decimate=APRILTAG_DECIMATE)

    def _leak() -> None:
        det.tag_detector_ptr = None  # __del__ then frees nothing

    atexit.register(_leak)
    return det


def settings() -> dict:
    """The comparison markers' settings, for the benchmark's JSON."""
    return {
        "aruco": {"dictionary": "DICT_4X4_50", "corner_refinement": "subpix"},
        "apriltag": {
            "library": "pupil-apriltags (AprilTag 3)",
            "family": APRILTAG_FAMILY,
            "quad_decimate": APRILTAG_DECIMATE,
            "threads": 1,
        },
        "marker_size": "black square as wide as the pad, one white cell around it",
        "pose": "cv2.solvePnP IPPE_SQUARE on the four corners",
    }
