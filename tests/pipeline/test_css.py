"""CSS corners: the reference's results, the H, and one test per reference fault."""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import pytest

from pipeline.css import css_corners, detect_corners, gaussian_window, trace_edges
from tests.pipeline.shapes import H_OUTLINE

# --- helpers --------------------------------------------------------------------------


def edge_map(size: int = 100) -> np.ndarray:
    return np.zeros((size, size), bool)


def rc(points: np.ndarray) -> set[tuple[int, int]]:
    """(x, y) 0-based corner points as the spec's 1-based (row, col)."""
    return {(int(y) + 1, int(x) + 1) for x, y in np.asarray(points).reshape(-1, 2)}


def assert_same_points(found: np.ndarray, expected_rc: list[tuple[int, int]], tol=1.0) -> None:
    """``found`` (x, y, 0-based) equals the 1-based (row, col) set within ``tol`` px."""
    found = np.asarray(found, float).reshape(-1, 2)
    expected = np.array([(c - 1, r - 1) for r, c in expected_rc], float).reshape(-1, 2)
    assert found.shape[0] == expected.shape[0], (rc(found), expected_rc)
    if found.size == 0:
        return
    gaps = np.linalg.norm(found[:, None, :] - expected[None, :, :], axis=2)
    # A one-to-one match: every expected point has its own found point nearby.
    assert np.all(gaps.min(axis=0) <= tol), (rc(found), expected_rc)
    assert np.all(gaps.min(axis=1) <= tol), (rc(found), expected_rc)
    assert len(set(gaps.argmin(axis=1).tolist())) == expected.shape[0]


def rotate(points: np.ndarray, deg: float) -> np.ndarray:
    t = math.radians(deg)
    return points @ np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]).T


def h_contour(scale: float, deg: float, centre=(300, 300)) -> tuple[np.ndarray, np.ndarray]:
    """The rasterised H's contour (CHAIN_APPROX_NONE) and its integer true vertices."""
    vertices = np.round(rotate((H_OUTLINE - H_OUTLINE.mean(0)) * scale, deg) + np.array(centre))
    mask = np.zeros((2 * centre[1], 2 * centre[0]), np.uint8)
    cv2.fillPoly(mask, [vertices.astype(np.int32)], 255)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    assert len(contours) == 1
    return contours[0], vertices


def filled_contour(draw) -> np.ndarray:
    mask = np.zeros((500, 500), np.uint8)
    draw(mask)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    return max(contours, key=len)


def polyline(vertices: list[tuple[float, float]], step: float = 1.0) -> np.ndarray:
    """Points every ``step`` px along straight segments through ``vertices``."""
    pts = []
    for (x0, y0), (x1, y1) in itertools.pairwise(vertices):
        n = max(1, round(math.hypot(x1 - x0, y1 - y0) / step))
        t = np.arange(n) / n
        pts.append(np.stack([x0 + (x1 - x0) * t, y0 + (y1 - y0) * t], axis=1))
    pts.append(np.array([vertices[-1]], float))
    return np.concatenate(pts)


def kink(angle_deg: float, arm: float = 80.0, rotation_deg: float = 0.0) -> np.ndarray:
    """An open two-segment curve whose interior angle at the joint is ``angle_deg``."""
    turn = math.radians(180.0 - angle_deg)
    a = (-arm, 0.0)
    b = (arm * math.cos(turn), arm * math.sin(turn))
    pts = polyline([a, (0.0, 0.0), b])
    return rotate(pts, rotation_deg) + np.array([250.0, 250.0])


# --- the reference's results on 100x100 edge maps (spec table, 1-based row/col) ---------


def square_outline() -> np.ndarray:
    em = edge_map()
    em[29:70, 29] = em[29:70, 69] = True
    em[29, 29:70] = em[69, 29:70] = True
    return em


def l_shape() -> np.ndarray:
    em = edge_map()
    em[19:80, 29] = True  # col 30, rows 20..80
    em[79, 29:80] = True  # row 80, cols 30..80
    return em


def t_shape() -> np.ndarray:
    em = edge_map()
    em[29, 19:80] = True  # row 30, cols 20..80
    em[30:80, 49] = True  # col 50, rows 31..80
    return em


def circle_outline() -> np.ndarray:
    em = np.zeros((100, 100), np.uint8)
    cv2.circle(em, (49, 49), 30, 1, 1)
    return em > 0


def right_triangle() -> np.ndarray:
    em = edge_map()
    em[19:80, 19] = True  # col 20, rows 20..80
    em[79, 19:80] = True  # row 80, cols 20..80
    idx = np.arange(19, 80)
    em[idx, idx] = True  # the hypotenuse
    return em


REFERENCE = {
    "square": (square_outline, [(30, 30), (70, 30), (70, 70), (30, 70)]),
    "L": (l_shape, [(80, 30), (20, 30), (80, 80)]),
    "T": (t_shape, [(30, 50), (30, 20), (80, 50), (30, 80)]),
    "circle": (circle_outline, []),
    "right_triangle": (right_triangle, [(21, 20), (80, 20), (80, 79)]),
}


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_reference_results_on_edge_maps(name: str) -> None:
    build, expected = REFERENCE[name]
    found = detect_corners(build())
    assert found.dtype == np.float64 and found.shape[1] == 2
    assert_same_points(found, expected)


def test_reference_order_curves_then_end_points() -> None:
    # The T splits into the L-shaped curve (traced first) and the right half of the bar;
    # that half's start lies within 5 px of the corner, so only its far end is added.
    assert [tuple(p) for p in detect_corners(t_shape())] == [
        (49.0, 29.0),
        (19.0, 29.0),
        (49.0, 79.0),
        (79.0, 29.0),
    ]


# --- the H, circles, rectangles ---------------------------------------------------------


@pytest.mark.parametrize("scale", [10, 25, 60])
@pytest.mark.parametrize("deg", [0, 17, 45, 72, 90, 133, 200, 311])
def test_h_outline_gives_its_12_corners_in_contour_order(scale: float, deg: float) -> None:
    contour, vertices = h_contour(scale, deg)
    idx = css_corners(contour, closed=True)
    assert idx.dtype.kind == "i" and np.all(np.diff(idx) > 0)
    assert idx.size == 12
    corners = contour[idx, 0, :].astype(float)
    gaps = np.linalg.norm(corners[:, None, :] - vertices[None, :, :], axis=2)
    nearest = gaps.argmin(axis=1)
    assert np.all(gaps.min(axis=1) <= 1.5)
    # Contour order: consecutive corners are consecutive vertices, all one way round.
    steps = np.diff(np.append(nearest, nearest[0])) % 12
    assert set(steps.tolist()) in ({1}, {11})


@pytest.mark.parametrize(("tilt", "yaw", "dist"), [(30, 20, 3.0), (45, 140, 4.0), (55, 260, 6.0)])
def test_h_seen_in_perspective_gives_12_corners(tilt: float, yaw: float, dist: float) -> None:
    # A unit-tall H on the ground, seen by a 600 px camera tilted by ``tilt`` degrees.
    pad = (H_OUTLINE - H_OUTLINE.mean(0)) / 5
    t, y = math.radians(tilt), math.radians(yaw)
    rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])
    cam = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    world = np.c_[pad, np.zeros(len(pad))] @ rz.T @ rx.T + np.array([0, 0, dist])
    uv = world @ cam.T
    uv = uv[:, :2] / uv[:, 2:]
    mask = np.zeros((480, 640), np.uint8)
    cv2.fillPoly(mask, [np.round(uv * 16).astype(np.int32)], 1, shift=4)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    idx = css_corners(contours[0], closed=True)
    assert idx.size == 12
    gaps = np.linalg.norm(contours[0][idx, 0, :][:, None, :] - uv[None], axis=2)
    assert np.all(gaps.min(axis=1) <= 2.0) and len(set(gaps.argmin(axis=1).tolist())) == 12


def test_h_from_a_noisy_thresholded_frame_gives_12_corners() -> None:
    rng = np.random.default_rng(7)
    for deg in (0, 33, 71, 118):
        vertices = rotate((H_OUTLINE - H_OUTLINE.mean(0)) * 20, deg) + np.array([200, 200])
        gray = np.full((400, 400), 40, np.uint8)
        cv2.fillPoly(gray, [np.round(vertices * 16).astype(np.int32)], 210, cv2.LINE_AA, 4)
        gray = cv2.GaussianBlur(gray, (0, 0), 1.0)
        gray = np.clip(gray + rng.normal(0, 10, gray.shape), 0, 255).astype(np.uint8)
        _, binary = cv2.threshold(gray, 125, 255, cv2.THRESH_BINARY)
        contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        contour = max(contours, key=cv2.contourArea)
        idx = css_corners(contour, closed=True)
        assert idx.size == 12, deg
        gaps = np.linalg.norm(contour[idx, 0, :][:, None, :] - vertices[None], axis=2)
        assert np.all(gaps.min(axis=1) <= 3.0) and len(set(gaps.argmin(axis=1).tolist())) == 12


def test_h_corners_do_not_depend_on_the_contour_start() -> None:
    contour, _ = h_contour(30, 23)
    base = contour[css_corners(contour, closed=True), 0, :]
    for shift in (1, 57, 211, len(contour) - 3):
        rolled = np.roll(contour, shift, axis=0)
        found = rolled[css_corners(rolled, closed=True), 0, :]
        # Equal up to the pick within a one-pixel plateau (a tie broken by rounding).
        gaps = np.linalg.norm(found[:, None, :] - base[None, :, :], axis=2).min(axis=1)
        assert found.shape == base.shape and np.all(gaps <= 1.5)


def test_a_caller_wanting_12_corners_gets_the_same_answer_sooner() -> None:
    # `fewest` skips the false-corner passes where too few candidates reach them: the
    # answer is the same wherever the full detector finds 12 or more, and under 12
    # wherever it finds under 12. Blobs of a thresholded noise image and H outlines.
    rng = np.random.default_rng(3)
    noise = cv2.GaussianBlur(rng.normal(0, 1, (300, 300)), (0, 0), 4.0)
    mask = (noise > 0.05).astype(np.uint8)
    blobs, _ = cv2.findContours(mask, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    hs = [h_contour(scale, deg)[0] for scale in (12, 25) for deg in (0, 40)]
    curves = [c for c in blobs if len(c) >= 20] + hs
    short = 0
    for curve in curves:
        full = css_corners(curve, closed=True)
        sooner = css_corners(curve, closed=True, fewest=12)
        if full.size >= 12:
            assert sooner.tolist() == full.tolist()
        else:
            assert sooner.size < 12
            short += sooner.size != full.size
    assert len(curves) > 40 and short  # (some were cut short)


@pytest.mark.parametrize("radius", [12, 30, 55, 70, 100, 160, 220])
def test_circle_gives_no_corners(radius: int) -> None:
    contour = filled_contour(lambda m: cv2.circle(m, (250, 250), radius, 1, -1))
    assert css_corners(contour, closed=True).size == 0
    thin = np.zeros((500, 500), np.uint8)
    cv2.circle(thin, (250, 250), radius, 1, 1)
    assert detect_corners(thin > 0).shape == (0, 2)


@pytest.mark.parametrize("radius", [40, 80, 150])
def test_smooth_gray_disk_gives_no_corners(radius: int) -> None:
    gray = np.full((400, 400), 30, np.uint8)
    cv2.circle(gray, (200 * 16, 200 * 16), radius * 16, 200, -1, cv2.LINE_AA, 4)
    assert detect_corners(gray).shape == (0, 2)


@pytest.mark.parametrize("deg", [0, 10, 30, 45, 60, 81])
@pytest.mark.parametrize("size", [(40, 25), (120, 60), (300, 200)])
def test_rectangle_gives_4_corners(deg: float, size: tuple[int, int]) -> None:
    box = cv2.boxPoints(((250.3, 250.6), size, deg))
    contour = filled_contour(
        lambda m: cv2.fillPoly(m, [np.round(box * 16).astype(np.int32)], 1, shift=4)
    )
    idx = css_corners(contour, closed=True)
    assert idx.size == 4
    gaps = np.linalg.norm(contour[idx, 0, :][:, None, :] - box[None], axis=2)
    assert np.all(gaps.min(axis=1) <= 2.0) and len(set(gaps.argmin(axis=1).tolist())) == 4


def test_gray_image_goes_through_canny() -> None:
    gray = np.full((120, 140), 30, np.uint8)
    cv2.rectangle(gray, (30, 40), (100, 95), 200, -1)
    found = detect_corners(gray)
    assert_same_points(found, [(41, 31), (96, 31), (96, 101), (41, 101)], tol=1.5)


# --- one test per fault of the reference ------------------------------------------------


@pytest.mark.parametrize("rotation", range(0, 360, 15))
def test_fault_unwrapped_angle_169_deg_kink_rejected_at_any_rotation(rotation: int) -> None:
    # The reference read a 169 deg kink as 530 deg at some rotations and kept it.
    assert css_corners(kink(169.0, rotation_deg=rotation), closed=False, endpoints=False).size == 0
    # A clear corner is kept at every rotation, at the joint (index 80).
    sharp = css_corners(kink(120.0, rotation_deg=rotation), closed=False, endpoints=False)
    assert sharp.size == 1 and abs(int(sharp[0]) - 80) <= 1
    # Turning the other way (a reflex angle of 210 deg) is a corner too.
    mirrored = kink(150.0, rotation_deg=rotation) * np.array([1.0, -1.0])
    assert css_corners(mirrored, closed=False, endpoints=False).size == 1


def test_fault_zero_padding_results_move_exactly_with_the_image() -> None:
    # Corners within W samples of an open curve's end are where zero padding bit.
    w = gaussian_window(3.0)
    curve = polyline([(5.0, 0.0), (0.0, 0.0), (0.0, 60.0), (60.0, 60.0), (60.0, 53.0)])
    base = css_corners(curve, closed=False, endpoints=False)
    assert base.tolist() == [5, 65, 125] and base[0] < w and len(curve) - 1 - base[-1] < w
    for shift in ((1000.0, -731.0), (-250.5, 4096.25), (3.0, 3.0)):
        moved = css_corners(curve + np.array(shift), closed=False, endpoints=False)
        np.testing.assert_array_equal(moved, base)
    # Whole detector: shifting the edge map shifts every corner by exactly as much.
    em = np.zeros((200, 220), bool)
    em[:100, :100] = right_triangle()
    em[110:190, 120:200] = l_shape()[10:90, 10:90]
    found = detect_corners(em)
    assert found.shape[0] == 6
    for dy, dx in ((0, 1), (7, 13), (3, 0)):
        moved = np.zeros((200 + dy, 220 + dx), bool)
        moved[dy:, dx:] = em
        np.testing.assert_array_equal(detect_corners(moved), found + np.array([dx, dy]))


def test_fault_no_crash_without_corners_or_long_curves() -> None:
    assert detect_corners(edge_map()).shape == (0, 2)
    # Only curves too short to keep ((100 + 100) / 25 = 8 points or fewer).
    short = edge_map()
    short[10, 10:18] = True
    short[50:55, 60] = True
    assert trace_edges(short) == []
    assert detect_corners(short).shape == (0, 2)
    # An open curve without any corner: only its end points (or nothing).
    line = edge_map()
    line[40, 10:90] = True
    assert_same_points(detect_corners(line), [(41, 11), (41, 90)])
    assert detect_corners(line, endpoints=False).shape == (0, 2)
    # Gray images with no edge at all, or no long one.
    assert detect_corners(np.full((64, 64), 77, np.uint8)).shape == (0, 2)
    speck = np.zeros((64, 64), np.uint8)
    speck[30, 30] = 255
    assert detect_corners(speck).shape == (0, 2)
    # Curves at or below W points are skipped for corners (end points still count).
    assert css_corners(np.zeros((0, 2)), closed=True).size == 0
    assert css_corners(np.zeros((0, 2)), closed=False).size == 0
    assert css_corners(np.array([[3.0, 4.0]]), closed=False).tolist() == [0]
    tiny = polyline([(0, 0), (3, 3), (6, 0)])
    assert len(tiny) <= gaussian_window(3.0)
    assert css_corners(tiny, closed=False).tolist() == [0, len(tiny) - 1]
    assert css_corners(tiny, closed=True).size == 0


def test_fault_quantised_curvature_results_do_not_depend_on_units() -> None:
    # The reference's ceil(K * 100) / 100 flattens every curvature below 0.01 to 0.01:
    # scaled up by 128 this H would lose all its corners. Unquantised, the scale is
    # exact in binary, so the indices must be identical.
    contour, _ = h_contour(25, 31)
    pts = contour[:, 0, :].astype(float)
    base = css_corners(pts, closed=True)
    assert base.size == 12
    for factor in (128.0, 1 / 64):
        np.testing.assert_array_equal(css_corners(pts * factor, closed=True), base)


def test_corners_on_the_image_border_are_fine() -> None:
    # The reference crashed drawing marks there; we draw nothing, and border corners count.
    em = np.zeros((60, 80), bool)
    em[0, :] = em[-1, :] = em[:, 0] = em[:, -1] = True
    assert_same_points(detect_corners(em), [(1, 1), (60, 1), (60, 80), (1, 80)])


# --- tracing ----------------------------------------------------------------------------


def test_trace_orders_points_and_flags_closed_curves() -> None:
    curves = trace_edges(square_outline())
    assert len(curves) == 1
    pts, closed = curves[0]
    assert closed and pts.shape == (160, 2) and pts.dtype.kind == "i"
    assert tuple(pts[0]) == (29, 29) and tuple(pts[1]) == (29, 30)  # down column 30 first
    steps = np.abs(np.diff(pts, axis=0)).max(axis=1)
    assert np.all(steps == 1)
    assert {tuple(p) for p in pts} == {tuple(p) for p in np.argwhere(square_outline())[:, ::-1]}
    (p1, c1), (p2, c2) = trace_edges(t_shape())
    assert not c1 and not c2 and len(p1) == 81 and len(p2) == 30
    assert tuple(p1[0]) == (19, 29) and tuple(p1[-1]) == (49, 79)


def test_trace_walks_both_ways_from_the_seed() -> None:
    # A '<': the column-major seed is its tip, in the middle of the curve.
    em = edge_map()
    for i in range(31):
        em[40 - i, 10 + i] = em[40 + i, 10 + i] = True
    (pts, closed), *rest = trace_edges(em)
    assert not rest and not closed and len(pts) == 61
    # Forward from the tip goes up (smaller y wins the tie), backward goes down; the
    # backward half comes first.
    assert tuple(pts[0]) == (40, 70) and tuple(pts[30]) == (10, 40) and tuple(pts[-1]) == (40, 10)
    assert_same_points(detect_corners(em), [(41, 11), (71, 41), (11, 41)])


def test_trace_gap_size_bridges_one_pixel_gaps() -> None:
    em = edge_map()
    em[50, 10:40] = True
    em[50, 41:80] = True  # one pixel missing at column 40
    assert len(trace_edges(em)) == 2
    bridged = trace_edges(em, gap_size=2)
    assert len(bridged) == 1 and len(bridged[0][0]) == 69


def test_trace_min_length_keeps_longer_curves_only() -> None:
    em = edge_map()
    em[10, 10:20] = True  # 10 points
    em[30, 10:40] = True  # 30 points
    assert [len(p) for p, _ in trace_edges(em)] == [10, 30]  # default (100+100)/25 = 8
    assert [len(p) for p, _ in trace_edges(em, min_length=10)] == [30]
    assert [len(p) for p, _ in trace_edges(em, min_length=9)] == [10, 30]
    assert trace_edges(em, min_length=30) == []
    assert trace_edges(np.zeros((0, 0), bool)) == []
    assert trace_edges(em.astype(np.uint8) * 255, min_length=0)[0][0].shape == (10, 2)


def test_opencv_contour_layout_is_accepted() -> None:
    contour, _ = h_contour(20, 10)
    np.testing.assert_array_equal(
        css_corners(contour, closed=True), css_corners(contour[:, 0, :], closed=True)
    )


def test_gaussian_window() -> None:
    assert gaussian_window(3.0) == 12
    assert gaussian_window(1.0) == 4
    assert gaussian_window(0.2) == 1
    assert gaussian_window(50.0) == 30


# --- bad input --------------------------------------------------------------------------

GOOD = polyline([(0, 0), (40, 0), (40, 40)])


@pytest.mark.parametrize(
    ("args", "kwargs", "name"),
    [
        ((None, True), {}, "curve"),
        ((np.zeros((10, 3)), True), {}, "curve"),
        ((np.zeros(10), True), {}, "curve"),
        ((np.zeros((10, 2, 2)), True), {}, "curve"),
        ((np.array([["a", "b"]] * 20), True), {}, "curve"),
        ((np.ones((20, 2), bool), True), {}, "curve"),
        ((np.ones((20, 2), complex), True), {}, "curve"),
        ((np.where(np.arange(40)[:, None] == 7, np.nan, GOOD[:40]), True), {}, "curve"),
        ((np.where(np.arange(40)[:, None] == 7, np.inf, GOOD[:40]), True), {}, "curve"),
        ((GOOD, 1), {}, "closed"),
        ((GOOD, None), {}, "closed"),
        ((GOOD, True), {"sigma": 0.0}, "sigma"),
        ((GOOD, True), {"sigma": -1.0}, "sigma"),
        ((GOOD, True), {"sigma": math.nan}, "sigma"),
        ((GOOD, True), {"sigma": "3"}, "sigma"),
        ((GOOD, True), {"c": -0.5}, "c"),
        ((GOOD, True), {"c": math.inf}, "c"),
        ((GOOD, True), {"t_angle_deg": 0.0}, "t_angle_deg"),
        ((GOOD, True), {"t_angle_deg": 200.0}, "t_angle_deg"),
        ((GOOD, True), {"endpoints": "yes"}, "endpoints"),
    ],
)
def test_css_corners_rejects_bad_input(args, kwargs, name: str) -> None:
    with pytest.raises(ValueError, match=f"^{name} "):
        css_corners(*args, **kwargs)


@pytest.mark.parametrize(
    ("arg", "kwargs", "name"),
    [
        (None, {}, "edge_map"),
        (np.zeros((5, 5, 3), bool), {}, "edge_map"),
        (np.zeros(5, bool), {}, "edge_map"),
        (np.zeros((5, 5), float), {}, "edge_map"),
        (np.zeros((5, 5), bool), {"gap_size": 0}, "gap_size"),
        (np.zeros((5, 5), bool), {"gap_size": 1.5}, "gap_size"),
        (np.zeros((5, 5), bool), {"gap_size": True}, "gap_size"),
        (np.zeros((5, 5), bool), {"min_length": -1}, "min_length"),
        (np.zeros((5, 5), bool), {"min_length": math.nan}, "min_length"),
    ],
)
def test_trace_edges_rejects_bad_input(arg, kwargs, name: str) -> None:
    with pytest.raises(ValueError, match=f"^{name} "):
        trace_edges(arg, **kwargs)


@pytest.mark.parametrize(
    ("arg", "kwargs", "name"),
    [
        (None, {}, "image"),
        (np.zeros((20, 20, 3), np.uint8), {}, "image"),
        (np.zeros((20, 20), np.float32), {}, "image"),
        (np.zeros((20, 20), np.uint16), {}, "image"),
        (np.zeros((20, 20), np.uint8), {"canny": (0.2, 0.5)}, "canny"),
        (np.zeros((20, 20), np.uint8), {"canny": (1.5, 0.0)}, "canny"),
        (np.zeros((20, 20), np.uint8), {"canny": 0.3}, "canny"),
        (np.zeros((20, 20), bool), {"sigma": 0}, "sigma"),
        (np.zeros((20, 20), bool), {"t_angle_deg": -5}, "t_angle_deg"),
        (np.zeros((20, 20), bool), {"gap_size": 0}, "gap_size"),
        (np.zeros((20, 20), bool), {"endpoints": 1}, "endpoints"),
    ],
)
def test_detect_corners_rejects_bad_input(arg, kwargs, name: str) -> None:
    with pytest.raises(ValueError, match=f"^{name} "):
        detect_corners(arg, **kwargs)
