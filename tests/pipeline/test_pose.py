import numpy as np
import pytest

from pipeline import Camera, Reference
from pipeline.edgefit import RESOLVED_PX, EdgeModel, edge_support, fit_edges
from pipeline.pose import (
    ippe_candidates,
    pick_by_yaw,
    pose_to_vectors,
    project,
    tilt_deg,
    to_pose,
    turned,
)
from pipeline.preprocess import binarize
from pipeline.render import camera_rotation, make_pad_image, make_scene, render
from pipeline.result import Pose

CAM = Camera.from_fov(640, 480, 60.0)


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(make_pad_image(800), 0.55)


def test_vectors_round_trip():
    pose = Pose(np.array([0.3, -0.2, 2.5]), camera_rotation(40.0, tilt_deg=7.0), 0.0, True)
    back = to_pose(*pose_to_vectors(pose), 0.0, True)
    np.testing.assert_allclose(back.position_m, pose.position_m, atol=1e-9)
    np.testing.assert_allclose(back.R_pad_cam, pose.R_pad_cam, atol=1e-9)


def test_twin_is_a_half_turn_about_the_pad_and_the_hint_picks():
    pose = Pose(np.array([0.3, -0.2, 2.5]), camera_rotation(40.0), 0.1, True)
    twin = turned(pose)
    np.testing.assert_allclose(twin.position_m, [-0.3, 0.2, 2.5])
    assert twin.yaw_deg == pytest.approx(-140.0)
    assert pick_by_yaw(pose, 30.0) is pose
    assert pick_by_yaw(pose, -150.0).yaw_deg == pytest.approx(-140.0)
    asym = Pose(pose.position_m, pose.R_pad_cam, 0.1, False)
    assert pick_by_yaw(asym, -150.0) is asym  # no twin for an asymmetric pad


def test_tilt_of_a_nadir_camera_is_zero():
    for tilt in (0.0, 5.0, 12.0):
        pose = Pose(np.array([0, 0, 3.0]), camera_rotation(70.0, tilt_deg=tilt), 0, True)
        assert tilt_deg(pose_to_vectors(pose)[0]) == pytest.approx(tilt, abs=1e-6)


def test_ippe_returns_the_true_pose_among_its_candidates(reference):
    R = camera_rotation(10.0, tilt_deg=4.0)
    pose = Pose(np.array([0.2, 0.1, 2.0]), R, 0.0, True)
    px = project(reference.corners_m, *pose_to_vectors(pose), CAM)
    found = [to_pose(r, t, 0, True) for r, t in ippe_candidates(reference.corners_m, px, CAM)]
    assert min(np.linalg.norm(p.position_m - pose.position_m) for p in found) < 1e-6


def test_edge_fit_recovers_the_pose_from_a_disturbed_start(reference):
    R = camera_rotation(-35.0, tilt_deg=6.0, tilt_dir_deg=100.0)
    truth = Pose(np.array([0.4, -0.3, 3.0]), R, 0.0, True)
    scene = make_scene(make_pad_image(800), 0.55, rng=np.random.default_rng(0))
    frame = render(scene, CAM, truth.position_m, R)
    smooth = binarize(frame, "otsu").smooth
    rvec, tvec = pose_to_vectors(truth)
    # A start about a pixel off, as IPPE on the corners gives.
    start = (
        rvec + np.array([[0.001], [-0.001], [0.001]]),
        tvec + np.array([[0.005], [0.004], [0.01]]),
    )
    fit = fit_edges(smooth, reference.edge_model, CAM, *start)
    got = to_pose(fit.rvec, fit.tvec, fit.rms_px, True)
    assert np.linalg.norm(got.position_m - truth.position_m) < 0.01
    assert fit.rms_px < 0.3
    assert edge_support(smooth, reference.edge_model, CAM, fit.rvec, fit.tvec) > 0.9
    # Where there is no pad, the pad's edges are not found.
    blank = binarize(np.full_like(frame, 120), "otsu").smooth
    assert edge_support(blank, reference.edge_model, CAM, fit.rvec, fit.tvec) < 0.1


def test_edge_support_counts_only_the_sides_a_frame_tells_apart(reference):
    # A ring the pad does not have, put in its model around the H: 2 mm wide (under half
    # a pixel 3 m away) it is not looked for; 3 cm wide it is, and, not found, lowers the
    # support.
    R = camera_rotation(20.0, tilt_deg=3.0)
    truth = Pose(np.array([0.1, 0.2, 3.0]), R, 0.0, True)
    frame = render(
        make_scene(make_pad_image(800), 0.55, rng=np.random.default_rng(1)),
        CAM,
        truth.position_m,
        R,
    )
    smooth = binarize(frame, "otsu").smooth
    rvec, tvec = pose_to_vectors(truth)
    square = np.array([(-0.2, -0.2), (0.2, -0.2), (0.2, 0.2), (-0.2, 0.2)])
    h = [(reference.corners_m, True)]
    alone = edge_support(
        smooth, EdgeModel.from_polygons(h), CAM, rvec, tvec, resolved_px=RESOLVED_PX
    )
    assert alone > 0.9
    for width_m, unchanged in ((0.002, True), (0.03, False)):
        ring = [(square, True), (square * (1.0 - width_m / 0.2), False)]
        model = EdgeModel.from_polygons(h + ring)
        support = edge_support(smooth, model, CAM, rvec, tvec, resolved_px=RESOLVED_PX)
        assert (support == pytest.approx(alone)) is unchanged, (width_m, support, alone)


def test_the_pads_up_is_opencvs_rotations_third_column_to_the_bit():
    import cv2

    from pipeline.pose import pad_normal_in_camera, project

    rng = np.random.default_rng(8)
    cam = Camera.from_fov(640, 480, 60.0)
    pts = rng.uniform(-0.3, 0.3, (12, 2))
    for scale in (0.0, 1e-17, 1e-8, 0.1, 1.0, 3.0):
        for _ in range(50):
            r = rng.normal(0, scale, 3) if scale else np.zeros(3)
            R, _ = cv2.Rodrigues(r.reshape(3, 1))
            np.testing.assert_array_equal(pad_normal_in_camera(r), R[:, 2])
            t = np.array([0.1, -0.2, 3.0])
            want, _ = cv2.projectPoints(np.column_stack([pts, np.zeros(12)]), r, t, cam.K, cam.dist)
            np.testing.assert_allclose(project(pts, r, t, cam), want.reshape(-1, 2), atol=1e-9)
