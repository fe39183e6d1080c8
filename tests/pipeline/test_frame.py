import json
import math
import re

import cv2
import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.pose import TURN
from pipeline.render import (
    DESIGNS,
    camera_rotation,
    make_pad_image,
    make_scene,
    random_view,
    render,
    render_view,
)
from pipeline.result import yaw_of

CAM = Camera.from_fov(640, 480, 60.0)


@pytest.fixture(scope="module")
def pad():
    return make_pad_image(1100)


@pytest.fixture(scope="module")
def reference(pad):
    return Reference.from_image(pad, 0.55)


@pytest.fixture(scope="module")
def scene(pad):
    return make_scene(pad, 0.55, rng=np.random.default_rng(4), lookalikes=2)


def _errors(pose, position, R, symmetric=True):
    """Position error (% of altitude) and rotation error (deg), modulo the pad's half turn."""
    best = (math.inf, math.inf)
    twins = [(position, R), (TURN @ position, TURN @ R)] if symmetric else [(position, R)]
    for p, r in twins:
        pos = 100 * np.linalg.norm(pose.position_m - p) / p[2]
        c = (np.trace(pose.R_pad_cam.T @ r) - 1) / 2
        rot = math.degrees(math.acos(np.clip(c, -1, 1)))
        best = min(best, (pos, rot))
    return best


@pytest.mark.parametrize(
    ("position", "yaw", "tilt"),
    [
        ((0.0, 0.0, 1.2), 0.0, 0.0),
        ((0.3, -0.2, 2.5), 40.0, 6.0),
        ((-0.6, 0.4, 4.0), -120.0, 10.0),
        ((0.5, 0.3, 5.5), 170.0, 3.0),
    ],
)
def test_pose_over_the_pad(reference, scene, position, yaw, tilt):
    R = camera_rotation(yaw, tilt_deg=tilt, tilt_dir_deg=30.0)
    p = np.array(position)
    frame = render(scene, CAM, p, R, snr_db=25.0, blur_sigma_px=0.6, rng=np.random.default_rng(1))
    res = process_frame(frame, reference, CAM)
    assert res.detected and res.pose is not None
    pos_err, rot_err = _errors(res.pose, p, R)
    assert pos_err < 3.0
    assert rot_err < 3.0
    assert res.pose.symmetric
    assert res.corners_px.shape == (12, 2)
    assert len(res.hu) == 7 and res.hu[0] > 0
    assert set(res.timings_ms) >= {"preprocess", "contours", "corners", "pose", "total"}


def test_yaw_hint_picks_between_the_two_poses_of_a_symmetric_pad(reference, scene):
    R = camera_rotation(60.0)
    frame = render(scene, CAM, np.array([0.2, 0.1, 2.0]), R)
    near = process_frame(frame, reference, CAM, yaw_hint=55.0)
    far = process_frame(frame, reference, CAM, yaw_hint=-120.0)
    assert abs(yaw_of(near.pose.R_pad_cam) - 60.0) < 1.0
    assert abs(abs(yaw_of(far.pose.R_pad_cam)) - 120.0) < 1.0
    np.testing.assert_allclose(near.pose.position_m, [0.2, 0.1, 2.0], atol=0.03)
    np.testing.assert_allclose(far.pose.position_m, [-0.2, -0.1, 2.0], atol=0.03)


@pytest.mark.parametrize("yaw", [0.0, 25.0, 170.0, -100.0])
def test_corners_follow_the_reference_order(reference, scene, yaw):
    from pipeline.render import project_points

    R = camera_rotation(yaw)
    p = np.array([0.1, 0.0, 1.5])
    frame = render(scene, CAM, p, R)
    res = process_frame(frame, reference, CAM, yaw_hint=yaw)
    truth = project_points(CAM, p, R, np.column_stack([reference.corners_m, np.zeros(12)]))
    assert np.max(np.linalg.norm(res.corners_px - truth, axis=1)) < 0.5


def test_no_pad_no_detection_and_no_exception(reference, pad):
    rng = np.random.default_rng(11)
    hits = 0
    for _ in range(12):
        empty = make_scene(pad, 0.55, rng=rng, lookalikes=3, pad_visible=False)
        view = random_view(rng, CAM)
        res = process_frame(render_view(empty, CAM, view, rng), reference, CAM)
        hits += res.detected
        if not res.detected:
            assert res.pose is None and res.reason
    assert hits == 0


def test_the_reason_names_the_shade_of_shapes_looked_at(reference, pad):
    """A dark H is looked for among dark shapes, and the reason says so."""
    frame = np.full((480, 640, 3), 200, np.uint8)
    cv2.circle(frame, (320, 240), 60, (40, 40, 40), -1)
    cv2.rectangle(frame, (100, 100), (160, 130), (230, 230, 230), -1)
    dark = Reference.from_image(cv2.bitwise_not(pad), 0.55)
    assert dark.polarity == "dark" and reference.polarity == "bright"
    # (the count is over every threshold and view tried)
    assert re.fullmatch(r"no H among \d+ dark shape\(s\)", process_frame(frame, dark, CAM).reason)
    assert re.fullmatch(
        r"no H among \d+ bright shape\(s\)", process_frame(frame, reference, CAM).reason
    )


def test_blank_frame(reference):
    res = process_frame(np.zeros((480, 640, 3), np.uint8), reference, CAM)
    assert not res.detected and res.pose is None
    json.dumps(res.to_dict())


def test_large_frames_are_subsampled_and_reported_in_input_pixels(reference, scene):
    big_cam = Camera.from_fov(1280, 960, 60.0)
    R = camera_rotation(10.0)
    frame = render(scene, big_cam, np.array([0.0, 0.1, 2.0]), R)
    res = process_frame(frame, reference, big_cam)
    assert res.detected
    np.testing.assert_allclose(res.pose.position_m, [0.0, 0.1, 2.0], atol=0.03)
    assert res.corners_px[:, 0].max() > 640  # input pixels, not working pixels


def test_a_camera_at_another_resolution_of_the_same_aspect_is_scaled(reference, scene):
    frame = render(scene, CAM, np.array([0.0, 0.0, 2.0]), camera_rotation(0.0))
    res = process_frame(frame, reference, Camera.from_fov(1280, 960, 60.0))
    assert res.detected
    assert res.pose.position_m[2] == pytest.approx(2.0, abs=0.03)


def test_lens_distortion_is_handled(reference, scene):
    cam = Camera(640, 480, CAM.K, np.array([-0.2, 0.05, 0.0, 0.0, 0.0]))
    R = camera_rotation(-30.0, tilt_deg=5.0)
    p = np.array([0.4, -0.3, 2.0])
    frame = render(scene, cam, p, R)
    res = process_frame(frame, reference, cam)
    assert res.detected
    pos_err, rot_err = _errors(res.pose, p, R)
    assert pos_err < 1.0 and rot_err < 1.0
    # The same frame read as if undistorted gives a worse pose.
    wrong = process_frame(frame, reference, CAM)
    if wrong.pose is not None:
        assert _errors(wrong.pose, p, R)[0] > pos_err


def test_to_dict_is_json_serialisable(reference, scene):
    frame = render(scene, CAM, np.array([0.0, 0.0, 2.0]), camera_rotation(0.0))
    d = process_frame(frame, reference, CAM).to_dict()
    text = json.dumps(d)
    assert '"detected": true' in text
    assert len(d["corners_px"]) == 12 and len(d["pose"]["R_pad_cam"]) == 3


@pytest.mark.parametrize(
    ("frame", "message"),
    [
        (None, "image_bgr"),
        (np.zeros((480, 640, 3), np.float64), "image_bgr"),
        (np.zeros((480, 640, 5), np.uint8), "image_bgr"),
        (np.zeros((0, 0, 3), np.uint8), "image_bgr"),
        ("frame.png", "image_bgr"),
    ],
)
def test_bad_frames_raise_value_error_naming_the_parameter(reference, frame, message):
    with pytest.raises(ValueError, match=message):
        process_frame(frame, reference, CAM)


def test_bad_arguments(reference):
    frame = np.zeros((480, 640, 3), np.uint8)
    with pytest.raises(ValueError, match="reference"):
        process_frame(frame, "pad.png", CAM)
    with pytest.raises(ValueError, match="camera"):
        process_frame(frame, reference, None)
    with pytest.raises(ValueError, match="yaw_hint"):
        process_frame(frame, reference, CAM, yaw_hint=float("nan"))
    with pytest.raises(ValueError, match="aspect"):
        process_frame(np.zeros((480, 480, 3), np.uint8), reference, CAM)
    with pytest.raises(ValueError, match="method"):
        process_frame(frame, reference, CAM, method="magic")


@pytest.mark.parametrize("method", ["otsu", "adaptive", "seed"])
def test_every_threshold_method_finds_a_clean_pad(reference, scene, method):
    frame = render(scene, CAM, np.array([0.0, 0.0, 1.5]), camera_rotation(15.0))
    assert process_frame(frame, reference, CAM, method=method).detected


def _plain_h_pad(size: int = 1000) -> np.ndarray:
    """Another pad design: no side bars, a bolder H, a gray board."""
    pad = np.full((size, size, 3), 45, np.uint8)
    s = size / 100
    for x0, y0, x1, y1 in ((20, 18, 38, 82), (62, 18, 80, 82), (38, 42, 62, 58)):
        cv2.rectangle(
            pad,
            (round(x0 * s), round(y0 * s)),
            (round(x1 * s) - 1, round(y1 * s) - 1),
            (235, 235, 235),
            -1,
        )
    return pad


@pytest.mark.parametrize("floor", ["asphalt", "grass", "concrete"])
def test_another_pad_design_on_any_floor(floor):
    pad = _plain_h_pad()
    reference = Reference.from_image(pad, 0.8)
    assert not any(m.bright for m in reference.marks)  # no bars
    scene = make_scene(pad, 0.8, rng=np.random.default_rng(6), floor=floor)
    R = camera_rotation(-50.0, tilt_deg=5.0, tilt_dir_deg=200.0)
    p = np.array([0.3, 0.2, 3.5])
    frame = render(scene, CAM, p, R, snr_db=20.0, blur_sigma_px=0.8, rng=np.random.default_rng(2))
    res = process_frame(frame, reference, CAM, yaw_hint=-50.0)
    assert res.detected
    pos_err, rot_err = _errors(res.pose, p, R)
    assert pos_err < 2.0 and rot_err < 2.0


class _Verdict:
    """A verifier that answers the same for every candidate, recording what it saw."""

    def __init__(self, answer: bool) -> None:
        self.answer = answer
        self.seen: list[tuple[np.ndarray, np.ndarray]] = []

    def accepts(self, corners_px, contour_px, camera) -> bool:
        self.seen.append((corners_px, contour_px))
        return self.answer


def test_the_verifier_is_consulted_before_the_pose(reference, scene):
    frame = render(scene, CAM, np.array([0.0, 0.0, 2.0]), camera_rotation(0.0))
    yes, no = _Verdict(True), _Verdict(False)
    assert process_frame(frame, reference, CAM, verifier=yes).detected
    assert yes.seen and yes.seen[0][0].shape == (12, 2)
    res = process_frame(frame, reference, CAM, verifier=no)
    assert not res.detected and res.pose is None
    assert "verifier rejected" in res.reason


def test_an_h_without_the_dark_board_around_it_is_not_the_pad(reference):
    # The same H and bars painted straight onto a gray floor: every edge is where the
    # pad's would be, but the board around the H is missing.
    painted = make_pad_image(1100, board_bgr=(140, 140, 140))
    scene = make_scene(painted, 0.55, rng=np.random.default_rng(5), floor="plain")
    frame = render(scene, CAM, np.array([0.1, 0.1, 2.0]), camera_rotation(30.0))
    res = process_frame(frame, reference, CAM)
    assert not res.detected
    assert "board around them" in res.reason


def test_a_pad_whose_heading_marks_are_not_seen_is_reported_as_symmetric():
    # The shared photos' pad: its triangle above the H tells its heading.
    design = DESIGNS["paper_ring"]
    picture = design.draw(800).image
    reference = Reference.from_image(picture, design.size_m)
    assert not reference.symmetric
    # The same pad with its triangle hidden (taped over, say).
    hidden = picture.copy()
    hidden[150:235, 550:645] = picture[300, 200]
    R = camera_rotation(30.0, tilt_deg=3.0, tilt_dir_deg=100.0)
    p = np.array([0.02, -0.03, 0.9])
    for pad, told in ((picture, True), (hidden, False)):
        scene = make_scene(pad, design.size_m, rng=np.random.default_rng(3), floor="plain")
        frame = render(scene, CAM, p, R, snr_db=30.0, rng=np.random.default_rng(4))
        res = process_frame(frame, reference, CAM, yaw_hint=30.0)
        assert res.detected and res.pose.symmetric is not told
        # told by its marks, or picked by the caller's heading: the right one either way
        pos_err, rot_err = _errors(res.pose, p, R, symmetric=False)
        assert pos_err < 2.0 and rot_err < 2.0
