"""The pose on frames drawn another way (`pipeline.bench.vector`): from the pad's
geometry alone, or its picture warped by OpenCV; not by the renderer the reference's
picture shares its conventions with."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.bench.__main__ import main
from pipeline.bench.frames import altitude_for
from pipeline.bench.hint import gravity_hint
from pipeline.bench.tally import Tally
from pipeline.bench.vector import draw_pad, warp_picture
from pipeline.render import PadGeometry, camera_rotation, get_design, make_pad_image
from pipeline.render.view import random_view

CAMERA = Camera.from_fov(640, 480, 60.0)


def _reference() -> Reference:
    return Reference.from_image(make_pad_image(1100), PadGeometry().size_m)


def test_the_board_spans_what_the_pinhole_camera_says() -> None:
    # Straight down from 2 m: the 0.55 m board spans fx * 0.55 / 2 pixels.
    frame = draw_pad(
        CAMERA, np.array([0.0, 0.0, 2.0]), camera_rotation(0.0), snr_db=None, blur_px=0.0,
        rng=np.random.default_rng(0),
    )  # fmt: skip
    row = frame[240, :, 1].astype(float)
    # The floor is 120, the board 27: the board's edges where the row crosses 73.5
    # (a partly covered pixel holds the share it covers).
    dark = row < 73.5
    left, right = np.argmax(dark), len(row) - np.argmax(dark[::-1])
    expected = CAMERA.fx * 0.55 / 2.0
    assert abs((right - left) - expected) <= 1.0
    assert frame[240, 320].mean() > 200  # the H's crossbar at the centre


def test_the_pad_must_lie_in_front_of_the_camera() -> None:
    with pytest.raises(ValueError, match="in front of the camera"):
        draw_pad(
            CAMERA, np.array([0.0, 0.0, -2.0]), camera_rotation(0.0), snr_db=None, blur_px=0.0,
            rng=np.random.default_rng(0),
        )  # fmt: skip


@pytest.mark.parametrize("snr_db", [45.0, 20.0])
def test_vector_drawn_poses_meet_the_bars(snr_db: float) -> None:
    """1-6 m: with the attitude hint, position within 1 % of the altitude (median) and
    rotation within a degree; without it, no pose off by over 3 degrees unflagged."""
    reference = _reference()
    hinted, unhinted = Tally(), Tally()
    for i in range(16):
        rng = np.random.default_rng([5, i])
        view = random_view(rng, CAMERA, snr_db=None, max_blur_px=0.0, lighting=False)
        frame = draw_pad(
            CAMERA, view.position_m, view.R_pad_cam, snr_db=snr_db, blur_px=0.5, rng=rng
        )
        g = gravity_hint(view.R_pad_cam, [5, i, 11])
        res = process_frame(frame, reference, CAMERA, gravity_hint=g)
        hinted.score(res.detected and res.pose is not None, res.pose, view, True)
        res = process_frame(frame, reference, CAMERA)
        assert res.detected and res.pose is not None
        unhinted.score(True, res.pose, view, True)
        assert res.pose.ambiguous or unhinted.rot_deg[-1] <= 3.0, (i, unhinted.rot_deg[-1])
    assert hinted.detected == hinted.n
    assert np.median(hinted.pos_pct) <= 1.0 and max(hinted.pos_pct) <= 3.0, hinted.pos_pct
    assert np.median(hinted.rot_deg) <= 1.0 and max(hinted.rot_deg) <= 3.0, hinted.rot_deg


def test_vector_bench_cli(capsys) -> None:
    assert main(["--vector", "--frames", "2"]) == 0
    out = json.loads(capsys.readouterr().out)
    for level in ("clean", "noisy"):
        assert out[level]["with_hint"]["detection_rate"] == 1.0
        assert out[level]["without_hint"]["silently_wrong_over_3_deg"] == 0
        assert "median" in out[level]["with_hint"]["position_error_pct"]


def test_a_picture_warped_is_the_pad_drawn_as_polygons() -> None:
    # The two ways of drawing meet: the default design's picture warped by OpenCV and
    # the pad drawn from its geometry, seen from 2 m, a slant and a turn.
    pose = (np.array([0.1, -0.15, 2.0]), camera_rotation(25.0, tilt_deg=10.0, tilt_dir_deg=70.0))
    drawn = draw_pad(CAMERA, *pose, snr_db=None, blur_px=0.0, rng=np.random.default_rng(0))
    warped = warp_picture(
        CAMERA, get_design("default"), *pose, snr_db=None, blur_px=0.0,
        rng=np.random.default_rng(0),
    )  # fmt: skip
    board = drawn[..., 1] < 73.5
    assert abs(int(board.sum()) - int((warped[..., 1] < 73.5).sum())) <= 0.01 * board.sum()
    assert np.abs(drawn.astype(int) - warped.astype(int)).mean() < 2.0


def test_a_ringed_pad_warped_is_posed_within_the_bars() -> None:
    # red_on_black (a serif H in a ring and a hexagon, on black) posed from its picture
    # warped by OpenCV, not ray-traced by the renderer, the attitude exact.
    design = get_design("red_on_black")
    reference = Reference.from_image(design.draw().image, design.size_m)
    hinted = Tally()
    for i in range(12):
        rng = np.random.default_rng([3, i])
        view = random_view(
            rng, CAMERA, altitude=altitude_for(design), pad_size_m=design.size_m,
            snr_db=None, max_blur_px=0.0, lighting=False,
        )  # fmt: skip
        frame = warp_picture(
            CAMERA, design, view.position_m, view.R_pad_cam, snr_db=45.0, blur_px=0.5, rng=rng
        )
        g = gravity_hint(view.R_pad_cam, [3, i], noise_deg=0.0)
        res = process_frame(frame, reference, CAMERA, gravity_hint=g)
        hinted.score(res.detected and res.pose is not None, res.pose, view, True)
    assert hinted.detected == hinted.n
    assert np.median(hinted.pos_pct) <= 1.0 and max(hinted.pos_pct) <= 3.0, hinted.pos_pct


def test_vector_bench_cli_per_design(capsys) -> None:
    assert main(["--vector", "--design", "orange_ring", "--frames", "2"]) == 0
    out = json.loads(capsys.readouterr().out)["designs"]["orange_ring"]
    assert out["renderer"].startswith("the design's picture warped")
    for level in ("clean", "noisy"):
        assert out[level]["with_exact_hint"]["detection_rate"] == 1.0
        assert out[level]["without_hint"]["silently_wrong_over_3_deg"] == 0


@pytest.mark.parametrize("i", [20, 26, 103, 129])
def test_a_pose_a_hairline_ring_tilts_is_flagged_without_the_attitude(i: int) -> None:
    # paper_ring (a printed H in a hairline ring, a triangle for its heading, on a
    # sheet) near the far end of its band, warped by OpenCV, at 20 dB with a blur: its
    # ring a pixel wide. These four of 150 frames were posed 3.2-6 degrees off without
    # the attitude and not flagged ambiguous: the ring's blurred line, fitted on some of
    # its sides, and the triangle, fitted the wrong way round, pulled the sheet's
    # corners 1-1.9 px off. Fitted without the ring, or the right way round, the sheet
    # reads another tilt: the pose is flagged.
    design = get_design("paper_ring")
    reference = Reference.from_image(design.draw().image, design.size_m)
    rng = np.random.default_rng([7, i])
    view = random_view(
        rng, CAMERA, altitude=altitude_for(design), pad_size_m=design.size_m, snr_db=None,
        max_blur_px=0.0, lighting=False,
    )  # fmt: skip
    frame = warp_picture(
        CAMERA, design, view.position_m, view.R_pad_cam, snr_db=20.0, blur_px=0.8, rng=rng
    )
    res = process_frame(frame, reference, CAMERA)
    assert res.detected and res.pose is not None
    tally = Tally()
    tally.score(True, res.pose, view, True)
    assert res.pose.ambiguous or tally.rot_deg[-1] <= 2.0, tally.rot_deg
