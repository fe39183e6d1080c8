"""The H in view fitted with its strokes' widths free: a pad drawn a little unlike its
reference picture (printing, fabric, a synthetic drawing) is still found whole."""

import cv2
import numpy as np
import pytest

from pipeline import Camera, Reference
from pipeline.hfit import h_deformation
from pipeline.homography_fit import Deformation, apply_h, fit_homography
from pipeline.pose import pose_to_vectors
from pipeline.render import PadGeometry, camera_rotation, make_pad_image, make_scene, render
from pipeline.result import Pose

CAM = Camera.from_fov(640, 480, 60.0)


def test_only_an_h_has_a_stroke_deformation():
    assert h_deformation(PadGeometry().h_corners_m) is not None
    a, b = 0.03, 0.12
    plus = np.array(
        [[-a, b], [a, b], [a, a], [b, a], [b, -a], [a, -a],
         [a, -b], [-a, -b], [-a, -a], [-b, -a], [-b, a], [-a, a]]
    )  # fmt: skip
    assert h_deformation(plus) is None
    assert h_deformation(PadGeometry().h_corners_m[:8]) is None


@pytest.mark.parametrize("start", [0, 5])
def test_the_deformation_moves_the_inner_edges_only(start):
    corners = np.roll(PadGeometry().h_corners_m, -start, axis=0)  # any first corner
    d = h_deformation(corners)
    moved = d.corners(corners, np.array([0.01]))  # bolder strokes
    shift = np.roll(moved - corners, start, axis=0)  # in the H's own numbering
    assert np.allclose(shift[[0, 5, 6, 11]], 0.0)  # the outer box stays
    # the legs 0.01 wider inward, the crossbar 0.005 thicker on each side
    assert np.allclose(np.abs(shift[[1, 4, 7, 10]]).sum(axis=1), 0.01)
    np.testing.assert_allclose(np.abs(shift[[2, 3, 8, 9]]), [[0.01, 0.005]] * 4)


def test_a_pad_with_lighter_strokes_than_its_picture_is_fitted_whole():
    reference = Reference.from_image(make_pad_image(800), 0.55)
    # The reference's legs are 0.12 of the pad wide and its crossbar 0.10.
    thin = make_pad_image(800, leg_width=0.105, crossbar_height=0.085)
    scene = make_scene(thin, 0.55, rng=np.random.default_rng(0), floor="plain")
    R = camera_rotation(30.0, tilt_deg=5.0, tilt_dir_deg=40.0)
    position = np.array([0.05, -0.1, 2.2])
    frame = render(scene, CAM, position, R, snr_db=35, rng=np.random.default_rng(1))
    levels = cv2.GaussianBlur(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY), (5, 5), 1.0)
    rvec, tvec = pose_to_vectors(Pose(position, R, 0.0, True))
    Rm, _ = cv2.Rodrigues(rvec)
    true = CAM.K @ np.column_stack([Rm[:, 0], Rm[:, 1], tvec.ravel()])
    true /= true[2, 2]
    rigid = fit_homography(levels, reference.h_edges, true)
    free = fit_homography(levels, reference.h_edges, true, deform=reference.h_deformation)
    assert rigid is not None and free is not None
    assert free.support > 0.95 > 0.8 > rigid.support
    # The strokes came out 0.015 of the pad's width (0.00825 m) lighter.
    np.testing.assert_allclose(free.shape, [-0.00825], atol=0.0015)
    # The outer box did not move with the legs.
    outer = reference.corners_m[[0, 5, 6, 11]]
    assert np.abs(apply_h(free.H, outer) - apply_h(true, outer)).max() < 0.3


def test_no_deformation_is_the_rigid_fit():
    d = Deformation.none(12)
    corners = PadGeometry().h_corners_m
    assert d.corners(corners, np.zeros(0)) is corners
