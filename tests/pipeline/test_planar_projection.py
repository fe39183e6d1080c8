import cv2
import numpy as np
import pytest

from pipeline.camera import Camera
from pipeline.planar_projection import project_plane

K = np.array([[554.0, 0.0, 319.5], [0.0, 560.0, 239.5], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize(
    "dist",
    [
        np.zeros(5),
        np.array([-0.2, 0.05, 0.001, -0.002, 0.01]),  # radial and tangential
        np.array([0.1, -0.02, 0.0, 0.0]),  # four coefficients
        np.array([-0.2, 0.05, 0.001, -0.002, 0.01, 0.02, 0.0, 0.0]),  # rational: OpenCV's
    ],
)
@pytest.mark.parametrize(
    "rvec", [np.zeros(3), np.array([0.3, -0.2, 0.25]), np.array([2.9, 0.4, -0.3])]
)
def test_points_and_their_derivatives_by_the_pose_are_opencvs(dist, rvec):
    cam = Camera(640, 480, K, dist)
    pts = np.random.default_rng(0).uniform(-0.4, 0.4, (200, 2))
    tvec = np.array([0.1, -0.2, 3.0])
    proj, jac = project_plane(pts, rvec, tvec.reshape(3, 1), cam)
    want, want_jac = cv2.projectPoints(np.column_stack([pts, np.zeros(200)]), rvec, tvec, K, dist)
    assert np.abs(proj - want.reshape(-1, 2)).max() < 1e-9
    assert np.abs(jac - want_jac[:, :6].reshape(200, 2, 6)).max() < 1e-6


def test_a_point_at_depth_zero_projects_as_opencvs_does():
    # (OpenCV takes 1/z as 1 there: no division by zero, no exception)
    cam = Camera(640, 480, K)
    proj, _ = project_plane(np.array([[0.1, 0.2]]), np.zeros(3), np.zeros(3), cam)
    want, _ = cv2.projectPoints(np.array([[0.1, 0.2, 0.0]]), np.zeros(3), np.zeros(3), K, None)
    assert np.allclose(proj, want.reshape(-1, 2))
