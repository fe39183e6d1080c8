"""Coordinate frames shared by the simulated camera, the missions and the 3D view.

NED: the vehicle's local frame (north, east, down), as LOCAL_POSITION_NED.
Body: FRD (forward, right, down), rotated from NED by MAVLink ATTITUDE's
roll, pitch and yaw (ZYX). Pad: the pipeline's frame (x to the pad picture's
right, y to its top, z up); the pad's heading is where its picture's top
faces, degrees clockwise from north.
"""

from __future__ import annotations

import math

import numpy as np


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


def camera_yaw_in_pad(pad_heading_deg: float, vehicle_yaw_rad: float) -> float:
    """The down-looking camera's yaw in the pad frame (``pipeline.result.yaw_of``), degrees.

    The camera's image top is the vehicle's nose, so its yaw is the pad's heading minus
    the vehicle's (headings turn clockwise, the pad-frame yaw counter-clockwise).

    >>> camera_yaw_in_pad(30.0, math.radians(50.0))
    -20.0
    """
    yaw = float(pad_heading_deg) - math.degrees(float(vehicle_yaw_rad))
    return (yaw + 180.0) % 360.0 - 180.0
