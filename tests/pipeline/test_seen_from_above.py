"""A located H, or a pose, that no camera above the pad could see is not taken.

An H is mirror-symmetric: a homography that mirrors it puts its corners, relabelled, on
the H's own, and the edges under them are all found. An H fitted astray on a paved
floor (a photographed reference, an empty frame from the shared negatives) came out
mirrored and folded through its vanishing line, its corners bunched at the frame's
edge; measured, it gave a "detection" with the camera 0.9 m under the ground. A
far pad's H (4 px) fitted astray on a floor passed as seen, and its pose put the
camera 2 cm under the ground looking up (68 px off its own points). Without the
attitude, an H squashed to a sliver on a carpet's noise was posed 18 % of its span
off its own points: no plane this camera sees (``measure.MAX_UNPOSED``; since the
reference's corners are placed off the pixel grid that photo's view no longer reaches
the check: `tests.pipeline.test_faint_h` shows its part on another). Another sliver
there fitted its points within 5 % of its span, posed 86 degrees off the pad's normal
(``measure.MAX_VIEW_DEG``): no camera over a pad sees it so.
"""

from __future__ import annotations

import numpy as np
import pytest

import pipeline.measure
from pipeline.homography_fit import MAX_DEPTH_RATIO, seen_from_above
from pipeline.measure import MAX_VIEW_DEG, _seen_from_deg, measure
from pipeline.pose import camera_height_m, pose_to_vectors
from pipeline.render import camera_rotation
from pipeline.result import Pose
from tests.pipeline.bench_support import (
    CAM,
    bench_frames,
    needs_photos,
    photo_detected,
    photo_view,
    true_homography,
)

MIRRORS = {"left-right": np.diag([-1.0, 1.0, 1.0]), "top-bottom": np.diag([1.0, -1.0, 1.0])}


@pytest.mark.parametrize("i", [0, 7, 19])
def test_the_true_h_is_measured_and_its_mirror_images_are_not(i):
    pad, _, _, view, reference = bench_frames("default", 0, i, "today")
    H = true_homography(view.position_m, view.R_pad_cam)
    assert measure(pad, reference, CAM, H, gravity=None) is not None
    for name, mirror in MIRRORS.items():
        assert not seen_from_above(H @ mirror, reference.corners_m), name
        assert measure(pad, reference, CAM, H @ mirror, gravity=None) is None, name


def test_an_h_across_its_vanishing_line_or_stretched_into_the_distance_is_not_seen():
    corners = np.array([[-1.0, 1.0], [1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]])
    view = np.array([[100.0, 0.0, 320.0], [0.0, -100.0, 240.0], [0.0, 0.0, 1.0]])
    assert seen_from_above(view, corners)
    # depth growing along y: the far corners MAX_DEPTH_RATIO times as far, and beyond
    for k, seen in ((0.99, True), (1.01, False)):
        slope = (MAX_DEPTH_RATIO * k - 1.0) / (MAX_DEPTH_RATIO * k + 1.0)
        tilted = view @ np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, slope, 1.0]])
        assert seen_from_above(tilted, corners) is seen, k
    # the vanishing line through the H: corners on both sides of it
    folded = view @ np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 1.0]])
    assert not seen_from_above(folded, corners)
    assert not seen_from_above(np.zeros((3, 3)), corners)


@pytest.mark.parametrize("height", [3.0, 0.2, -0.02, -3.0])
def test_the_cameras_height_over_the_pad_is_told_from_its_pose(height):
    """Under the ground (a pose of edges taken astray), the height comes out negative."""
    R_pad_cam = camera_rotation(30.0, tilt_deg=20.0, tilt_dir_deg=45.0)
    if height < 0:
        R_pad_cam = np.diag([1.0, -1.0, -1.0]) @ R_pad_cam  # (looking up at the pad's plane)
    pose = Pose(np.array([0.4, -0.3, height]), R_pad_cam, 0.1, False)
    assert camera_height_m(*pose_to_vectors(pose)) == pytest.approx(height)


@pytest.mark.parametrize("off_deg", [0.0, 35.0, 74.0, 86.0])
def test_the_angle_a_pad_is_seen_from_is_told_from_its_pose(off_deg):
    """The camera 3 m from the pad's centre, ``off_deg`` from its normal, whatever it
    looks at; past MAX_VIEW_DEG no camera over a pad sees it so."""
    a = np.radians(off_deg)
    position = 3.0 * np.array([np.sin(a) * 0.6, np.sin(a) * 0.8, np.cos(a)])
    R_pad_cam = camera_rotation(30.0, tilt_deg=20.0, tilt_dir_deg=45.0)
    pose = Pose(position, R_pad_cam, 0.1, False)
    assert _seen_from_deg(*pose_to_vectors(pose)) == pytest.approx(off_deg, abs=1e-6)
    assert (off_deg > MAX_VIEW_DEG) is (off_deg == 86.0)


@needs_photos
@pytest.mark.slow
def test_an_h_squashed_to_a_sliver_seen_from_the_pads_side_is_no_pad(monkeypatch):
    # The photos bench's negative neg_111 (carpet), seed 7, view 2: with the inverted
    # dark block H's reference, a sliver of 5 x 43 px by the photo's rotated border was
    # posed with the camera 0.6 m up and 9 m aside, 86 degrees off the pad's normal.
    image = photo_view("neg_111", 7, 2)
    assert not photo_detected(image, "refs/dark_block_H_synth_inverted.png")
    monkeypatch.setattr(pipeline.measure, "MAX_VIEW_DEG", 90.0)
    assert photo_detected(image, "refs/dark_block_H_synth_inverted.png")
