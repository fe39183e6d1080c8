"""A hard shadow's edge across the pad (a pole, a building): the H is still the pad's.

The check that the H stands out from its board (``candidates.blob_separation``)
pools the levels of the whole H; a shadow's edge through it spreads them over
two levels on both sides, so the check is also made per quadrant.
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.candidates import MIN_BLOB_SEPARATION, blob_separation
from pipeline.render import camera_rotation, make_pad_image, make_scene, render
from pipeline.render.degrade import Shadow
from pipeline.shapes import Region

CAM = Camera.from_fov(640, 480, 60.0)


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(make_pad_image(800), 0.55)


@pytest.fixture(scope="module")
def scene():
    return make_scene(make_pad_image(800), 0.55, rng=np.random.default_rng(0))


@pytest.mark.parametrize("edge_x", [-0.04, 0.0, 0.04])
@pytest.mark.parametrize("darkness", [0.6, 0.8])
def test_a_pad_half_in_a_hard_shadow_is_found_where_it_is(reference, scene, edge_x, darkness):
    # The shadow covers the pad plane's x > edge_x: its edge crosses the H's crossbar.
    shadow = Shadow(((edge_x, -50.0), (50.0, -50.0), (50.0, 50.0), (edge_x, 50.0)), darkness, 1.0)
    position = np.array([0.05, 0.0, 2.5])
    frame = render(
        scene, CAM, position, camera_rotation(20.0), shadow=shadow, snr_db=25,
        rng=np.random.default_rng(1),
    )  # fmt: skip
    res = process_frame(frame, reference, CAM)
    assert res.detected, res.reason
    # the camera's place over the pad, modulo the pad's half turn (the H is symmetric)
    found = np.asarray(res.pose.position_m)
    err = min(np.linalg.norm(found - position), np.linalg.norm(found * [-1, -1, 1] - position))
    assert err < 0.03 * position[2]


def _square(x0: int, size: int) -> Region:
    corners = np.array([[0, 0], [size - 1, 0], [size - 1, size - 1], [0, size - 1]]) + x0
    return Region(corners.astype(np.int32), float(size * size))


def test_a_shape_of_the_floors_own_texture_does_not_stand_out():
    # An H-sized patch of grass-like texture is no more uniform than its surroundings:
    # neither as a whole nor in any quadrant.
    rng = np.random.default_rng(3)
    smooth = np.clip(rng.normal(110, 30, (120, 120)), 0, 255).astype(np.uint8)
    region = _square(30, 60)
    assert blob_separation(smooth, region, 10.0) < MIN_BLOB_SEPARATION


def test_a_painted_patch_in_half_shadow_stands_out():
    # Paint 200 on a board 40, the right half of both in a shadow taking 70 % of the
    # light: pooled over the whole the levels overlap, but each side stands out.
    board = np.full((120, 120), 40.0)
    board[40:80, 40:80] = 200.0
    board[:, 60:] *= 0.3
    smooth = np.clip(board + np.random.default_rng(0).normal(0, 4, board.shape), 0, 255)
    assert blob_separation(smooth.astype(np.uint8), _square(40, 40), 8.0) >= MIN_BLOB_SEPARATION
