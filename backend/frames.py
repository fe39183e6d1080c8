"""Coordinate frames shared by the simulated camera, the missions and the 3D view.

NED: the vehicle's local frame (north, east, down), as LOCAL_POSITION_NED.
Body: FRD (forward, right, down), rotated from NED by MAVLink ATTITUDE's
roll, pitch and yaw (ZYX). Pad: the pipeline's frame (x to the pad picture's
right, y to its top, z up); the pad's heading is where its picture's top
faces, degrees clockwise from north.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pipeline.result import yaw_of

#: Looking straight down, image top = vehicle nose (columns: cam x, y, z in body FRD).
DOWN_MOUNT = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def rot_ned_body(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``R_ned_body`` (body FRD -> NED) for MAVLink ATTITUDE angles in radians."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def rot_ned_pad(pad_heading_deg: float) -> np.ndarray:
    """``R_ned_pad``: columns are the pad's x (picture right), y (picture top), z (up)."""
    psi = math.radians(pad_heading_deg)
    x = [-math.sin(psi), math.cos(psi), 0.0]
    y = [math.cos(psi), math.sin(psi), 0.0]
    z = [0.0, 0.0, -1.0]
    return np.column_stack([x, y, z])


def mount_rotation(roll_deg: float, pitch_deg: float, yaw_deg: float) -> np.ndarray:
    """``R_body_cam`` of a camera turned from `DOWN_MOUNT` as a vehicle turns by these
    angles (degrees, ZYX about its forward, right and down axes): pitch up looks ahead
    of straight down, roll right to its left, yaw right turns the picture's top to
    the right of the nose.

    >>> bool(np.allclose(mount_rotation(0.0, 0.0, 0.0), DOWN_MOUNT))
    True
    >>> np.round(mount_rotation(0.0, 30.0, 0.0)[:, 2], 3).tolist()  # the optical axis
    [0.5, 0.0, 0.866]
    """
    r, p, y = (math.radians(float(a)) for a in (roll_deg, pitch_deg, yaw_deg))
    return rot_ned_body(r, p, y) @ DOWN_MOUNT


def mount_angles(R_body_cam: np.ndarray) -> tuple[float, float, float]:
    """The roll, pitch and yaw (degrees) of `mount_rotation` that give ``R_body_cam``.

    >>> np.round(mount_angles(mount_rotation(-4.0, 7.5, 30.0)), 6).tolist()
    [-4.0, 7.5, 30.0]
    """
    M = np.asarray(R_body_cam, np.float64) @ DOWN_MOUNT.T  # (rot_ned_body's form)
    roll = math.atan2(M[2, 1], M[2, 2])
    pitch = -math.asin(min(max(float(M[2, 0]), -1.0), 1.0))
    yaw = math.atan2(M[1, 0], M[0, 0])
    return (math.degrees(roll), math.degrees(pitch), math.degrees(yaw))


def camera_in_pad(
    pad_heading_deg: float, roll: float, pitch: float, yaw: float, R_body_cam: np.ndarray
) -> np.ndarray:
    """``R_pad_cam`` of a camera mounted by ``R_body_cam`` on a vehicle at ATTITUDE's
    roll, pitch and yaw (radians), over a pad whose picture's top faces ``pad_heading_deg``."""
    return rot_ned_pad(pad_heading_deg).T @ rot_ned_body(roll, pitch, yaw) @ R_body_cam


def vision_hints(
    pad_heading_deg: float, roll: float, pitch: float, yaw: float, R_body_cam: np.ndarray
) -> dict[str, Any]:
    """``process_frame``'s hints from the vehicle's attitude (radians) and the camera's
    mount: the camera's yaw in the pad frame, which settles the H's half-turn, and
    down in the camera frame, which tells the pad's level pose from its tilted twin."""
    R_pad_cam = camera_in_pad(pad_heading_deg, roll, pitch, yaw, R_body_cam)
    return {
        "yaw_hint": yaw_of(R_pad_cam),
        "gravity_hint": gravity_in_camera(roll, pitch, R_body_cam),
    }


def gravity_in_camera(roll: float, pitch: float, R_body_cam: np.ndarray) -> np.ndarray:
    """Down (gravity's direction) in the camera frame, for ATTITUDE's roll and pitch
    (radians) and the camera's mount ``R_body_cam``.

    >>> DOWN = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> gravity_in_camera(0.0, 0.0, DOWN).tolist()  # level: straight along the optical axis
    [0.0, 0.0, 1.0]
    """
    down_body = rot_ned_body(roll, pitch, 0.0).T @ np.array([0.0, 0.0, 1.0])
    return np.asarray(R_body_cam, float).T @ down_body
