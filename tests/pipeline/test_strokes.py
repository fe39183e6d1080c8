import numpy as np

from pipeline.homography_fit import apply_h
from pipeline.render import PadGeometry
from pipeline.strokes import (
    MAX_NOTCH_FILL,
    cut_through,
    deepest_dip,
    notch_fill,
    notches,
    stroke_samples,
)
from tests.pipeline.bench_support import score_bench_frames

H_M = PadGeometry().h_corners_m
A = np.array([[700.0, 0.0, 320.0], [0.0, -700.0, 240.0], [0.0, 0.0, 1.0]])


def _draw(cut: bool) -> np.ndarray:
    import cv2

    img = np.full((480, 640, 3), 30, np.uint8)
    cv2.fillPoly(img, [np.round(apply_h(A, H_M)).astype(np.int32)], (230, 230, 230))
    if cut:  # a gap across the left leg
        x0 = int(apply_h(A, H_M[:1])[0, 0])
        img[180:188, x0 - 4 : x0 + 52] = 30
    return cv2.GaussianBlur(img, (5, 5), 1.0)


def _not_paint(pts):
    return np.zeros(len(pts), bool)


def test_a_solid_h_has_no_dip_and_a_cut_one_has():
    samples = stroke_samples(H_M, A, _not_paint)
    weights = np.array([0.114, 0.587, 0.299])
    assert deepest_dip(_draw(False), weights, samples) < 0.1
    assert deepest_dip(_draw(True), weights, samples) > 0.6


def test_shadows_are_not_gaps():
    img = _draw(False).astype(np.float32)
    img[:, 320:] *= 0.5  # a shadow's edge across the crossbar
    samples = stroke_samples(H_M, A, _not_paint)
    assert deepest_dip(img.astype(np.uint8), np.array([0.114, 0.587, 0.299]), samples) < 0.35


def test_a_cut_stroke_stands_out_of_a_noisy_frame():
    samples = stroke_samples(H_M, A, _not_paint)
    weights = np.array([0.114, 0.587, 0.299])
    rng = np.random.default_rng(0)
    for cut in (False, True):
        for _ in range(5):
            noisy = _draw(cut) + rng.normal(0.0, 40.0, (480, 640, 3))
            assert cut_through(np.clip(noisy, 0, 255).astype(np.uint8), weights, samples) is cut


def test_a_small_h_in_a_noisy_frame_is_not_taken_for_a_cut_one():
    # The bench's paper_ring at 2.9 m, 16 dB: an H of 15 px whose strokes are 1.5 px.
    # Its paint changes by a fifth of the contrast from one point to the next along
    # their middles; the deepest dip came to 0.52, over MAX_DIP, and the pad was
    # refused as a broken H.
    assert score_bench_frames("paper_ring", (76,)).detected == 1


def test_a_window_a_read_only_frame_and_a_gray_one_read_the_strokes_alike():
    # A window cut out of a frame (its rows not contiguous), a read-only copy and the
    # frame itself; a gray picture and the same picture with three equal channels.
    weights = np.array([0.114, 0.587, 0.299])
    frame = _draw(True)
    whole = deepest_dip(frame, weights, stroke_samples(H_M, A, _not_paint))
    shift = np.array([[1.0, 0.0, -100.0], [0.0, 1.0, -60.0], [0.0, 0.0, 1.0]])
    window = frame[60:420, 100:560]
    assert not window.flags.c_contiguous
    in_window = stroke_samples(H_M, shift @ A, _not_paint)
    assert abs(deepest_dip(window, weights, in_window) - whole) < 1e-9
    frozen = frame.copy()
    frozen.setflags(write=False)
    assert deepest_dip(frozen, weights, stroke_samples(H_M, A, _not_paint)) == whole
    gray = frame[..., 1].copy()
    three = np.dstack([gray] * 3)
    samples = stroke_samples(H_M, A, _not_paint)
    assert abs(deepest_dip(gray, weights, samples) - deepest_dip(three, weights, samples)) < 1e-9


def _h_paint(pts):
    """The H's paint as a reference shows it: inside its 12-corner outline."""
    import cv2

    outline = H_M.astype(np.float32).reshape(-1, 1, 2)
    return np.array(
        [cv2.pointPolygonTest(outline, (float(x), float(y)), False) >= 0 for x, y in pts]
    )


def _bar_cut_by_a_leg() -> np.ndarray:
    """The H with a gap cut through its crossbar next to the left leg."""
    img = _draw(False)
    px = apply_h(A, H_M)  # corners 2 and 9: the crossbar's inner corners on the left
    x_in, y_top, y_bot = int(px[2, 0]), int(px[2, 1]), int(px[9, 1])
    img[y_top - 3 : y_bot + 3, x_in + 1 : x_in + 7] = 30
    return img


def test_a_gap_cut_through_the_crossbar_next_to_a_leg_is_a_cut():
    # A broken H of the design bench's floor, its gap next to a leg, passed for a bold
    # H: the crossbar's points stopped a quarter of its length short of the legs.
    weights = np.array([0.114, 0.587, 0.299])
    samples = stroke_samples(H_M, A, _h_paint)
    assert not cut_through(_draw(False), weights, samples)
    assert cut_through(_bar_cut_by_a_leg(), weights, samples)


def _notched(fill: bool, shadow_x: int | None = None) -> np.ndarray:
    """The H, its lower notch's half next to the crossbar painted over (a letter M's V
    under a crossbar fitted at its point); with a shadow's edge at ``shadow_x``."""
    import cv2

    img = np.full((480, 640, 3), 30, np.uint8)
    cv2.fillPoly(img, [np.round(apply_h(A, H_M)).astype(np.int32)], (230, 230, 230))
    px = apply_h(A, H_M)  # corners 8, 9: the crossbar's lower inner corners; 7: a leg's end
    if fill:
        depth = int(0.5 * (px[7, 1] - px[8, 1]))
        img[int(px[8, 1]) : int(px[8, 1]) + depth, int(px[9, 0]) : int(px[8, 0])] = 230
    out = cv2.GaussianBlur(img, (5, 5), 1.0).astype(np.float32)
    if shadow_x is not None:
        out[:, shadow_x:] *= 0.45
    return out.astype(np.uint8)


def test_notches_painted_over_are_no_h_s():
    weights = np.array([0.114, 0.587, 0.299])
    where = notches(H_M, _h_paint)
    # The H's bare notches read as its board wherever a shadow's edge falls (the H
    # spans x 224-416, its notches' middle x 320)...
    for shadow_x in (None, 200, 260, 320, 380, 440):
        assert notch_fill(_notched(False, shadow_x), weights, where, A) < 0.1, shadow_x
    # ... and painted over, as paint, where no shadow's edge falls between a leg and
    # the notch's middle.
    for shadow_x in (None, 200, 440):
        filled = notch_fill(_notched(True, shadow_x), weights, where, A)
        assert filled > MAX_NOTCH_FILL, shadow_x
