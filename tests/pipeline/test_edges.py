import cv2
import numpy as np
import pytest

from pipeline.edges import refine_polygon, signed_area

SS = 16  # supersampling for exact area-coverage drawing


def _draw(poly: np.ndarray, size: int = 200, inside: int = 220, outside: int = 25) -> np.ndarray:
    """A polygon drawn with exact pixel coverage (pixel centres at integers)."""
    big = np.full((size * SS, size * SS), outside, np.uint8)
    pts = np.round(((poly + 0.5) * SS - 0.5) * 16).astype(np.int32)
    cv2.fillPoly(big, [pts], inside, cv2.LINE_8, shift=4)
    return cv2.resize(big, (size, size), interpolation=cv2.INTER_AREA)


QUAD = np.array([[50.3, 60.7], [150.2, 40.1], [160.9, 140.4], [70.5, 150.6]])


def test_refines_corners_to_a_tenth_of_a_pixel():
    img = cv2.GaussianBlur(_draw(QUAD), (5, 5), 1.0)
    out, rms = refine_polygon(img, np.round(QUAD))
    assert np.max(np.abs(out - QUAD)) < 0.15
    assert rms < 0.3


@pytest.mark.parametrize("phase", np.arange(0.0, 1.0, 0.125))
def test_sides_along_the_pixel_grid_are_placed_at_any_phase(phase):
    # (a reference picture's H: every side along a row or a column, where a parabola
    # through the steepest drops locked to the grid, up to 0.5 px off)
    rect = np.array([[60.0, 70.0], [140.0, 70.0], [140.0, 130.0], [60.0, 130.0]])
    rect += [phase, 0.5 * phase]
    out, _ = refine_polygon(cv2.GaussianBlur(_draw(rect), (5, 5), 1.0), np.round(rect))
    assert np.max(np.abs(out - rect)) < 0.15


def test_refinement_survives_noise():
    rng = np.random.default_rng(1)
    noisy = np.clip(_draw(QUAD) + rng.normal(0, 20, (200, 200)), 0, 255).astype(np.uint8)
    out, _ = refine_polygon(cv2.GaussianBlur(noisy, (5, 5), 1.0), np.round(QUAD))
    assert np.max(np.abs(out - QUAD)) < 0.25


def test_dark_polygon_on_bright_ground():
    img = cv2.GaussianBlur(_draw(QUAD, inside=20, outside=200), (5, 5), 1.0)
    out, _ = refine_polygon(img, np.round(QUAD), bright_inside=False)
    assert np.max(np.abs(out - QUAD)) < 0.15


def test_orientation_does_not_matter():
    img = cv2.GaussianBlur(_draw(QUAD), (5, 5), 1.0)
    out, _ = refine_polygon(img, np.round(QUAD[::-1]))
    assert np.max(np.abs(out - QUAD[::-1])) < 0.15
    assert signed_area(QUAD) > 0 > signed_area(QUAD[::-1])


def test_returns_none_where_there_is_no_edge():
    flat = np.full((200, 200), 128, np.uint8)
    assert refine_polygon(flat, QUAD) is None


def test_rejects_degenerate_input():
    with pytest.raises(ValueError, match="corners"):
        refine_polygon(np.zeros((10, 10), np.uint8), np.zeros((2, 2)))


def test_a_polygon_whose_sides_are_too_short_to_measure_is_not_refined():
    # (a small reference picture's mark of a few pixels: nothing to sample, no error)
    tiny = np.array([[10.0, 10.0], [13.0, 10.0], [13.0, 13.0], [10.0, 13.0]])
    img = cv2.GaussianBlur(_draw(tiny, size=30), (3, 3), 0.8)
    assert refine_polygon(img, tiny) is None
