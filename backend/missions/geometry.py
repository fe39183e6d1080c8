"""From one vision pose to what guidance needs: the pad relative to the vehicle.

Frames (as in ``sim.camera``): local NED; body FRD with
``R_ned_body = Rz(yaw) Ry(pitch) Rx(roll)`` (MAVLink ATTITUDE); camera (OpenCV: x right,
y down, z forward) with ``R_body_cam`` the mount; pad frame (x picture right, y picture
top, z up) with ``Pose.position_m`` the camera centre and ``Pose.R_pad_cam``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from backend.frames import DOWN_MOUNT, rot_ned_body
from pipeline import Camera, Pose


def wrap180(deg: float) -> float:
    """An angle in degrees wrapped to [-180, 180)."""
    return (float(deg) + 180.0) % 360.0 - 180.0


def wrap90(deg: float) -> float:
    """An angle modulo the H's 180-degree symmetry, wrapped to [-90, 90)."""
    return (float(deg) + 90.0) % 180.0 - 90.0


def heading_error_deg(vehicle_yaw_deg: float, pad_heading_deg: float) -> float:
    """Vehicle heading minus pad heading, modulo the pad's 180-degree symmetry, in [-90, 90)."""
    return wrap90(vehicle_yaw_deg - pad_heading_deg)


@dataclass(frozen=True)
class PadFix:
    """What one detection tells guidance.

    Attributes
    ----------
    t_capture : float
        Capture time of the frame, on the mission's clock (s).
    time_usec : int
        Capture time on the vehicle's clock (LANDING_TARGET ``time_usec``).
    target_frd : tuple of float
        The pad centre relative to the camera, in body FRD axes (m): what LANDING_TARGET
        carries (ArduCopter adds PLND_CAM_POS_* for the mount offset).
    distance_m : float
        Camera to pad centre (m).
    offset_ned : tuple of float
        The pad centre relative to the vehicle's centre, local NED axes (m).
    height_m : float
        The camera's height above the pad (m).
    heading_error_deg : float
        Vehicle heading minus the pad's, modulo 180 degrees, in [-90, 90).
    image_px : tuple of float
        Where the pad centre is in the image (x, y pixels).
    """

    t_capture: float
    time_usec: int
    target_frd: tuple[float, float, float]
    distance_m: float
    offset_ned: tuple[float, float, float]
    height_m: float
    heading_error_deg: float
    image_px: tuple[float, float]

    def to_dict(self) -> dict:
        return {
            "t_capture": self.t_capture,
            "time_usec": self.time_usec,
            "target_frd": list(self.target_frd),
            "distance_m": self.distance_m,
            "offset_ned": list(self.offset_ned),
            "height_m": self.height_m,
            "heading_error_deg": self.heading_error_deg,
            "image_px": list(self.image_px),
        }


def pad_fix(
    pose: Pose,
    camera: Camera,
    attitude_rpy: tuple[float, float, float],
    *,
    t_capture: float,
    time_usec: int,
    mount_rotation: np.ndarray = DOWN_MOUNT,
    mount_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> PadFix:
    """Turn a vision pose into a :class:`PadFix`.

    ``attitude_rpy``: the vehicle's roll, pitch, yaw (rad) when the frame was taken,
    used only to express the offset in NED; the body-frame target and the heading
    error come from the vision pose alone.

    Examples
    --------
    >>> from pipeline import Camera, Pose
    >>> R = np.diag([1.0, -1.0, -1.0])  # looking down, picture upright
    >>> pose = Pose(np.array([0.2, -0.1, 3.0]), R, 0.5, True)  # 0.2 m east, 0.1 m south
    >>> fix = pad_fix(pose, Camera.from_fov(640, 480, 60), (0, 0, 0), t_capture=0, time_usec=0)
    >>> [round(v, 2) for v in fix.target_frd], round(fix.heading_error_deg, 1)
    ([0.1, -0.2, 3.0], 0.0)
    """
    R_pc = np.asarray(pose.R_pad_cam, float)
    p = np.asarray(pose.position_m, float).reshape(3)
    R_bc = np.asarray(mount_rotation, float)
    if R_pc.shape != (3, 3) or R_bc.shape != (3, 3):
        raise ValueError("pose.R_pad_cam and mount_rotation must be 3x3 rotations")
    if not np.all(np.isfinite(p)) or not np.all(np.isfinite(R_pc)):
        raise ValueError("pose must be finite")
    if len(attitude_rpy) != 3 or not all(math.isfinite(a) for a in attitude_rpy):
        raise ValueError(f"attitude_rpy must be 3 finite angles, got {attitude_rpy!r}")
    v_cam = R_pc.T @ (-p)  # pad centre seen from the camera, camera axes
    v_body = R_bc @ v_cam
    R_nb = rot_ned_body(*attitude_rpy)
    offset = R_nb @ (v_body + np.asarray(mount_offset_m, float))
    # Heading of the nose in the pad frame, clockwise from the picture's top edge.
    nose = (R_pc @ R_bc.T)[:, 0]
    rel = math.degrees(math.atan2(nose[0], nose[1]))
    if v_cam[2] > 1e-6:
        K = camera.K
        u = float(K[0, 0] * v_cam[0] / v_cam[2] + K[0, 2])
        v = float(K[1, 1] * v_cam[1] / v_cam[2] + K[1, 2])
    else:
        u = v = float("nan")
    return PadFix(
        t_capture=float(t_capture),
        time_usec=int(time_usec),
        target_frd=(float(v_body[0]), float(v_body[1]), float(v_body[2])),
        distance_m=float(np.linalg.norm(v_cam)),
        offset_ned=(float(offset[0]), float(offset[1]), float(offset[2])),
        height_m=float(p[2]),
        heading_error_deg=wrap90(rel),
        image_px=(u, v),
    )
