import cv2
import numpy as np
import pytest

from pipeline.hfit import fit_h

SS = 8


def _draw(rects, size=(160, 200), angle_deg=0.0):
    """Rectangles (x0, y0, x1, y1) filled with exact coverage, then turned about the centre."""
    h, w = size
    big = np.zeros((h * SS, w * SS), np.uint8)
    for x0, y0, x1, y1 in rects:
        cv2.rectangle(
            big, (round(x0 * SS), round(y0 * SS)), (round(x1 * SS) - 1, round(y1 * SS) - 1), 255, -1
        )
    img = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
    if angle_deg:
        M = cv2.getRotationMatrix2D((w / 2 - 0.5, h / 2 - 0.5), angle_deg, 1.0)
        img = cv2.warpAffine(img, M, (w, h), flags=cv2.INTER_LINEAR)
    return (img > 127).astype(np.uint8) * 255


H = [(40, 30, 60, 130), (140, 30, 160, 130), (60, 72, 140, 88)]
TRUTH = np.array(
    [(40, 30), (60, 30), (60, 72), (140, 72), (140, 30), (160, 30),
     (160, 130), (140, 130), (140, 88), (60, 88), (60, 130), (40, 130)], float
) - 0.5  # fmt: skip


def test_block_h_corners_in_order():
    fit = fit_h(_draw(H))
    assert fit is not None and fit.iou > 0.97
    np.testing.assert_allclose(fit.corners, TRUTH, atol=0.6)
    assert fit.leg_fraction == pytest.approx(20 / 120, abs=0.01)


def test_serifs_do_not_add_corners():
    serifs = [(34, 30, 66, 36), (34, 124, 66, 130), (134, 30, 166, 36), (134, 124, 166, 130)]
    fit = fit_h(_draw(H + serifs))
    assert fit is not None and 0.75 < fit.iou < 0.97
    np.testing.assert_allclose(fit.corners, TRUTH, atol=1.0)


def test_thin_strokes_down_to_eight_percent_of_the_width():
    thin = [(40, 30, 50, 130), (150, 30, 160, 130), (50, 76, 150, 84)]
    fit = fit_h(_draw(thin))
    assert fit is not None
    assert fit.leg_fraction == pytest.approx(10 / 120, abs=0.01)


@pytest.mark.parametrize("angle", [17.0, 90.0, -133.0])
def test_any_rotation(angle):
    fit = fit_h(_draw(H, size=(220, 220), angle_deg=angle))
    assert fit is not None and fit.iou > 0.93
    sides = np.linalg.norm(np.diff(np.vstack([fit.corners, fit.corners[:1]]), axis=0), axis=1)
    assert sides[0] == pytest.approx(20, abs=1.5)  # top of the left leg
    assert sides[11] == pytest.approx(100, abs=1.5)  # its outer side


@pytest.mark.parametrize(
    "rects",
    [
        [(40, 30, 160, 130)],  # a slab
        [(40, 30, 60, 130), (140, 30, 160, 130)],  # II: no crossbar
        [(40, 30, 60, 130), (140, 30, 160, 130), (60, 114, 140, 130)],  # U
        [(40, 72, 160, 88), (92, 20, 108, 140)],  # +
        [(40, 30, 60, 130), (140, 30, 160, 130), (90, 30, 110, 130), (60, 72, 140, 88)],  # 3 legs
    ],
)
def test_shapes_that_are_not_an_h(rects):
    assert fit_h(_draw(rects)) is None
