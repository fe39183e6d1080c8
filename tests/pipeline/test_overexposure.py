"""Overexposed frames: white paint that clips reads darker than it is, so the board
around it reads brighter against it than on the reference picture; the board check
allows for the light the paint lost, not for any bright floor."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.bench.frames import SCENE_EVERY, make_scenes, make_view
from pipeline.bench.hint import gravity_hint
from pipeline.render import get_design
from pipeline.render.degrade import Exposure
from pipeline.render.view import render_view

CAM = Camera.from_fov(640, 480, 60.0)


def _frames(design_name: str, seed: int, i: int, level: str, exposure: Exposure | None):
    """Frame ``i`` of the bench's ``level`` views (its pad and its empty twin), with
    ``exposure`` in place of the view's own when given; the attitude hint; the reference."""
    design = get_design(design_name)
    reference = Reference.from_image(design.draw().image, design.size_m)
    scenes = make_scenes(design, [seed, i // SCENE_EVERY], level, ())
    view, noise_seed = make_view([seed, i, 7], CAM, design, level)
    if exposure is not None:
        view = dataclasses.replace(view, exposure=exposure)
    pad = render_view(scenes.pad, CAM, view, np.random.default_rng(noise_seed))
    empty = render_view(scenes.empty, CAM, view, np.random.default_rng(noise_seed))
    return pad, empty, gravity_hint(view.R_pad_cam, [seed, i, 11]), reference


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
    pad, _, hint, reference = _frames(design, 21, i, "today", Exposure(gain, gamma))
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected, res.reason


def test_an_h_on_grass_is_not_a_dark_boards_pad_when_overexposed() -> None:
    # The real-world mix's empty frame 11 of the ICAO pad (a dark board): an H
    # painted on grass, its paint clipped, its grass at 0.69 of it against the
    # board's 0.27 on the picture: more than the clipped light explains.
    _, empty, hint, reference = _frames("icao", 0, 11, "real", None)
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
