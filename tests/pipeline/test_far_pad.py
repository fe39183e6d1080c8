"""A far pad on a small frame: found on the frame enlarged, then followed or tracked.

With the vehicle's attitude and heading as hints, as the station gives them: so far
away the two planar poses fit the pixels alike.

At 18 m a 0.55 m pad spans 17 px of a 640 x 480 frame at 60 degrees, its H's legs
2-3 px: thresholded at the frame's own pixels the legs merge or break. Interpolated
to twice the size, the H keeps its shape and corners (`pipeline.frame`'s last search).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pipeline.measure
from pipeline import Camera, Reference, process_frame
from pipeline.bench.hint import gravity_hint
from pipeline.bench.tally import Tally
from pipeline.render import camera_rotation, make_pad_image, make_scene, render
from pipeline.view import View
from tests.pipeline.bench_support import sweep_frames

CAM = Camera.from_fov(640, 480, 60.0)
WIDE = Camera.from_fov(1280, 720, 60.0)


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(make_pad_image(800), 0.55)


def _frames(altitude: float, count: int):
    for k in range(count):
        rng = np.random.default_rng(100 + k)
        scene = make_scene(make_pad_image(800), 0.55, rng=rng)
        position = np.array([rng.uniform(-2, 2), rng.uniform(-1.5, 1.5), altitude])
        yaw = rng.uniform(0, 360)
        R = camera_rotation(yaw, tilt_deg=rng.uniform(0, 8), tilt_dir_deg=rng.uniform(0, 360))
        hints = {"yaw_hint": yaw, "gravity_hint": gravity_hint(R, [k])}
        yield render(scene, CAM, position, R, snr_db=30, rng=rng), position, hints


def test_a_pad_18_m_away_is_found_and_its_position_measured(reference):
    found = []
    for frame, position, hints in _frames(18.0, 12):
        res = process_frame(frame, reference, CAM, **hints)
        if res.detected:
            found.append(np.linalg.norm(res.pose.position_m - position) / 16.0)
    # Searched at the frame's own resolution alone: 3 of these 12 (1 of 12 at 20 m).
    assert len(found) >= 10, len(found)
    assert np.median(found) < 0.04, found


def test_a_small_pad_found_at_the_frames_own_resolution_is_measured_enlarged(monkeypatch):
    # The altitude sweep's 640 x 480 frames at 10 m (point 9): the pad spans 30 px and
    # is found on the working view; measured on a window doubled around it, its
    # position comes closer (median 1.2 % of the altitude against 1.75 %).
    def median_error(enlarged_below_px: float) -> float:
        monkeypatch.setattr(pipeline.measure, "ENLARGED_BELOW_PX", enlarged_below_px)
        errors = []
        for j in range(12):
            pad, _, view, hint, reference = sweep_frames("default", CAM, 9, 10.0, j)
            res = process_frame(pad, reference, CAM, gravity_hint=hint)
            assert res.detected and res.pose is not None, res.reason
            found = np.asarray(res.pose.position_m)
            errors.append(
                min(
                    np.linalg.norm(found - view.position_m),
                    np.linalg.norm(found * [-1, -1, 1] - view.position_m),
                )
            )
        return float(np.median(errors)) / 10.0

    enlarged = median_error(pipeline.measure.ENLARGED_BELOW_PX)
    assert enlarged < 0.014
    assert enlarged < 0.85 * median_error(0.0)


def test_a_far_pad_once_found_is_followed_or_tracked_in_an_enlarged_window(reference):
    frame, _, hints = next(_frames(15.0, 1))
    first = process_frame(frame, reference, CAM, **hints)
    assert first.detected and first.found_by == "search"
    again = process_frame(frame, reference, CAM, prior=first, **hints)
    assert again.found_by == "follow"  # its sides found again where they were
    np.testing.assert_allclose(again.corners_px, first.corners_px, atol=0.5)
    # Moved further than its sides are looked for: found in the window around it,
    # enlarged as the far search found it.
    shift = np.array([[1.0, 0.0, 9.0], [0.0, 1.0, -7.0], [0.0, 0.0, 1.0]])
    moved = dataclasses.replace(first, homography=shift @ first.homography)
    again = process_frame(frame, reference, CAM, prior=moved, **hints)
    assert again.found_by == "track"
    np.testing.assert_allclose(again.corners_px, first.corners_px, atol=0.5)


def test_an_enlarged_view_keeps_the_frames_pixel_centres():
    frame = np.zeros((48, 64, 3), np.uint8)
    frame[20, 30] = 255
    view = View.enlarged(frame.shape, 128)
    assert view.scale == 2.0 and view.size == (128, 96)
    big = view.image(frame)[..., 0].astype(float)
    y, x = np.unravel_index(np.argmax(big), big.shape)
    # Frame pixel (30, 20) lies at view pixel (2 * 30 + 0.5, 2 * 20 + 0.5): between 4 pixels.
    assert (x, y) in {(60, 40), (61, 40), (60, 41), (61, 41)}
    np.testing.assert_allclose(view.matrix @ [30, 20, 1], [60.5, 40.5, 1])


def test_a_small_camera_is_enlarged_at_most_twice():
    # A CMUcam4's 160 x 120 frame: 320 x 240 for the last search, not 1280 x 960.
    assert View.enlarged((120, 160, 3), 1280).size == (320, 240)
    assert View.enlarged((720, 1280, 3), 1280).scale == 1.0
    assert View.enlarged((1080, 1920, 3), 1280).scale == 1.0


@pytest.mark.parametrize(
    ("point", "altitude", "j"), [(16, 28.0, 16), (17, 32.0, 15), (18, 36.0, 36), (19, 40.0, 9)]
)
def test_a_far_hs_board_on_the_frame_enlarged_is_read_as_the_camera_blurred_it(point, altitude, j):
    # The altitude sweep's 1280 x 720 frames at 28-40 m, searched doubled: an H of
    # 10-15 frame pixels. Its board read 0.40-0.45 of the paint beside it against the
    # picture's 0.16-0.17 (tolerance 0.2) while the picture was blurred as if the view
    # were the camera's own pixels; blurred as the camera blurs the enlarged view, the
    # picture's board reads 0.21-0.26 and the frame's 0.29-0.36.
    frame, _, view, hint, reference = sweep_frames("default", WIDE, point, altitude, j)
    res = process_frame(frame, reference, WIDE, gravity_hint=hint)
    assert res.detected and res.found_by == "search", res.reason
    tally = Tally()
    tally.score(True, res.pose, view, False)
    assert tally.pos_pct[0] < 4.0, tally.pos_pct
