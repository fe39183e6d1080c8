import json
import math

import cv2
import numpy as np
import pytest

from pipeline import Camera


def test_from_fov_focal_length_is_half_width_over_tan_half_fov():
    cam = Camera.from_fov(640, 480, 60.0)
    assert cam.fx == pytest.approx(320 / math.tan(math.radians(30)))
    assert cam.fy == cam.fx
    assert cam.K[0, 2] == pytest.approx(319.5) and cam.K[1, 2] == pytest.approx(239.5)
    assert cam.hfov_deg == pytest.approx(60.0)
    assert not cam.has_distortion


def _write_yaml(path, K, dist, w, h):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", w)
    fs.write("image_height", h)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", dist)
    fs.release()


def test_from_file_reads_opencv_yaml(tmp_path):
    K = np.array([[500.0, 0, 320], [0, 505.0, 240], [0, 0, 1]])
    dist = np.array([[-0.2, 0.05, 0.001, -0.002, 0.0]])
    path = tmp_path / "calib.yaml"
    _write_yaml(path, K, dist, 640, 480)
    cam = Camera.from_file(path)
    assert (cam.width, cam.height) == (640, 480)
    np.testing.assert_allclose(cam.K, K)
    np.testing.assert_allclose(cam.dist, dist.ravel())
    assert cam.has_distortion


@pytest.mark.parametrize("matrix_form", ["nested", "opencv"])
def test_from_file_reads_json(tmp_path, matrix_form):
    K = [[600.0, 0, 330], [0, 600.0, 250], [0, 0, 1]]
    km = (
        K
        if matrix_form == "nested"
        else {"rows": 3, "cols": 3, "data": [v for row in K for v in row]}
    )
    data = {"image_width": 640, "image_height": 480, "camera_matrix": km}
    data["distortion_coefficients"] = [0.1, -0.05, 0, 0, 0]
    path = tmp_path / "calib.json"
    path.write_text(json.dumps(data))
    cam = Camera.from_file(path)
    np.testing.assert_allclose(cam.K, K)
    assert cam.dist[0] == pytest.approx(0.1)


def test_undistort_points_inverts_projection(tmp_path):
    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    cam = Camera(640, 480, K, np.array([-0.25, 0.08, 0.0, 0.0, 0.0]))
    pts3 = np.array([[0.3, -0.2, 1.0], [-0.4, 0.25, 1.0]])
    distorted, _ = cv2.projectPoints(pts3, np.zeros(3), np.zeros(3), K, cam.dist)
    ideal = (K @ pts3.T).T
    ideal = ideal[:, :2] / ideal[:, 2:]
    np.testing.assert_allclose(cam.undistort_points(distorted.reshape(-1, 2)), ideal, atol=1e-3)


def test_scaled_keeps_the_field_of_view():
    cam = Camera.from_fov(1280, 960, 70.0).scaled(640, 480)
    assert cam.hfov_deg == pytest.approx(70.0, abs=1e-6)
    assert cam.K[0, 2] == pytest.approx(319.5)


def test_a_window_or_size_of_a_camera_is_the_camera_checked_again():
    cam = Camera(640, 480, Camera.from_fov(640, 480, 60.0).K, [-0.2, 0.05, 0.001, 0.0, 0.01])
    assert cam.brown_conrady is not None  # (worked out once, shared with the windows)
    for view in (cam.cropped(100, 50, 200, 150), cam.cropped(100, 50, 200, 150).scaled(300, 225)):
        again = Camera(view.width, view.height, view.K, view.dist)
        np.testing.assert_array_equal(view.K, again.K)
        np.testing.assert_array_equal(view.brown_conrady, again.brown_conrady)
        assert not view.K.flags.writeable and not view.dist.flags.writeable
    with pytest.raises(ValueError, match="width and height"):
        cam.cropped(0, 0, 0, 480)
    with pytest.raises(ValueError, match="width and height"):
        cam.scaled(320, -1)
    with pytest.raises(ValueError, match="width and height"):
        cam.cropped(0, 0, 0.5, 480)
    with pytest.raises(ValueError, match="finite"):
        cam.cropped(float("nan"), 0, 640, 480)


@pytest.mark.parametrize(
    ("args", "word"),
    [((0, 480, 60), "width"), ((640, 480, 0), "hfov_deg"), ((640, 480, 180), "hfov_deg")],
)
def test_from_fov_rejects_bad_arguments(args, word):
    with pytest.raises(ValueError, match=word):
        Camera.from_fov(*args)


def test_from_file_errors_name_the_problem(tmp_path):
    with pytest.raises(ValueError, match="no calibration file"):
        Camera.from_file(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        Camera.from_file(bad)
    partial = tmp_path / "partial.json"
    partial.write_text(json.dumps({"camera_matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}))
    with pytest.raises(ValueError, match="image_width"):
        Camera.from_file(partial)


def test_camera_rejects_bad_matrix():
    with pytest.raises(ValueError, match="K must be"):
        Camera(640, 480, np.eye(2))
    with pytest.raises(ValueError, match="dist"):
        Camera(640, 480, np.eye(3) * 500 + np.diag([0, 0, -499]), np.array([np.nan] * 5))
