"""Overexposed frames: white paint that clips reads darker than it is, so the board
around it reads brighter against it than on the reference picture; the board check
allows for the light the paint lost, not for any bright floor."""

from __future__ import annotations

import pytest

from pipeline import Reference, process_frame
from pipeline.render.degrade import Exposure
from tests.pipeline.bench_support import (
    CAM,
    TEXT_BELOW,
    assert_found_and_empty_twin_not,
    bench_frames,
    design_frames,
)


@pytest.mark.parametrize(
    ("design", "i", "gain", "gamma"),
    [
        ("icao", 6, 1.29, 0.70),
        ("icao", 25, 1.72, 0.73),
        ("icao", 35, 1.68, 0.83),
        ("grass_paint", 0, 1.6, 0.9),
    ],
)
def test_an_overexposed_pad_is_found(design: str, i: int, gain: float, gamma: float) -> None:
    exposure = Exposure(gain, gamma)
    pad, _, hint, _, reference = bench_frames(design, 21, i, "today", exposure=exposure)
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected, res.reason


def test_an_h_on_grass_is_not_a_dark_boards_pad_when_overexposed() -> None:
    # The real-world mix's empty frame 11 of the ICAO pad (a dark board): an H
    # painted on grass, its paint clipped, its grass at 0.69 of it against the
    # board's 0.27 on the picture: more than the clipped light explains.
    _, empty, hint, _, reference = bench_frames("icao", 0, 11, "real")
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected


@pytest.mark.parametrize("design", ["icao", "icao_circle"])
def test_clipped_paint_partly_shadowed_is_allowed_for(design: str) -> None:
    # The real-world mix's view 2 (an exposure error, a shadow, sun glare, JPEG): the
    # ICAO pad's clipped paint reads 244 of 255, its board 0.56 of it against the
    # picture's 0.33.
    assert_found_and_empty_twin_not(*bench_frames(design, 0, 2, "real"))


def test_clipped_paint_does_not_vouch_for_an_h_without_its_pads_marks() -> None:
    # The bench's view 39 of a pad with a ring and letters around its H: the empty
    # twin holds an H painted on a lighter floor, its paint clipped (241 of 255), the
    # floor 0.70 of it against the board's 0.38 on the picture, within what the clipped
    # light explains; but neither the ring nor the letters are around it.
    pad, empty, hint, _ = design_frames(TEXT_BELOW, 39, "today")
    reference = Reference.from_image(TEXT_BELOW.draw().image, TEXT_BELOW.size_m)
    assert reference.painted_marks
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
    found = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert found.detected, found.reason
