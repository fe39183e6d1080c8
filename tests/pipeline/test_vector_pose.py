"""The pose on frames drawn from the pad's geometry alone (`pipeline.bench.vector`),
not by the renderer the reference's picture shares its conventions with."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.bench.__main__ import main
from pipeline.bench.hint import gravity_hint
from pipeline.bench.tally import Tally
from pipeline.bench.vector import draw_pad
from pipeline.render import PadGeometry, camera_rotation, make_pad_image
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
