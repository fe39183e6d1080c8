"""A far pad found by its light sheet (`Reference.outline_bright`, `board_search`).

serif_octagon's H is printed in a dark octagon on a white sheet. From 15 m on (640 x
480) the H inside the octagon is no mark of the threshold at all, so no board grew
around it; the sheet is one, of the H's polarity, with the octagon for its hole. And
the pose the sheet gave found 0.17-0.20 of the pad's edges, under `MIN_BOARD_SUPPORT`:
the double rim's four octagons, 5-8 mm apart, were counted though no frame tells them
apart from 3-5 m on (`pipeline.edgefit.RESOLVED_PX`).
"""

from __future__ import annotations

import pytest

from pipeline import Camera, process_frame
from pipeline.bench.sweep import altitude_points
from pipeline.bench.tally import pose_errors
from pipeline.render import get_design
from tests.pipeline.bench_support import design_reference, sweep_frames

CAM = Camera.from_fov(640, 480, 60.0)


def test_only_a_sheet_as_light_as_its_h_is_a_light_outline():
    assert design_reference("serif_octagon").outline_bright
    for design in ("default", "dark_on_light", "thin", "paper_ring", "icao", "red_on_black"):
        assert not design_reference(design).outline_bright, design


@pytest.mark.parametrize("j", [2, 4])
def test_a_far_sheet_is_found_as_a_mark_of_the_hs_polarity(j):
    altitude = altitude_points(get_design("serif_octagon"), CAM)[11]
    assert altitude == pytest.approx(15.3, abs=0.1)
    pad, empty, view, hint, reference = sweep_frames(
        "serif_octagon", CAM, 11, altitude, j, per_point=20
    )
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    assert pose_errors(res.pose, view.position_m, view.R_pad_cam)[0] < 5.0
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
