"""The pad's pixels weighed against the attitude: by what they show, not by how many
vertices the reference's marks happen to have."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import Camera, Reference
from pipeline.measure import WEIGHED_POINTS, _fit_pose
from pipeline.pose import pad_normal_in_camera, pose_to_vectors, tilt_from_level_deg
from pipeline.render import camera_rotation, get_design
from pipeline.result import Pose

CAM = Camera.from_fov(640, 480, 60.0)


@pytest.fixture(scope="module")
def ringed() -> Reference:
    """A pad whose marks (a ring, a hexagon) are polygons of many vertices."""
    design = get_design("red_on_black")
    return Reference.from_image(design.draw().image, design.size_m)


def _view(reference: Reference, stretch: float = 0.0):
    """The homography of the pad 10 m below a camera tilted 8 degrees, its width
    ``stretch`` too large (a bias of the edges that no level pad shows, and that the
    pose can only take for a tilt), and the camera's attitude."""
    position = np.array([0.3, -0.2, 10.0])
    R_pad_cam = camera_rotation(30.0, tilt_deg=8.0, tilt_dir_deg=40.0)
    rvec, tvec = pose_to_vectors(Pose(position, R_pad_cam, 0.0, True))
    R = np.asarray(R_pad_cam).T
    H = CAM.K @ np.column_stack([R[:, 0], R[:, 1], tvec.reshape(3)]) @ np.diag([1 + stretch, 1, 1])
    return H / H[2, 2], -pad_normal_in_camera(rvec)


def _pose(reference: Reference, H: np.ndarray, gravity: np.ndarray, pts_m: np.ndarray):
    levels = np.zeros((CAM.height, CAM.width), np.uint8)
    fitted = _fit_pose(reference, levels, CAM, H, pts_m, polish=False, gravity=gravity)
    assert fitted is not None
    return fitted[0]


def test_a_point_listed_twice_weighs_no_more(ringed):
    # Every pose point is placed by one homography: listing each twice (a ring drawn
    # with twice the vertices) must not pull the pose toward the pixels.
    pts = ringed.pose_points_m
    assert len(pts) > WEIGHED_POINTS
    H, gravity = _view(ringed, stretch=0.01)
    once = _pose(ringed, H, gravity, pts)
    twice = _pose(ringed, H, gravity, np.vstack([pts, pts]))
    assert np.allclose(once.rvec, twice.rvec, atol=1e-9)
    assert np.allclose(once.tvec, twice.tvec, atol=1e-9)


def test_a_ringed_pad_is_held_level_as_a_plain_one_is(ringed):
    # Pixels 1 % too wide, posed from the H's corners and the marks' 200-odd vertices
    # under the attitude: the ring's vertices add span, not a count that outweighs the
    # attitude (they had leaned the pose 1.9 degrees; the default pad's 24 points, 0.01).
    H, gravity = _view(ringed, stretch=0.01)
    assert tilt_from_level_deg(_pose(ringed, H, gravity, ringed.corners_m).rvec, gravity) < 0.1
    assert tilt_from_level_deg(_pose(ringed, H, gravity, ringed.pose_points_m).rvec, gravity) < 0.5
