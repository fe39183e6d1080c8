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


def _italic(lean: float, angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The H above, its legs leaning by ``lean`` (x += lean * its height above the
    middle), turned about the centre: the picture (220 px) and its 12 true corners."""
    c = np.array([109.5, 109.5])
    pts = TRUTH + 0.5 + [10.0, 30.0] - [110.0, 110.0]  # (the H centred on the canvas)
    pts[:, 0] -= lean * pts[:, 1]
    a = np.radians(-angle_deg)  # (cv2's angles turn the picture counter-clockwise)
    turn = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    corners = pts @ turn.T + c
    big = np.zeros((220 * SS, 220 * SS), np.uint8)
    cv2.fillPoly(big, [np.round(((corners + 0.5) * SS - 0.5) * 16).astype(np.int32)], 255, 8, 4)
    img = cv2.resize(big, (220, 220), interpolation=cv2.INTER_AREA)
    return (img > 127).astype(np.uint8) * 255, corners


@pytest.mark.parametrize(("lean", "angle"), [(0.2, 0.0), (-0.3, 0.0), (0.25, 37.0), (0.15, -110.0)])
def test_an_italic_hs_corners_are_its_own(lean, angle):
    # Its legs lean, its crossbar and ends stay level: fitted as a turned block H (its
    # legs' minimum-area rectangle stands along them), its ends and crossbar came a
    # tenth of its height off (0.88 of it covered at a lean of 0.2); sheared level
    # first, the block H is the italic one.
    picture, truth = _italic(lean, angle)
    fit = fit_h(picture)
    assert fit is not None and fit.iou > 0.97
    # (read from whichever of its ends is nearer the picture's top: a half turn apart)
    off = min(np.abs(fit.corners - np.roll(truth, k, axis=0)).max() for k in (0, 6))
    assert off < 1.0, (fit.corners, truth)


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
