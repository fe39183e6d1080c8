"""Planar pose: the camera's pose over the pad from pad-to-image correspondences."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.result import Pose, yaw_of

# A 180 degree turn about the pad's z axis.
TURN = np.diag([-1.0, -1.0, 1.0])


def _object(points_m: np.ndarray) -> np.ndarray:
    pts = np.asarray(points_m, np.float64).reshape(-1, 2)
    return np.column_stack([pts, np.zeros(len(pts))])


def ippe_candidates(
    points_m: np.ndarray, image_px: np.ndarray, camera: Camera
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Both poses IPPE finds for >= 4 coplanar pad points (z = 0) and their pixels.

    A small or distant plane seen nearly head-on has two poses that fit its
    corners almost equally well (tilted one way or the other); the caller
    decides between them with more evidence. Poses behind the camera are dropped.
    """
    obj = _object(points_m)
    img = np.asarray(image_px, np.float64).reshape(-1, 1, 2)
    if len(obj) < 4:
        return []
    try:
        _, rvecs, tvecs, _ = cv2.solvePnPGeneric(
            obj, img, camera.K, camera.dist, flags=cv2.SOLVEPNP_IPPE
        )
    except cv2.error:
        return []
    return [(r.copy(), t.copy()) for r, t in zip(rvecs, tvecs, strict=True) if t[2, 0] > 0]


def tilt_deg(rvec: np.ndarray) -> float:
    """Angle between the camera's optical axis and straight down onto the pad."""
    R_cam_pad, _ = cv2.Rodrigues(rvec)
    # The pad's +z in camera coordinates is R_cam_pad[:, 2]; looking down, the
    # optical axis (camera +z) points along pad -z.
    return float(np.degrees(np.arccos(np.clip(-R_cam_pad[2, 2], -1.0, 1.0))))


def to_pose(rvec: np.ndarray, tvec: np.ndarray, rms: float, symmetric: bool) -> Pose:
    """Turn OpenCV's pad->camera (rvec, tvec) into the camera's pose in the pad frame."""
    R_cam_pad, _ = cv2.Rodrigues(rvec)
    R_pad_cam = R_cam_pad.T
    position = -R_pad_cam @ np.asarray(tvec, np.float64).reshape(3)
    return Pose(position, R_pad_cam, rms, symmetric)


def turned(pose: Pose) -> Pose:
    """The pose's twin for a pad that looks the same after a 180 degree turn."""
    return Pose(TURN @ pose.position_m, TURN @ pose.R_pad_cam, pose.reprojection_px, True)


def pick_by_yaw(pose: Pose, yaw_hint: float | None) -> Pose:
    """Of a symmetric pose and its twin, the one whose yaw is nearer ``yaw_hint``."""
    if yaw_hint is None or not pose.symmetric:
        return pose
    twin = turned(pose)
    return pose if _angle_diff(yaw_of(pose.R_pad_cam), yaw_hint) <= 90.0 else twin


def project(points_m: np.ndarray, rvec: np.ndarray, tvec: np.ndarray, camera: Camera) -> np.ndarray:
    """Pixels of pad points (N x 2 on the pad plane, or N x 3)."""
    pts = np.asarray(points_m, np.float64)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    proj, _ = cv2.projectPoints(pts, rvec, tvec, camera.K, camera.dist)
    return proj.reshape(-1, 2)


def pose_to_vectors(pose: Pose) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's pad->camera (rvec, tvec) for a pose."""
    R_cam_pad = np.asarray(pose.R_pad_cam).T
    tvec = -R_cam_pad @ np.asarray(pose.position_m, np.float64)
    rvec, _ = cv2.Rodrigues(R_cam_pad)
    return rvec, tvec.reshape(3, 1)


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)
