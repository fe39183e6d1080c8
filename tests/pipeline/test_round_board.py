"""A far pad found by its round board (`pipeline.board_search`, `Reference.round_board`).

From 18 m on a 640 x 480 frame orange_ring's H (white, in a white ring on an orange
disc) spans some 12 px, blurred into its ring: no threshold parts the two, and the
pad went unfound in 3, 5 and 6 of the altitude sweep's 20 views at 18, 20 and 24 m
(seed 0). The disc around them is a plain ellipse.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pipeline import Camera, process_frame
from pipeline.bench.sweep import altitude_points
from pipeline.bench.tally import TURN, pose_errors
from pipeline.board_search import _board_ellipse, _board_quad
from pipeline.render import get_design
from tests.pipeline.bench_support import design_reference, sweep_frames

CAM = Camera.from_fov(640, 480, 60.0)


@pytest.mark.parametrize(
    ("design", "radius"),
    [
        ("orange_ring", 0.535),  # its disc (the hem beyond)
        ("red_on_black", 0.55),  # its disc
        ("serif_octagon", 0.282),  # the octagon printed on its sheet
        ("icao_circle", 2.005),  # the disc its ring holds
        ("paper_ring", 0.131),  # the sheet inside its ring
    ],
)
def test_an_h_on_a_round_board_has_one(design, radius):
    board = design_reference(design).round_board
    assert board is not None
    assert board.radius_m == pytest.approx(radius, abs=0.01)
    assert np.abs(board.centre_m).max() < 0.02


@pytest.mark.parametrize("design", ["default", "icao", "dark_on_light", "thin", "grass_paint"])
def test_square_boards_and_bare_hs_have_none(design):
    assert design_reference(design).round_board is None


def test_an_ellipse_is_a_round_board_and_a_square_is_not():
    seed = np.zeros((80, 80), np.uint8)
    cv2.rectangle(seed, (36, 36), (44, 44), 1, -1)
    disc = np.zeros_like(seed)
    cv2.ellipse(disc, (40, 40), (22, 15), 30.0, 0, 360, 1, -1)
    rect = _board_ellipse(disc, seed, 9.0, 2.6, 12.0)
    assert rect is not None
    sides = sorted(np.hypot(*(np.roll(rect, -1, axis=0) - rect).T))
    assert sides == pytest.approx([30, 30, 44, 44], abs=2.0)
    square = np.zeros_like(seed)
    cv2.rectangle(square, (22, 22), (58, 58), 1, -1)
    assert _board_ellipse(square, seed, 12.0, 2.6, 12.0) is None
    assert _board_quad(square, seed, 12.0, 2.6, 12.0) is not None


# (sweep point, view) of the sweep at 20 frames a point: the views the pad was missed in
MISSED = [(8, 8), (8, 15), (9, 7), (9, 15), (9, 19), (10, 1), (10, 2), (10, 3), (10, 4)]


@pytest.mark.parametrize(("point", "j"), MISSED)
def test_a_far_disc_pad_is_found_by_its_board_and_posed(point, j):
    design = get_design("orange_ring")
    altitude = altitude_points(design, CAM)[point]
    pad, empty, view, hint, reference = sweep_frames(
        "orange_ring", CAM, point, altitude, j, per_point=20
    )
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    # (its H's half turn: the pad alone does not tell it)
    err = min(
        pose_errors(res.pose, view.position_m, view.R_pad_cam)[0],
        pose_errors(res.pose, TURN @ view.position_m, TURN @ view.R_pad_cam)[0],
    )
    assert err < 8.0
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
