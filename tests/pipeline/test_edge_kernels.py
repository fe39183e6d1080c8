"""The compiled edge loops against plain numpy statements of the same arithmetic."""

import cv2
import numpy as np
import pytest

from pipeline.edge_kernels import GIVE_UP_STEPS, MIN_DROP, STEP_PX, _side_medians, edge_offsets
from pipeline.edgefit import EdgeModel
from pipeline.homography_fit import apply_h, fit_homography, support
from pipeline.render import PadGeometry


def _bilinear(img, x, y):
    h, w = img.shape
    x0, y0 = np.floor(x), np.floor(y)
    ax, ay = x - x0, y - y0
    xi = [np.clip(x0 + d, 0, w - 1).astype(int) for d in (0, 1)]
    yi = [np.clip(y0 + d, 0, h - 1).astype(int) for d in (0, 1)]
    top = img[yi[0], xi[0]] * (1 - ax) + img[yi[0], xi[1]] * ax
    bottom = img[yi[1], xi[0]] * (1 - ax) + img[yi[1], xi[1]] * ax
    return top * (1 - ay) + bottom * ay


def _numpy_offsets(img, proj, normal, search):
    """The strongest bright-to-dark drop across each point (the kernel's contract)."""
    offsets = np.arange(-search, search + 1e-9, STEP_PX)
    pts = proj[:, None, :] + offsets[None, :, None] * normal[:, None, :]
    values = _bilinear(img.astype(np.float64), pts[..., 0], pts[..., 1])
    drops = values[:, :-1] - values[:, 1:]
    k = np.argmax(drops, axis=1)
    rows = np.arange(len(proj))
    inside = (proj[:, 0] > 2) & (proj[:, 1] > 2)
    inside &= (proj[:, 0] < img.shape[1] - 3) & (proj[:, 1] < img.shape[0] - 3)
    ok = (k > 0) & (k < drops.shape[1] - 1) & (drops[rows, k] > MIN_DROP) & inside
    kk = np.clip(k, 1, drops.shape[1] - 2)
    g0, g1, g2 = drops[rows, kk - 1], drops[rows, kk], drops[rows, kk + 1]
    den = g0 - 2 * g1 + g2
    sub = np.where(np.abs(den) > 1e-9, 0.5 * (g0 - g2) / np.where(den == 0, 1, den), 0.0)
    return offsets[0] + (kk + 0.5 + np.clip(sub, -0.5, 0.5)) * STEP_PX, ok


def _noise_and_points(seed, dtype):
    """A smoothed noise image (60 x 80) and 400 points in and around it, each with a
    normal in any direction."""
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0, 255, (60, 80)).astype(dtype), (5, 5), 1.0)
    proj = rng.uniform(-5, 85, (400, 2))
    angle = rng.uniform(0, 2 * np.pi, 400)
    return img, proj, np.column_stack([np.cos(angle), np.sin(angle)])


@pytest.mark.parametrize("search", [1.5, 2.5, 6.0])
def test_edge_offsets_match_the_numpy_statement(search):
    img, proj, normal = _noise_and_points(3, np.float32)
    delta, ok = edge_offsets(img, proj, normal, search, MIN_DROP)
    want_delta, want_ok = _numpy_offsets(img, proj, normal, search)
    np.testing.assert_array_equal(ok, want_ok)
    np.testing.assert_allclose(delta[ok], want_delta[ok], atol=1e-4)
    assert ok.sum() > 50


@pytest.mark.parametrize("search", [1.5, 6.0])
def test_a_uint8_image_reads_as_its_float_copy(search):
    # (the frames' smoothed channel is sampled as it is, uint8; points near and past
    # the border take the clamped reads, the rest the unclamped ones)
    img, proj, normal = _noise_and_points(4, np.uint8)
    got = edge_offsets(img, proj, normal, search, MIN_DROP)
    want = edge_offsets(img.astype(np.float32), proj, normal, search, MIN_DROP)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    want_delta, want_ok = _numpy_offsets(img, proj, normal, search)
    np.testing.assert_array_equal(got[1], want_ok)
    np.testing.assert_allclose(got[0][want_ok], want_delta[want_ok], atol=1e-9)


def test_an_edge_is_found_where_it_is_and_only_with_the_right_polarity():
    img = np.zeros((40, 40), np.float32)
    img[:, :20] = 200.0  # bright left half: the edge lies at x = 19.5
    img = cv2.GaussianBlur(img, (5, 5), 1.0)
    proj = np.array([[17.0, 20.0], [17.0, 20.0]])
    normal = np.array([[1.0, 0.0], [-1.0, 0.0]])  # bright to dark, and the other way
    delta, ok = edge_offsets(img, proj, normal, 3.0, MIN_DROP)
    assert ok.tolist() == [True, False]
    assert abs(17.0 + delta[0] - 19.5) < 0.05
    # A drop under the least that counts is no edge.
    faint = np.clip(img, 0, 2.0)
    assert not edge_offsets(faint, proj, normal, 3.0, MIN_DROP)[1].any()


def _edge_along_a_column(at: float, blur: float) -> np.ndarray:
    """A 40 x 40 picture, bright left of x = ``at``, dark right of it, each pixel the
    share of it that is bright (area-sampled), blurred by ``blur`` px, in uint8."""
    x = np.arange(40)
    row = 40.0 + 160.0 * np.clip(at - (x - 0.5), 0.0, 1.0)
    img = cv2.GaussianBlur(np.repeat(row[None, :], 40, axis=0), (0, 0), blur)
    return np.round(img).astype(np.uint8)


@pytest.mark.parametrize("blur", [0.5, 0.8, 1.2])
def test_the_centroid_places_a_side_along_the_grid_at_any_phase(blur):
    # Across a side along the pixel columns, the parabola's vertex locks to the grid
    # (`edge_offsets`); the drops' centroid does not.
    parabola, centroid = [], []
    for at in np.arange(20.0, 21.0, 0.05):
        img = _edge_along_a_column(at, blur)
        proj = np.array([[at + 0.3, 20.0], [at - 0.4, 12.0]])  # put a little off, as a fit's
        normal = np.array([[1.0, 0.0], [1.0, 0.0]])
        for out, use in ((parabola, False), (centroid, True)):
            delta, ok = edge_offsets(img, proj, normal, 2.5, MIN_DROP, use)
            assert ok.all()
            out.extend(proj[:, 0] + delta - at)
    assert np.abs(parabola).max() > 0.25
    assert np.abs(centroid).max() < 0.16
    assert abs(np.mean(centroid)) < 0.03


def test_the_centroid_of_a_wide_edge_samples_beyond_the_search():
    # A 1.6 px blur spreads the drops over some 4 px, beyond a search of 1.5 px each
    # side: the samples past it are taken too, and the edge lies where it is.
    errors = []
    for at in np.arange(20.0, 21.0, 0.05):
        proj = np.array([[at, 20.0], [at + 0.7, 12.0]])
        delta, ok = edge_offsets(
            _edge_along_a_column(at, 1.6), proj, np.array([[1.0, 0.0]] * 2), 1.5, MIN_DROP, True
        )
        errors.extend((proj[:, 0] + delta - at)[ok])
    assert len(errors) > 30
    assert np.abs(errors).max() < 0.05


def _drawn(polygon_m: np.ndarray, H: np.ndarray) -> np.ndarray:
    """A 640 x 480 picture of the polygon put by ``H``, bright on dark, drawn 8x finer
    and averaged (its edges anti-aliased as a camera's are)."""
    big = np.zeros((480 * 8, 640 * 8), np.float32)
    pts = np.round(((apply_h(H, polygon_m) + 0.5) * 8 - 0.5) * 16).astype(np.int32)
    cv2.fillPoly(big, [pts], 180, shift=4)
    return cv2.resize(big, (640, 480), interpolation=cv2.INTER_AREA) + 30.0


def test_fit_homography_recovers_a_drawn_h_and_support_finds_its_sides():
    h = PadGeometry().h_corners_m
    true = np.array([[700.0, 80, 330], [-60, -650, 250], [0.05, 0.08, 1]])
    img = _drawn(h, true)
    model = EdgeModel.from_polygons([(h, True)])
    start = true.copy()
    start[0, 2] += 2.0
    start[1, 0] *= 0.97
    fit = fit_homography(img, model, start)
    assert fit is not None and fit.support > 0.95
    assert np.abs(apply_h(fit.H, h) - apply_h(true, h)).max() < 0.2
    assert support(img, model, true) > 0.95
    moved = true.copy()
    moved[0, 2] += 3.0
    assert support(img, model, moved) < 0.6
    # A model put nowhere finite is not found at all.
    assert support(img, model, np.diag([1.0, 1.0, 0.0])) == 0.0


def _circle(r: float, n: int = 64) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([r * np.cos(t), r * np.sin(t)])


def test_a_rim_beside_a_thin_ring_is_fitted_only_where_the_ring_is_or_far_from_it():
    # A disc's rim 5 cm out from a ring 1.5 cm wide: alone, the rim's edge is pushed
    # out by the ring's blur; it is fitted where the ring is, or 4 times as far as
    # it would need alone.
    polys = [(_circle(0.55), False), (_circle(0.50), True), (_circle(0.485), False)]
    plain = EdgeModel.from_polygons(polys)
    rim = EdgeModel.from_polygons(polys, rims={0: 0.0})
    on_rim = rim.polygon == 0
    assert np.allclose(plain.clearance_m[on_rim], 0.05, rtol=0.05)
    assert np.allclose(rim.clearance_m[on_rim], 0.015, rtol=0.05)  # the ring's own
    assert np.array_equal(rim.clearance_m[~on_rim], plain.clearance_m[~on_rim])
    # a ring that touches a square board's rim at its sides' middles only: no matter
    square = np.array([[-0.55, 0.55], [0.55, 0.55], [0.55, -0.55], [-0.55, -0.55]])
    polys = [(square, False), (_circle(0.54), True), (_circle(0.525), False)]
    plain = EdgeModel.from_polygons(polys)
    rim = EdgeModel.from_polygons(polys, rims={0: 0.0})
    assert np.array_equal(rim.clearance_m, plain.clearance_m)
    # a rim with a hem 2 cm wide beyond it: fitted where the hem is 4 times as wide as
    # a side needs
    hemmed = EdgeModel.from_polygons(polys, rims={0: 0.02})
    assert np.allclose(hemmed.clearance_m[plain.polygon == 0], 0.005)
    assert np.array_equal(
        hemmed.clearance_m[plain.polygon > 0], plain.clearance_m[plain.polygon > 0]
    )


@pytest.mark.parametrize(("n", "sides"), [(1, 1), (9, 3), (600, 200), (50, 50)])
def test_each_residual_is_given_its_own_sides_median(n: int, sides: int) -> None:
    rng = np.random.default_rng(n)
    side = rng.integers(0, sides, n)
    r = rng.normal(size=n)
    want = np.empty(n)
    for j in np.unique(side):
        want[side == j] = np.median(r[side == j])
    assert np.array_equal(_side_medians(r, side), want)


def test_a_fit_that_finds_few_of_its_sides_gives_up_after_a_few_steps():
    h = PadGeometry().h_corners_m
    model = EdgeModel.from_polygons([(h, True)])
    start = np.array([[700.0, 80, 330], [-60, -650, 250], [0.05, 0.08, 1]])
    # Blurred noise: edges everywhere, none of them an H's.
    rng = np.random.default_rng(1)
    noise = cv2.GaussianBlur(rng.uniform(0, 255, (480, 640)).astype(np.float32), (0, 0), 1.5)
    full = fit_homography(noise, model, start)
    short = fit_homography(noise, model, start, iterations=GIVE_UP_STEPS)
    assert full is not None and short is not None and full.support < 0.3
    assert not np.allclose(full.H, short.H)  # (the later steps would change it)
    gave_up = fit_homography(noise, model, start, give_up_below=0.3)
    np.testing.assert_array_equal(gave_up.H, short.H)
    # A fit finding its H goes on to the end.
    img = _drawn(h, start)
    moved = start.copy()
    moved[0, 2] += 2.0
    kept = fit_homography(img, model, moved, give_up_below=0.3)
    np.testing.assert_array_equal(kept.H, fit_homography(img, model, moved).H)
