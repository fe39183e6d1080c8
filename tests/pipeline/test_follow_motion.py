"""A pad moving steadily across the frame is followed where its motion takes it."""

from __future__ import annotations

import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.homography_fit import apply_h
from pipeline.render import camera_rotation, make_pad_image, make_scene, render


def _frames(step_m: float, count: int):
    pad = make_pad_image(600)
    reference = Reference.from_image(pad, 0.55)
    camera = Camera.from_fov(640, 480, 60)
    scene = make_scene(pad, 0.55, rng=np.random.default_rng(3))
    frames = []
    for k in range(count):
        at, yaw = np.array([step_m * k, 0.0, 2.5]), 15.0 + 2.0 * k
        frames.append(render(scene, camera, at, camera_rotation(yaw), rng=np.random.default_rng(k)))
    return reference, camera, frames


def test_the_motion_between_two_frames_is_reported_and_predicts_the_next():
    # 4 cm a frame at 2.5 m: 9 px, further than a followed side is looked for
    # (frame.FOLLOW_REACH_PX) from where it was.
    reference, camera, frames = _frames(0.04, 4)
    prior = process_frame(frames[0], reference, camera)
    assert prior.detected and prior.motion is None
    ways = []
    for frame in frames[1:]:
        result = process_frame(frame, reference, camera, prior=prior)
        assert result.detected
        ways.append(result.found_by)
        # The motion maps where the pad was to where it is.
        moved = apply_h(result.motion, apply_h(prior.homography, reference.corners_m))
        assert np.abs(moved - apply_h(result.homography, reference.corners_m)).max() < 1e-6
        prior = result
    # The second frame had no motion to go by: the pad was searched for around where
    # it was; from the third on, it is followed where its motion takes it.
    assert ways[0] == "track"
    assert ways[1:] == ["follow", "follow"]


def test_a_pad_that_stops_is_still_found_when_the_motion_no_longer_holds():
    reference, camera, frames = _frames(0.04, 3)
    first = process_frame(frames[0], reference, camera)
    second = process_frame(frames[1], reference, camera, prior=first)
    assert second.motion is not None
    stopped = process_frame(frames[1], reference, camera, prior=second)  # no move at all
    assert stopped.detected and stopped.found_by == "follow"
    # (followed from where it was, once the prediction's sides were not found)
    assert np.abs(stopped.corners_px - second.corners_px).max() < 0.5
