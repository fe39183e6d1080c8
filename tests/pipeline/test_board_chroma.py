"""A far board's outline found on its own colour (`Reference.board_chroma`, `board_search`).

thin's white H on a blue board: on the H's channel (white against blue) the blue reads
dark and grass no lighter, and the board's rim steps 20-25 levels against a floor
noise of 6-14. On the altitude sweep's views 10.9 m away (seed 0, 20 a point) its
faint H was refused and its board, fitted, found none of its outline: 3 of 20 views
missed. At 15.3 m, where its H's strokes are a pixel wide, the board is placed by that
outline too (`board_search.CHROMA_PLACED`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import Camera, process_frame
from pipeline.bench.sweep import altitude_points
from pipeline.bench.tally import TURN, pose_errors
from pipeline.render import get_design
from tests.pipeline.bench_support import design_reference, sweep_frames

CAM = Camera.from_fov(640, 480, 60.0)
SAME = np.eye(3)


@pytest.mark.parametrize("design", ["thin", "orange_ring"])
def test_a_coloured_board_has_a_chroma(design):
    chroma = design_reference(design).board_chroma
    assert chroma is not None
    assert np.linalg.norm(chroma) == pytest.approx(1.0)
    assert abs(chroma.sum()) < 1e-9  # (a grey reads 0 on it, whatever its lightness)
    board = np.asarray(design_reference(design).board_bgr)
    assert chroma @ board > 40.0


@pytest.mark.parametrize("design", ["default", "dark_on_light", "paper_ring", "red_on_black"])
def test_a_grey_board_has_none(design):
    assert design_reference(design).board_chroma is None


def _found_by_its_board(point: int, j: int, within_pct: float):
    """thin's sweep view ``j`` of ``point`` (20 a point): found by its board, posed within
    ``within_pct`` of the altitude (modulo the half turn, which its symmetric pad does not
    tell), its empty twin empty; the view and the hint."""
    altitude = altitude_points(get_design("thin"), CAM)[point]
    pad, empty, view, hint, reference = sweep_frames("thin", CAM, point, altitude, j, per_point=20)
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    errors = [
        pose_errors(res.pose, T @ view.position_m, T @ view.R_pad_cam)[0] for T in (SAME, TURN)
    ]
    assert min(errors) < within_pct
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
    return pad, hint, reference


@pytest.mark.parametrize("j", [2, 7])
def test_a_far_blue_board_is_found_by_its_outline_on_its_chroma(j):
    pad, hint, reference = _found_by_its_board(9, j, 5.0)
    # A grey frame shows no chroma: the board's outline is not found so there.
    grey = np.repeat(pad.mean(axis=2, keepdims=True).astype(np.uint8), 3, axis=2)
    assert process_frame(grey, reference, CAM, gravity_hint=hint).found_by != "board"
    assert process_frame(grey[..., 0], reference, CAM, gravity_hint=hint).found_by != "board"


@pytest.mark.parametrize("j", [5, 9])
def test_a_far_blue_board_on_grass_grows_on_its_chroma(j):
    # 15.3 m: the H too faint to place, its blue board 20-25 levels from the grass on
    # the H's channel under a floor noise of 16-21: no board grew around it there.
    _found_by_its_board(11, j, 8.0)


@pytest.mark.parametrize("j", [6, 8])
def test_a_far_blue_board_is_placed_by_its_outline_on_its_chroma(j):
    # 15.3 m: fitted on the H's channel (its strokes 1.3 px wide, blurred), these
    # boards posed 8-10 % off, found 0.14 of the pad's edges there and were refused;
    # placed by their outline on the chroma, 0.8-1.1 % off.
    _found_by_its_board(11, j, 2.0)
