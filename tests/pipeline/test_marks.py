import numpy as np
import pytest

from pipeline import Reference
from pipeline.marks import Mark, symmetric_marks
from pipeline.render import get_design


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
