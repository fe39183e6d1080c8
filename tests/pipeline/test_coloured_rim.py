"""A coloured board's rim, found on its colour (`pipeline.marks.find_marks`'s ``chroma``).

The shared photos' orange pad (a white H in a white ring on an orange disc, a black hem
around it, concrete beyond) is a rectified photo cropped to the disc. On its learned
channel the disc (57) steps 18 levels from the concrete (75), as much as its own
shading: the cut between them ran into the floor, and the pad had no rim. Its synthetic
twin, an orange disc cropped to its width on dark grey, is one level with the grey on
the channel: its "rim" was the picture's square edge. On the disc's colour both step
over 95 levels.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.bench.frames import SCENE_EVERY, make_scenes, make_view
from pipeline.bench.hint import gravity_hint
from pipeline.bench.picture_design import picture_design
from pipeline.bench.tally import pose_errors
from pipeline.render.view import render_view
from tests.pipeline.bench_support import PHOTOS, needs_photos

CAM = Camera.from_fov(640, 480, 60.0)


def _orange_disc(grey_bgr: tuple[int, int, int], disc_bgr=(30, 110, 235)) -> np.ndarray:
    """An orange disc cropped to a little less than its width on ``grey_bgr``, a white
    ring and a white H on it."""
    picture = np.full((600, 600, 3), grey_bgr, np.uint8)
    cv2.circle(picture, (300, 300), 303, disc_bgr, -1, cv2.LINE_AA)
    cv2.circle(picture, (300, 300), 200, (235, 235, 235), 16, cv2.LINE_AA)
    for x0, y0, x1, y1 in ((215, 180, 255, 420), (345, 180, 385, 420), (255, 280, 345, 320)):
        cv2.rectangle(picture, (x0, y0), (x1, y1), (235, 235, 235), -1)
    return picture


def _rims(reference: Reference) -> list:
    return [m for m in reference.marks if m.rim]


def test_a_coloured_disc_cropped_to_its_width_has_its_rim_where_the_channel_shows_none():
    reference = Reference.from_image(_orange_disc((70, 70, 70)), 1.2)
    (rim,) = _rims(reference)
    radii = np.hypot(*rim.corners_m.T)
    assert len(rim.corners_m) > 12
    assert radii.mean() == pytest.approx(0.6 * 303 / 300, rel=0.01)
    assert np.ptp(radii) < 0.01
    # ... so the picture's edge is no board's outline
    assert not reference.board_is_outline


def test_a_grey_disc_as_light_as_its_floor_shows_no_rim():
    # (no colour: the same picture, the disc the grey's own; the board fills the picture)
    reference = Reference.from_image(_orange_disc((70, 70, 70), (70, 70, 70)), 1.2)
    assert reference.board_chroma is None
    (rim,) = _rims(reference)
    assert len(rim.corners_m) == 4 and reference.board_is_outline


def test_a_board_running_along_the_pictures_edge_is_no_disc():
    # A square orange board on grey, cut by the picture on two sides: what is left of
    # its outline is no ellipse, and no rim is made up.
    picture = _orange_disc((70, 70, 70))
    picture[:] = (70, 70, 70)
    cv2.rectangle(picture, (40, 0), (600, 560), (30, 110, 235), -1)
    for x0, y0, x1, y1 in ((215, 180, 255, 420), (345, 180, 385, 420), (255, 280, 345, 320)):
        cv2.rectangle(picture, (x0, y0), (x1, y1), (235, 235, 235), -1)
    assert not _rims(Reference.from_image(picture, 1.2))


@needs_photos
def test_the_real_orange_pads_rim_is_its_discs_edge_lighter_than_its_hem():
    picture = cv2.imread(str(PHOTOS / "refs" / "orange_rectified.png"), cv2.IMREAD_COLOR)
    reference = Reference.from_image(picture, 1.1)
    (rim,) = _rims(reference)
    radius = float(np.hypot(*(rim.corners_m - rim.corners_m.mean(axis=0)).T).mean())
    assert radius == pytest.approx(0.535, abs=0.01)
    # (the concrete beyond is lighter than the disc on the channel, the hem darker: the
    # rim's edge is the hem's, and from afar the disc shows with its hem)
    assert rim.bright and rim.band_m > 0.005 and rim.banded
    board = reference.round_board
    assert board is not None and reference.marks[board.mark] is rim
    assert board.seen_m == pytest.approx(board.radius_m + rim.band_m)
    # ... and the reference cropped inside the disc has none but the picture's edge
    inner = cv2.imread(str(PHOTOS / "refs" / "orange_rectified_inner.png"), cv2.IMREAD_COLOR)
    (edge,) = _rims(Reference.from_image(inner, 1.1))
    assert len(edge.corners_m) == 4


@needs_photos
@pytest.mark.parametrize("j", range(4))
def test_the_real_orange_pad_is_posed_right_with_its_rim(j):
    # `pipeline.bench --sweep altitude --picture refs/orange_rectified.png --size 1.1
    # --hint --frames 20`, 6 m: with the rim taken dark inside (the concrete's side) the
    # pad was posed turned half round, 19 of 20 poses 58-139 % off.
    design = picture_design(PHOTOS / "refs" / "orange_rectified.png", 1.1)
    reference = Reference.from_image(design.draw().image, design.size_m)
    scenes = make_scenes(design, [0, 1000 + (2 * 20 + j) // SCENE_EVERY % 4], "today", ())
    view, noise_seed = make_view([0, 2, j, 11], CAM, design, "today", altitude=(6.0, 6.0))
    frame = render_view(scenes.pad, CAM, view, np.random.default_rng(noise_seed))
    res = process_frame(
        frame, reference, CAM, gravity_hint=gravity_hint(view.R_pad_cam, [0, 2, j, 12])
    )
    assert res.detected and res.pose is not None
    assert pose_errors(res.pose, view.position_m, view.R_pad_cam)[0] < 3.0
