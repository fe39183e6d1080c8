"""The board's hue read through the camera's exposure curve (``template._hue``).

A gamma scales a colour's log-chromaticity and keeps its hue: an orange board seen
darker or brighter than its reference is as saturated as the curve made it. The frame's
board is read through the curve (``template.EXPOSURE_CURVES``) that brings it to the
reference's saturation, so an orange pad under another exposure keeps its board, while
grey and green floors, whose hue no curve turns to orange, do not.
"""

from __future__ import annotations

from functools import cache

import cv2
import numpy as np
import pytest

import pipeline.template
from pipeline import Camera, Reference, process_frame
from pipeline.bench.photos import FOV_DEG, carried_box, degraded_view, in_box, load_manifest
from pipeline.find import MAX_HUE
from pipeline.template import _hue
from tests.pipeline.bench_support import PHOTOS, needs_photos

ORANGE = np.array([47.0, 108.0, 181.0])  # B, G, R: the rectified orange pad's board
ANOTHER_CAMERA = np.array([22.0, 47.0, 135.0])  # the same pad in another photo (13 deg off)


def _curved(bgr: np.ndarray, gamma: float, gain: float = 1.0) -> np.ndarray:
    return 255.0 * gain * (bgr / 255.0) ** gamma


@pytest.mark.parametrize("gamma", [0.55, 0.8, 1.25, 1.6, 1.9])
def test_a_coloured_board_keeps_its_hue_under_another_exposure_curve(gamma) -> None:
    assert _hue(_curved(ORANGE, gamma, gain=1.1), ORANGE) <= MAX_HUE


@pytest.mark.parametrize("gamma", [1.2, 1.3, 1.4])
def test_another_cameras_board_under_a_darker_curve_is_still_the_pads(gamma) -> None:
    seen = _curved(ANOTHER_CAMERA, gamma)
    assert _hue(seen, ORANGE) <= MAX_HUE
    # (read as plain chromaticities, the curve takes it out of tolerance)
    assert np.abs(seen / seen.sum() - ORANGE / ORANGE.sum()).sum() > MAX_HUE


@pytest.mark.parametrize(
    "floor",
    [[85.0, 86.0, 89.0], [140.0, 122.0, 92.0], [60.0, 120.0, 80.0], [160.0, 100.0, 70.0]],
    ids=["grey asphalt", "blue-grey tiles", "grass", "blue tarp"],
)
def test_a_floor_of_another_hue_is_no_orange_board_under_any_curve(floor) -> None:
    for gamma in (0.6, 1.0, 1.6):
        assert _hue(_curved(np.array(floor), gamma), ORANGE) > MAX_HUE


def test_a_board_without_colour_is_read_as_it_is() -> None:
    white = np.array([215.0, 215.0, 215.0])
    tinted = np.array([170.0, 147.0, 153.0])
    plain = np.abs(tinted / tinted.sum() - white / white.sum()).sum()
    assert _hue(tinted, white) == pytest.approx(plain, abs=1e-6)
    assert _hue(np.array([60.0, 180.0, 60.0]), white) > MAX_HUE  # (a green board)


@cache
def _orange_reference() -> Reference:
    picture = cv2.imread(str(PHOTOS / "refs" / "orange_rectified.png"), cv2.IMREAD_COLOR)
    return Reference.from_image(picture, 1.1)


@needs_photos
@pytest.mark.parametrize(("seed", "k"), [(2, 0), (3, 1), (4, 0)])
def test_a_real_orange_pad_seen_darker_keeps_its_board(seed, k, monkeypatch) -> None:
    """A real photo's orange pad in the photos bench's views that a curve darkened (gamma
    1.3-1.7): its board reads up to 1.7 times as saturated as the reference's, its hue
    13-16 degrees off (another camera's white balance)."""
    manifest = load_manifest(PHOTOS)
    index, item = next(
        (n, i) for n, i in enumerate(manifest["items"]) if i["file"].endswith("DJI_0084_33.jpg")
    )
    photo = cv2.imread(str(PHOTOS / item["file"]), cv2.IMREAD_COLOR)
    view, T = degraded_view(photo, seed, index, k)
    reference = _orange_reference()
    camera = Camera.from_fov(view.shape[1], view.shape[0], FOV_DEG)
    res = process_frame(view, reference, camera)
    assert res.detected and in_box(res.corners_px, carried_box(item["h_box"], T)), res.reason
    # (read without the curve, its board is not the reference's)
    monkeypatch.setattr(pipeline.template, "EXPOSURE_CURVES", (1.0, 1.0))
    assert not process_frame(view, reference, camera).detected
