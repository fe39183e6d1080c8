"""Vision pose -> guidance quantities, checked against the simulated camera's geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from backend.missions.geometry import (
    heading_error_deg,
    pad_fix,
    rot_ned_body,
    wrap90,
    wrap180,
)
from pipeline import Camera, Pose
from sim.camera import SimCameraConfig, VehiclePose, camera_pose_in_pad_frame

CAM = Camera.from_fov(640, 480, 60.0)


def _fix(vehicle_ned, rpy, pad_ned, pad_heading, offset=(0.0, 0.0, 0.0)):
    cfg = SimCameraConfig(
        pad_north_m=pad_ned[0],
        pad_east_m=pad_ned[1],
        pad_heading_deg=pad_heading,
        mount_offset_m=offset,
    )
    pose = VehiclePose(vehicle_ned, *rpy, t=0.0)
    position, R = camera_pose_in_pad_frame(pose, cfg)
    return pad_fix(
        Pose(position, R, 0.1, True), CAM, rpy, t_capture=1.0, time_usec=5, mount_offset_m=offset
    )


@pytest.mark.parametrize(
    ("vehicle", "rpy", "heading"),
    [
        ((1.0, 2.0, -4.0), (0.0, 0.0, 0.0), 0.0),
        ((6.5, -0.7, -3.0), (0.05, -0.08, 2.0), 137.0),
        ((-2.0, 3.0, -1.2), (-0.1, 0.03, -2.9), 290.0),
    ],
)
def test_offset_and_target_match_the_geometry(vehicle, rpy, heading):
    pad = (1.5, 2.5, 0.0)
    fix = _fix(vehicle, rpy, pad, heading)
    want = np.subtract(pad, vehicle)
    np.testing.assert_allclose(fix.offset_ned, want, atol=1e-9)
    # The body-frame target is the same vector seen from the body axes.
    np.testing.assert_allclose(fix.target_frd, rot_ned_body(*rpy).T @ want, atol=1e-9)
    assert fix.distance_m == pytest.approx(float(np.linalg.norm(want)))
    assert fix.height_m == pytest.approx(-vehicle[2])
    assert fix.heading_error_deg == pytest.approx(
        heading_error_deg(math.degrees(rpy[2]), heading), abs=1e-6
    )
    assert (fix.t_capture, fix.time_usec) == (1.0, 5)


def test_mount_offset_is_left_out_of_the_target_and_kept_in_the_offset():
    offset = (0.1, -0.05, 0.08)
    rpy = (0.02, 0.01, 0.4)
    fix = _fix((0.0, 0.0, -3.0), rpy, (0.3, 0.2, 0.0), 10.0, offset)
    np.testing.assert_allclose(fix.offset_ned, (0.3, 0.2, 3.0), atol=1e-9)
    cam_to_pad = rot_ned_body(*rpy).T @ np.array([0.3, 0.2, 3.0]) - np.array(offset)
    np.testing.assert_allclose(fix.target_frd, cam_to_pad, atol=1e-9)


def test_pad_centre_projects_to_the_image_centre_when_straight_above():
    fix = _fix((2.0, 3.0, -2.0), (0.0, 0.0, 0.7), (2.0, 3.0, 0.0), 40.0)
    assert fix.image_px == pytest.approx((CAM.K[0, 2], CAM.K[1, 2]))


def test_heading_error_is_modulo_the_h_symmetry():
    assert heading_error_deg(10.0, 0.0) == pytest.approx(10.0)
    assert heading_error_deg(190.0, 0.0) == pytest.approx(10.0)
    assert heading_error_deg(-175.0, 0.0) == pytest.approx(5.0)
    assert wrap90(95.0) == pytest.approx(-85.0)
    assert wrap180(190.0) == pytest.approx(-170.0)


def test_bad_inputs_raise_value_error():
    good = Pose(np.array([0.0, 0.0, 2.0]), np.diag([1.0, -1.0, -1.0]), 0.1, True)
    with pytest.raises(ValueError, match="attitude_rpy"):
        pad_fix(good, CAM, (0.0, math.nan, 0.0), t_capture=0, time_usec=0)
    with pytest.raises(ValueError, match="attitude_rpy"):
        pad_fix(good, CAM, (0.0, 0.0), t_capture=0, time_usec=0)
    bad = Pose(np.array([0.0, math.inf, 2.0]), np.eye(3), 0.1, True)
    with pytest.raises(ValueError, match="pose"):
        pad_fix(bad, CAM, (0.0, 0.0, 0.0), t_capture=0, time_usec=0)
    with pytest.raises(ValueError, match="mount_rotation"):
        pad_fix(good, CAM, (0, 0, 0), t_capture=0, time_usec=0, mount_rotation=np.eye(2))
