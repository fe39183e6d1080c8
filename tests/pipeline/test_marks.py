import warnings

import cv2
import numpy as np
import pytest

from pipeline import Reference
from pipeline.marks import Mark, band_beyond, symmetric_marks
from pipeline.render import get_design
from tests.pipeline.bench_support import BLACK_ON_YELLOW


def test_a_ring_and_a_disc_rim_are_marks():
    d = get_design("orange_ring")
    ref = Reference.from_image(d.draw().image, d.size_m)
    curves = [m for m in ref.marks if len(m.corners_m) > 12]
    assert len(curves) >= 3  # the ring's two edges and the disc's rim
    radii = sorted(float(np.linalg.norm(m.corners_m, axis=1).mean()) for m in curves)
    assert radii[-1] > 0.5 * d.size_m * 0.9  # the rim, at the disc's edge


def test_a_dark_disc_on_a_floor_as_light_as_its_paint_has_its_rim_as_a_mark():
    # red_on_black: on its red channel the grey floor around the black disc is as light
    # as the red paint; the disc's rim, the pad's widest edge, is a mark all the same.
    d = get_design("red_on_black")
    ref = Reference.from_image(d.draw().image, d.size_m)
    rims = [m for m in ref.marks if m.rim]
    assert len(rims) == 1 and not rims[0].bright and len(rims[0].corners_m) > 12
    assert float(np.ptp(rims[0].corners_m, axis=0).max()) == pytest.approx(d.size_m, rel=0.02)
    # ... and the one rim a square board's picture has is its edge
    d = get_design("default")
    rims = [m for m in Reference.from_image(d.draw().image, d.size_m).marks if m.rim]
    assert len(rims) == 1 and len(rims[0].corners_m) == 4


def test_a_triangle_breaks_the_half_turn_symmetry():
    for name, symmetric in (("paper_ring", False), ("serif_octagon", False), ("icao", True)):
        d = get_design(name)
        assert Reference.from_image(d.draw().image, d.size_m).symmetric is symmetric


def test_symmetric_marks_compares_centres_areas_and_brightness():
    h = get_design("default").draw().h_corners_m
    box = np.array([[-0.2, 0.3], [-0.1, 0.3], [-0.1, -0.3], [-0.2, -0.3]])
    pair = (Mark(box, True), Mark(-box, True))
    assert symmetric_marks(h, pair)
    assert not symmetric_marks(h, pair[:1])
    assert not symmetric_marks(h, (Mark(box, True), Mark(-box, False)))


def _disc(radius: float, n: int = 96) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.column_stack([299.5 + radius * np.cos(t), 299.5 + radius * np.sin(t)])


@pytest.mark.parametrize("hem_px", [6, 16, 40])
def test_a_hem_beyond_a_discs_rim_is_measured(hem_px) -> None:
    # An orange disc with a dark hem on a grey floor: the hem is a band beyond the rim.
    picture = np.full((600, 600, 3), (108, 110, 112), np.uint8)
    cv2.circle(picture, (300, 300), 290, (34, 32, 34), -1, cv2.LINE_AA)
    cv2.circle(picture, (300, 300), 290 - hem_px, (38, 118, 232), -1, cv2.LINE_AA)
    assert band_beyond(picture, _disc(290 - hem_px)) == pytest.approx(hem_px, abs=1.5)


def test_a_rim_on_the_floor_or_at_the_pictures_edge_has_no_band() -> None:
    picture = np.full((600, 600, 3), (108, 110, 112), np.uint8)
    cv2.circle(picture, (300, 300), 290, (38, 118, 232), -1, cv2.LINE_AA)
    assert band_beyond(picture, _disc(290)) == 0.0
    # a board that fills its picture: nothing beyond its rim to tell
    board = np.full((400, 600, 3), 40, np.uint8)
    rect = np.array([[-0.5, -0.5], [599.5, -0.5], [599.5, 399.5], [-0.5, 399.5]])
    assert band_beyond(board, rect) == 0.0


def test_a_pads_hem_is_its_rims_band() -> None:
    # orange_ring's dark hem: 1.5 % of the disc's 1.1 m; the other designs have none.
    d = get_design("orange_ring")
    (rim,) = [m for m in Reference.from_image(d.draw().image, d.size_m).marks if m.rim]
    assert rim.band_m == pytest.approx(0.015 * d.size_m, abs=0.003)
    for name in ("default", "red_on_black", "icao_circle"):
        d = get_design(name)
        assert all(m.band_m == 0.0 for m in Reference.from_image(d.draw().image, d.size_m).marks)


def test_a_disc_whose_rim_steps_less_than_its_h_has_it_as_a_faint_rim() -> None:
    # On the channel learned from this picture the yellow disc steps to the white sheet
    # a third as far as the H steps to the disc: its rim is still a mark, traced where
    # the disc ends (the H's blurred edge joins it to its board: without that the H
    # alone was taken for the board, and its outline for the rim) ...
    (rim,) = Reference.from_image(BLACK_ON_YELLOW.draw().image, BLACK_ON_YELLOW.size_m).marks
    assert rim.rim and rim.faint and not rim.bright and len(rim.corners_m) > 12
    radius = np.linalg.norm(rim.corners_m, axis=1)
    assert radius == pytest.approx(np.full(len(radius), 0.36), abs=0.004)
    # ... and rims that step further are not faint
    for name in ("orange_ring", "red_on_black", "default"):
        d = get_design(name)
        rims = [m for m in Reference.from_image(d.draw().image, d.size_m).marks if m.rim]
        assert rims and not any(m.faint for m in rims)


def test_a_square_holes_cut_corners_make_no_repeated_vertices() -> None:
    """A white square cut out of a red disc (a hospital pad's cross, simplified): its hole
    is traced with its corners cut off, whose two ends the refinement puts on one point.
    A side of no length has no direction: its edge's normal came out nan."""
    pic = np.full((600, 600, 3), 255, np.uint8)
    cv2.circle(pic, (300, 300), 290, (30, 30, 200), -1, cv2.LINE_AA)
    cv2.rectangle(pic, (180, 180), (420, 420), (255, 255, 255), -1)
    h = np.array(  # a red H, 180 x 200 (a 45 px leg, a 40 px bar)
        [[210, 200], [255, 200], [255, 280], [345, 280], [345, 200], [390, 200], [390, 400],
         [345, 400], [345, 320], [255, 320], [255, 400], [210, 400]],
        np.int32,
    )  # fmt: skip
    cv2.fillPoly(pic, [h], (30, 30, 200), cv2.LINE_AA)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        ref = Reference.from_image(pic, 1.0)
        model = ref.edge_model
    for mark in ref.marks:
        c = mark.corners_m
        assert np.hypot(*(c - np.roll(c, 1, axis=0)).T).min() > 0.0
    assert np.hypot(*(model.b_m - model.a_m).T).min() > 0.0
    square = [m for m in ref.marks if len(m.corners_m) <= 8]
    assert [len(m.corners_m) for m in square] == [4]
