import numpy as np
import pytest

from pipeline.render import PadGeometry
from pipeline.shape_match import ShapeMatcher

H = PadGeometry().h_corners_m


def _view(poly, A):
    return poly @ A[:, :2].T + A[:, 2]


def _dense(poly, n=20):
    """The polygon's outline with n points per side, like a traced contour."""
    t = np.linspace(0.0, 1.0, n, endpoint=False)[:, None]
    return np.vstack(
        [a + t * (b - a) for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True)]
    )


@pytest.mark.parametrize(
    "A",
    [
        np.array([[900.0, 0.0, 320.0], [0.0, -900.0, 240.0]]),  # straight down
        np.array([[600.0, 500.0, 100.0], [400.0, -700.0, 300.0]]),  # turned and sheared
        np.array([[-300.0, 80.0, 50.0], [-60.0, 250.0, 60.0]]),  # small, turned round
    ],
)
def test_any_affine_view_of_the_h_matches_and_maps_its_corners(A):
    hit = ShapeMatcher.from_polygon(H).match(_view(_dense(H), A))
    assert hit is not None and hit.iou > 0.85
    # The H looks the same after a half turn: either numbering is a match.
    err = min(np.abs(_view(np.roll(H, k, axis=0), hit.affine) - _view(H, A)).max() for k in (0, 6))
    span = np.ptp(_view(H, A), axis=0).max()
    assert err < 0.04 * span


def test_shapes_that_are_not_the_h_overlap_less():
    matcher = ShapeMatcher.from_polygon(H)
    A = np.array([[900.0, 0.0, 320.0], [0.0, -900.0, 240.0]])
    square = np.array([[-0.1, 0.1], [0.1, 0.1], [0.1, -0.1], [-0.1, -0.1]])
    a, b = 0.03, 0.12
    plus = np.array(
        [[-a, b], [a, b], [a, a], [b, a], [b, -a], [a, -a],
         [a, -b], [-a, -b], [-a, -a], [-b, -a], [-b, a], [-a, a]]
    )  # fmt: skip
    h_iou = matcher.match(_view(_dense(H), A)).iou
    for other in (square, plus):
        assert matcher.match(_view(_dense(other), A)).iou < h_iou - 0.1
    assert matcher.match(_view(_dense(square), A), min_iou=0.9) is None


def test_degenerate_contours():
    matcher = ShapeMatcher.from_polygon(H)
    assert matcher.match(np.zeros((3, 2))) is None
    assert matcher.match(np.column_stack([np.arange(20.0), np.zeros(20)])) is None


def test_rasters_of_many_regions_at_once_are_each_regions_own():
    from pipeline.shape_match import _polygon_moments, _raster, _whitened_rasters

    rng = np.random.default_rng(5)
    polygons = [
        _view(_dense(H), np.array([[900.0, 0.0, 320.0], [0.0, -900.0, 240.0]])),
        _view(_dense(H), np.array([[600.0, 500.0, 100.0], [400.0, -700.0, 300.0]])),
        _star(rng),
        np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [30.0, 0.0], [5.0, 0.0], [1.0, 0.0]]),
    ]
    centres, whiten, cells = _whitened_rasters(polygons)
    assert len(cells) == 3 and not np.isfinite(whiten[3]).any()  # the flat one is degenerate
    # A self-crossing scribble's "covariance" need not be one: not rasterised either.
    scribble = rng.uniform(0, 50, (30, 2))
    _, w, scribbled = _whitened_rasters([scribble])
    assert len(scribbled) == int(np.isfinite(w).all())
    # ... nor does any other raise (its divisions may meet a zero): 300 of them at once.
    scribbles = [rng.uniform(0, 50, (int(rng.integers(3, 12)), 2)) for _ in range(300)]
    _, w, scribbled = _whitened_rasters(scribbles)
    assert len(scribbled) == int(np.isfinite(w).all(axis=(1, 2)).sum())
    for k, poly in enumerate(polygons[:3]):
        mean, cov = _polygon_moments(poly)
        np.testing.assert_allclose(centres[k], mean, atol=1e-3)  # (cv2.moments: float32)
        w = whiten[k]
        np.testing.assert_allclose(w @ cov @ w.T, np.eye(2), atol=1e-4)  # it whitens
        np.testing.assert_array_equal(cells[k], _raster((poly - mean) @ w.T))


def _star(rng):
    """A simple polygon of 40 points at random radii around a centre."""
    a = np.sort(rng.uniform(0, 2 * np.pi, 40))
    r = rng.uniform(10, 30, 40)
    return np.column_stack([50 + r * np.cos(a), 50 + r * np.sin(a)])


def test_the_bit_overlaps_are_the_float_products():
    # (the overlaps were a float32 matrix product of the cells: the same numbers)
    from pipeline.shape_match import _bits, _overlaps

    rng = np.random.default_rng(5)
    turns = (rng.random((120, 1600)) < 0.3).astype(np.uint8)
    regions = (rng.random((17, 1600)) < rng.uniform(0, 0.6, (17, 1))).astype(np.uint8)
    regions[3] = 0  # an empty region against an empty turn: no union
    turns[7] = 0
    areas = turns.sum(axis=1, dtype=np.int64)
    got = _overlaps(_bits(turns), areas, _bits(regions))
    t, r = turns.astype(np.float32), regions.T.astype(np.float32)
    inter = t @ r
    want = inter / np.maximum(t.sum(axis=1)[:, None] + r.sum(axis=0)[None, :] - inter, 1e-9)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, want)
