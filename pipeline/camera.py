"""Pinhole camera model with lens distortion, in OpenCV's conventions."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import cv2
import numpy as np


@dataclass(frozen=True, eq=False)
class Camera:
    """Intrinsics of a camera: image size, camera matrix ``K`` and distortion.

    Camera frame: x right, y down, z forward (OpenCV). ``dist`` holds OpenCV's
    distortion coefficients (k1, k2, p1, p2[, k3, ...]); zeros mean none.

    Examples
    --------
    >>> cam = Camera.from_fov(640, 480, 60.0)
    >>> round(cam.fx, 1)
    554.3
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))

    def __post_init__(self) -> None:
        if int(self.width) <= 0 or int(self.height) <= 0:
            raise ValueError(f"width and height must be positive, got {self.width}x{self.height}")
        K = np.asarray(self.K, dtype=np.float64)
        if K.shape != (3, 3) or not np.isfinite(K).all() or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ValueError("K must be a finite 3x3 camera matrix with positive focal lengths")
        dist = np.asarray(self.dist, dtype=np.float64).ravel()
        if dist.size not in (4, 5, 8, 12, 14) or not np.isfinite(dist).all():
            raise ValueError("dist must hold 4, 5, 8, 12 or 14 finite distortion coefficients")
        K.setflags(write=False)
        dist.setflags(write=False)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", dist)

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @cached_property
    def brown_conrady(self) -> np.ndarray | None:
        """(k1, k2, p1, p2, k3), zero where not given; None when the rational or
        thin-prism terms are used as well (``pipeline.planar_projection`` then asks
        OpenCV)."""
        if self.dist.size > 5 and (self.dist[5:] != 0).any():
            return None
        k = np.zeros(5)
        k[: min(5, self.dist.size)] = self.dist[:5]
        return k

    @property
    def has_distortion(self) -> bool:
        return bool((self.dist != 0).any())

    @property
    def hfov_deg(self) -> float:
        return math.degrees(2 * math.atan(self.width / (2 * self.fx)))

    @classmethod
    def from_fov(cls, width: int, height: int, hfov_deg: float) -> Camera:
        """An ideal camera with square pixels and the principal point at the centre.

        f = (W / 2) / tan(HFOV / 2) in pixels (the seed's eq. 6.12 is wrong).
        """
        if not 0 < float(hfov_deg) < 180:
            raise ValueError(f"hfov_deg must be in (0, 180), got {hfov_deg}")
        if int(width) <= 0 or int(height) <= 0:
            raise ValueError(f"width and height must be positive, got {width}x{height}")
        f = (width / 2) / math.tan(math.radians(hfov_deg) / 2)
        K = np.array([[f, 0, (width - 1) / 2], [0, f, (height - 1) / 2], [0, 0, 1]])
        return cls(int(width), int(height), K)

    @classmethod
    def from_file(cls, path: str | Path) -> Camera:
        """Read an OpenCV calibration file (YAML/XML via FileStorage, or JSON).

        Expected keys: ``camera_matrix``, ``distortion_coefficients``,
        ``image_width``, ``image_height``. In JSON a matrix may be a nested list or
        OpenCV's ``{"rows", "cols", "data"}`` form.
        """
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"path: no calibration file at {path}")
        if path.suffix.lower() == ".json":
            try:
                data = json.loads(path.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise ValueError(f"path: {path} is not valid JSON: {exc}") from exc
            K = _json_matrix(data, "camera_matrix", path)
            dist = _json_matrix(data, "distortion_coefficients", path)
            width, height = data.get("image_width"), data.get("image_height")
        else:
            fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
            if not fs.isOpened():
                raise ValueError(f"path: OpenCV cannot read {path} as a calibration file")
            try:
                K = fs.getNode("camera_matrix").mat()
                dist = fs.getNode("distortion_coefficients").mat()
                w_node, h_node = fs.getNode("image_width"), fs.getNode("image_height")
                width = None if w_node.empty() else int(w_node.real())
                height = None if h_node.empty() else int(h_node.real())
            finally:
                fs.release()
            if K is None:
                raise ValueError(f"path: {path} has no camera_matrix")
            if dist is None:
                dist = np.zeros(5)
        if width is None or height is None:
            raise ValueError(f"path: {path} needs image_width and image_height")
        return cls(int(width), int(height), np.asarray(K, float), np.asarray(dist, float).ravel())

    def scaled(self, width: int, height: int) -> Camera:
        """The same camera for an image resized to ``width`` x ``height``."""
        sx, sy = width / self.width, height / self.height
        S = np.diag([sx, sy, 1.0])
        K = S @ self.K
        # Pixel centres move with the scale: x' = (x + 0.5) * s - 0.5.
        K[0, 2] += 0.5 * sx - 0.5
        K[1, 2] += 0.5 * sy - 0.5
        return self._like(width, height, K)

    def cropped(self, x0: int, y0: int, width: int, height: int) -> Camera:
        """The same camera for the window of ``width`` x ``height`` pixels at (x0, y0).

        >>> Camera.from_fov(640, 480, 60.0).cropped(100, 50, 200, 100).K[:2, 2].tolist()
        [219.5, 189.5]
        """
        K = self.K.copy()
        K[0, 2] -= x0
        K[1, 2] -= y0
        return self._like(width, height, K)

    def _like(self, width: int, height: int, K: np.ndarray) -> Camera:
        """This camera's lens at another size or window, its distortion (read-only) and
        its model shared: checked as a new camera only where its size or matrix is
        off (the pipeline takes a camera for each window it looks at, a few a frame)."""
        width, height = int(width), int(height)
        if width <= 0 or height <= 0 or not np.isfinite(K).all():
            return Camera(width, height, K, self.dist)  # (which says what is wrong)
        out = object.__new__(Camera)
        K.setflags(write=False)
        for name, value in (("width", width), ("height", height), ("K", K), ("dist", self.dist)):
            object.__setattr__(out, name, value)
        if "brown_conrady" in self.__dict__:
            out.__dict__["brown_conrady"] = self.__dict__["brown_conrady"]
        return out

    def undistort_points(self, pts: np.ndarray) -> np.ndarray:
        """Pixel points (N x 2) with the lens distortion removed (still in pixels)."""
        pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
        if not self.has_distortion or len(pts) == 0:
            return pts.copy()
        out = cv2.undistortPoints(pts.reshape(-1, 1, 2), self.K, self.dist, P=self.K)
        return out.reshape(-1, 2)

    def to_dict(self) -> dict:
        return {
            "width": self.width,
            "height": self.height,
            "camera_matrix": self.K.tolist(),
            "distortion_coefficients": self.dist.tolist(),
        }


def _json_matrix(data: dict, key: str, path: Path) -> np.ndarray:
    if key not in data:
        if key == "distortion_coefficients":
            return np.zeros(5)
        raise ValueError(f"path: {path} has no {key}")
    value = data[key]
    if isinstance(value, dict):
        try:
            return np.asarray(value["data"], float).reshape(int(value["rows"]), int(value["cols"]))
        except (KeyError, ValueError) as exc:
            raise ValueError(f"path: {path}: {key} is malformed: {exc}") from exc
    try:
        return np.asarray(value, float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"path: {path}: {key} is malformed: {exc}") from exc
