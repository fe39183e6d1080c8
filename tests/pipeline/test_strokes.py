import numpy as np

from pipeline.homography_fit import apply_h
from pipeline.render import PadGeometry
from pipeline.strokes import cut_through, deepest_dip, stroke_samples
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
