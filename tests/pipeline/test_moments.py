"""Shape moments against OpenCV's oracle, invariances, orientation, eccentricity."""

from __future__ import annotations

import dataclasses
import json
import math

import cv2
import numpy as np
import pytest

from pipeline.moments import ShapeMoments, hu_distance, shape_moments
from tests.pipeline.shapes import H_OUTLINE

# Clearly asymmetric, so that every Hu invariant is far from 0.
BLOB = np.array([(10, 10), (120, 15), (100, 60), (60, 40), (30, 90)], float)


def rotate(points: np.ndarray, deg: float, about=(0.0, 0.0)) -> np.ndarray:
    t = math.radians(deg)
    r = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    about = np.asarray(about, float)
    return (points - about) @ r.T + about


def ellipse_polygon(a: float, b: float, n: int = 2000, centre=(400.0, 300.0)) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([centre[0] + a * np.cos(t), centre[1] + b * np.sin(t)], axis=1)


def filled(poly: np.ndarray, size=(600, 800)) -> np.ndarray:
    mask = np.zeros(size, np.uint8)
    cv2.fillPoly(mask, [np.round(poly * 16).astype(np.int32)], 255, shift=4)
    return mask


def contour_of(mask: np.ndarray) -> np.ndarray:
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    return max(contours, key=cv2.contourArea)


def assert_hu_close(ours: tuple[float, ...], ref: np.ndarray) -> None:
    ref = np.asarray(ref, float).ravel()
    # rtol as asked; atol only for invariants that are 0 up to rounding (symmetric shapes).
    np.testing.assert_allclose(ours, ref, rtol=1e-6, atol=1e-12 * abs(ref[0]))


CONTOURS = {
    "triangle": np.array([[[20, 30]], [[220, 40]], [[90, 200]]], np.int32),
    "blob_int": BLOB.astype(np.int32) + 300,
    "blob_reversed": (BLOB.astype(np.int32) + 300)[::-1].copy(),
    "h_contour": contour_of(filled(rotate(H_OUTLINE * 40, 23) + np.array([400, 300]))),
    "ellipse_float": ellipse_polygon(150, 40).astype(np.float32),
    "far_from_origin": (BLOB * 3 + 5000).astype(np.float32),
}


@pytest.mark.parametrize("name", sorted(CONTOURS))
def test_contour_matches_opencv(name: str) -> None:
    c = CONTOURS[name]
    m = shape_moments(c)
    ref = cv2.moments(c)
    assert m.area == pytest.approx(ref["m00"], rel=1e-9)
    assert m.area == pytest.approx(cv2.contourArea(c), rel=1e-9)
    assert m.centroid == pytest.approx((ref["m10"] / ref["m00"], ref["m01"] / ref["m00"]))
    assert_hu_close(m.hu, cv2.HuMoments(ref))


MASKS = {
    "blob": filled(BLOB + 200),
    "h_rotated": filled(rotate(H_OUTLINE * 30, -61) + np.array([400, 300])),
    "disk": cv2.circle(np.zeros((300, 300), np.uint8), (140, 160), 90, 1, -1),
    "two_pieces": filled(np.concatenate([BLOB, BLOB[::-1] + np.array([300, 200])])),
    "bool": filled(BLOB * 2 + 100) > 0,
}


@pytest.mark.parametrize("name", sorted(MASKS))
def test_mask_matches_opencv(name: str) -> None:
    mask = MASKS[name]
    m = shape_moments(mask)
    ref = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    assert m.area == ref["m00"] == np.count_nonzero(mask)
    assert m.centroid == pytest.approx((ref["m10"] / ref["m00"], ref["m01"] / ref["m00"]))
    assert_hu_close(m.hu, cv2.HuMoments(ref))


def test_normalisation_is_mu_over_m00_power_not_eq_4_13() -> None:
    # hu1 = eta20 + eta02 is 1/6 for any square when eta = mu / mu00^2; eq. 4.13's
    # mu_pq / mu_pq^2 would give 1/mu20 + 1/mu02, which changes with the size.
    for side in (4.0, 10.0, 300.0):
        sq = np.array([[0, 0], [side, 0], [side, side], [0, side]])
        assert shape_moments(sq).hu[0] == pytest.approx(1 / 6, rel=1e-12)


def test_contour_direction_and_layout_do_not_matter() -> None:
    a = shape_moments(BLOB)
    b = shape_moments(BLOB[::-1])
    c = shape_moments(BLOB.reshape(-1, 1, 2))
    for other in (b, c):
        assert other.area == pytest.approx(a.area) and other.area > 0
        np.testing.assert_allclose(other.hu, a.hu, rtol=1e-12)
        assert other.orientation_deg == pytest.approx(a.orientation_deg)


def test_translation_rotation_scale_invariance_of_polygons() -> None:
    base = shape_moments(BLOB)
    for shift in ((0.0, 0.0), (1234.5, -987.25)):
        for deg in (0.0, 17.0, 90.0, 163.0, 271.0):
            for scale in (0.25, 1.0, 7.0):
                m = shape_moments(rotate(BLOB, deg) * scale + shift)
                np.testing.assert_allclose(m.hu, base.hu, rtol=1e-8)
                assert m.area == pytest.approx(base.area * scale * scale, rel=1e-9)


def test_invariance_of_rasterised_masks_within_tolerance() -> None:
    # Pixels are not exactly rotation- or scale-invariant; the low invariants hold well.
    base = shape_moments(filled(BLOB * 2 + 150))
    for deg, scale in ((30.0, 2.0), (115.0, 1.5), (250.0, 3.0)):
        centred = (BLOB - BLOB.mean(0)) * scale
        m = shape_moments(filled(rotate(centred, deg) + np.array([500, 450]), size=(900, 1000)))
        np.testing.assert_allclose(m.hu[:2], base.hu[:2], rtol=0.02)
        assert hu_distance(m.hu, base.hu, count=4) < 0.1


def test_mirroring_flips_only_the_sign_of_hu7() -> None:
    a = shape_moments(BLOB)
    mirrored = shape_moments(BLOB * [-1, 1] + np.array([500, 0]))
    assert abs(a.hu[6]) > 1e-9  # not trivially zero
    assert mirrored.hu[6] == pytest.approx(-a.hu[6], rel=1e-9)
    np.testing.assert_allclose(mirrored.hu[:6], a.hu[:6], rtol=1e-9)
    # On pixels too.
    mask = filled(BLOB * 2 + 100)
    m1, m2 = shape_moments(mask), shape_moments(mask[:, ::-1].copy())
    assert m2.hu[6] == pytest.approx(-m1.hu[6], rel=1e-6)


@pytest.mark.parametrize("deg", [0.0, 10.0, 30.0, 45.0, 60.0, 89.0, 90.0, -20.0, -45.0, -89.0])
def test_orientation_is_counter_clockwise_on_screen(deg: float) -> None:
    rect = np.array([[-50, -10], [50, -10], [50, 10], [-50, 10]], float)
    # Counter-clockwise on screen is clockwise in image axes (y down): rotate by -deg.
    poly = rotate(rect, -deg) + np.array([400, 300])
    expected = deg if deg > -90 else deg + 180
    assert shape_moments(poly).orientation_deg == pytest.approx(expected, abs=1e-9)
    assert shape_moments(filled(poly)).orientation_deg == pytest.approx(expected, abs=0.5)


def test_orientation_range_and_example_direction() -> None:
    # A bar running up and to the right on screen: x grows while y (down) shrinks.
    bar = np.array([[100, 200], [110, 210], [210, 110], [200, 100]], float)
    assert shape_moments(bar).orientation_deg == pytest.approx(45.0)
    vertical = np.array([[0, 0], [10, 0], [10, 100], [0, 100]], float)
    assert shape_moments(vertical).orientation_deg == 90.0  # -90 folds to +90
    for deg in np.linspace(-179, 179, 37):
        o = shape_moments(rotate(vertical, deg)).orientation_deg
        assert -90.0 < o <= 90.0


def test_eccentricity() -> None:
    assert shape_moments(ellipse_polygon(100, 100, n=720)).eccentricity < 1e-6
    assert shape_moments(np.array([[0, 0], [7, 0], [7, 7], [0, 7]])).eccentricity == 0.0
    disk = cv2.circle(np.zeros((300, 300), np.uint8), (150, 150), 100, 1, -1)
    assert shape_moments(disk).eccentricity < 0.05
    ten_to_one = math.sqrt(1 - 1 / 100)
    for deg in (0.0, 33.0, 90.0):
        e = shape_moments(rotate(ellipse_polygon(200, 20), deg, about=(400, 300))).eccentricity
        assert e == pytest.approx(ten_to_one, abs=1e-6)
    mask = cv2.ellipse(np.zeros((300, 500), np.uint8), ((250, 150), (400, 40), 20), 1, -1)
    assert shape_moments(mask).eccentricity == pytest.approx(ten_to_one, abs=2e-3)
    line = np.zeros((50, 200), bool)
    line[20, 10:150] = True
    assert shape_moments(line).eccentricity == 1.0
    dot = np.zeros((5, 5), bool)
    dot[2, 2] = True
    single = shape_moments(dot)
    assert single.eccentricity == 0.0 and single.area == 1.0 and single.centroid == (2.0, 2.0)


def test_result_is_frozen_and_serialisable() -> None:
    m = shape_moments(BLOB)
    assert isinstance(m, ShapeMoments) and len(m.hu) == 7
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.area = 3.0  # type: ignore[misc]
    back = json.loads(json.dumps(m.to_dict()))
    assert back["hu"] == list(m.hu) and back["centroid"] == list(m.centroid)


@pytest.mark.parametrize(
    ("bad", "words"),
    [
        (None, "None"),
        (np.zeros((0, 2)), "at least 3"),
        (np.array([[0, 0], [5, 5]]), "at least 3"),
        (np.array([[0, 0], [5, 5], [10, 10], [2, 2]]), "zero area"),
        (np.array([[0, 0], [5, 0], [5, 5], [np.nan, 5]]), "finite"),
        (np.array([[0, 0], [5, 0], [np.inf, 5]]), "finite"),
        (np.zeros((4, 3)), "shape"),
        (np.zeros((4, 2, 2)), "shape"),
        (np.zeros(8), "shape"),
        (np.zeros((10, 10)), "shape"),  # float 2-D that is neither a mask nor points
        (np.zeros((10, 10), bool), "zero area"),
        (np.zeros((10, 10), np.uint8), "zero area"),
        (np.array([["a", "b"], ["c", "d"], ["e", "f"]]), "numbers"),
        (np.array([[0, 0], [5, 0], [5, 5]], complex), "real"),
    ],
)
def test_bad_shapes_raise_naming_the_parameter(bad, words: str) -> None:
    with pytest.raises(ValueError, match="shape") as info:
        shape_moments(bad)
    assert words in str(info.value)


def test_hu_distance_values() -> None:
    a = [0.2, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0]
    b = [0.2, 0.001, 0.0, 0.0, 0.0, 0.0, 0.0]
    assert hu_distance(a, a) == 0.0
    assert hu_distance(a, b) == pytest.approx(1.0, abs=1e-9)  # one decade apart in hu2
    assert hu_distance(b, a) == hu_distance(a, b)
    assert hu_distance(a, b, count=1) == 0.0
    zeros = [0.0] * 7
    assert hu_distance(zeros, zeros) == 0.0
    assert math.isfinite(hu_distance(zeros, a))
    # Values far below eps count as zero; a sign flip of a real value costs a lot.
    tiny = [0.2, 0.01, 1e-20, -1e-22, 0.0, 1e-25, -1e-21]
    assert hu_distance(a, tiny) < 1e-6
    flipped = list(a)
    flipped[6], a_seven = -1e-6, list(a)
    a_seven[6] = 1e-6
    assert hu_distance(a_seven, flipped) == pytest.approx(2 * math.log10(1 + 1e-6 / 1e-12))


def test_hu_distance_tells_the_h_from_look_alikes() -> None:
    h = shape_moments(filled(H_OUTLINE * 40 + np.array([300, 200]))).hu
    h_turned = shape_moments(filled(rotate(H_OUTLINE * 25, 37) + np.array([400, 300]))).hu
    slab = shape_moments(np.array([[0, 0], [3, 0], [3, 5], [0, 5]], float) * 40).hu
    plus = np.array(
        [
            (1, 0),
            (2, 0),
            (2, 1),
            (3, 1),
            (3, 2),
            (2, 2),
            (2, 3),
            (1, 3),
            (1, 2),
            (0, 2),
            (0, 1),
            (1, 1),
        ],
        float,
    )
    cross = shape_moments(plus * 50).hu
    same = hu_distance(h, h_turned, count=2)
    assert same < 0.05
    assert hu_distance(h, slab, count=2) > 10 * same
    assert hu_distance(h, cross, count=2) > 10 * same


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"count": 0}, "count"),
        ({"count": 8}, "count"),
        ({"count": True}, "count"),
        ({"count": 2.0}, "count"),
        ({"eps": 0.0}, "eps"),
        ({"eps": -1.0}, "eps"),
        ({"eps": math.nan}, "eps"),
    ],
)
def test_hu_distance_bad_options(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        hu_distance([0.1] * 7, [0.1] * 7, **kwargs)


@pytest.mark.parametrize(
    ("a", "b", "name"),
    [
        (None, [0.1] * 7, "a"),
        ([0.1] * 6, [0.1] * 7, "a"),
        ([0.1] * 7, [0.1] * 8, "b"),
        ([0.1] * 7, [math.nan] * 7, "b"),
        (["x"] * 7, [0.1] * 7, "a"),
    ],
)
def test_hu_distance_bad_vectors(a, b, name: str) -> None:
    with pytest.raises(ValueError, match=f"^{name} "):
        hu_distance(a, b)
