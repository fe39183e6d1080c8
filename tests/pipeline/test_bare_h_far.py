"""A pad that is an H alone (painted on grass: no marks around it, no board) has nothing
but its H to show from afar, and so small an H is any H: far away, a look-alike H of
hairline strokes painted on the same grass is not taken for it."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import process_frame
from pipeline.bench.frames import make_scenes, make_view
from pipeline.bench.hint import gravity_hint
from pipeline.bench.tally import TURN, pose_errors
from pipeline.render import get_design
from pipeline.render.view import render_view
from tests.pipeline.bench_support import CAM, design_reference

ALTITUDE_M = 50.0  # grass_paint's H spans 13 px (its pad 22 px)


def _views(j: int):
    """View ``j`` of a far scene of grass_paint's (the bench's floors and look-alikes) with
    a hairline H: the pad's frame, its empty twin, the view and the attitude hint."""
    design = get_design("grass_paint")
    scenes = make_scenes(design, [0, 2007], "today", ())
    view, noise = make_view([0, 3, j, 11], CAM, design, "today", altitude=(ALTITUDE_M,) * 2)
    pad = render_view(scenes.pad, CAM, view, np.random.default_rng(noise))
    empty = render_view(scenes.empty, CAM, view, np.random.default_rng(noise))
    return pad, empty, view, gravity_hint(view.R_pad_cam, [0, 3, j, 12])


@pytest.mark.parametrize("j", [12, 13, 15, 16, 17, 18])
def test_a_far_hairline_h_is_not_the_pad(j: int) -> None:
    pad, empty, view, hint = _views(j)
    reference = design_reference("grass_paint")
    seen = process_frame(empty, reference, CAM, gravity_hint=hint)
    assert not seen.detected and "H-shaped mark" in seen.reason  # (located, and refused)
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    if res.detected:  # (the pad itself, posed right or as its twin (symmetric), or nothing)
        assert res.pose is not None
        right = pose_errors(res.pose, view.position_m, view.R_pad_cam)[0]
        twin = pose_errors(res.pose, TURN @ view.position_m, TURN @ view.R_pad_cam)[0]
        assert min(right, twin) < 5.0
