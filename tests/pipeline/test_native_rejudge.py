"""A far pad's H on a frame wider than the working view, judged at the frame's own
resolution when the shrunk working view could not (`pipeline.find.Tally.turn_down`).

thin's H 15.3 m away on 1280 x 720 frames spans 24-30 px, its strokes about 2.5: on the
working view (the frame halved) 12-15 px with strokes of 1.3, too blurred to place its
corners. It was turned down there and, at 24 px or more, never looked at again at the
frame's own resolution, where it is clear: 6 of the sweep's 20 views at that point were
missed while 17.5-26 m away 19-20 were found.
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import Camera, process_frame
from pipeline.bench.sweep import altitude_points
from pipeline.bench.tally import TURN, pose_errors
from pipeline.render import get_design
from tests.pipeline.bench_support import sweep_frames

CAM = Camera.from_fov(1280, 720, 60.0)


@pytest.mark.parametrize("j", [4, 10])
def test_an_h_refused_on_the_halved_view_is_found_at_the_frames_own_resolution(j):
    altitude = altitude_points(get_design("thin"), CAM)[11]
    assert altitude == pytest.approx(15.3, abs=0.1)
    pad, empty, view, hint, reference = sweep_frames("thin", CAM, 11, altitude, j, per_point=20)
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "search", res.reason
    errors = [
        pose_errors(res.pose, T @ view.position_m, T @ view.R_pad_cam)[0] for T in (np.eye(3), TURN)
    ]
    assert min(errors) < 3.0
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
