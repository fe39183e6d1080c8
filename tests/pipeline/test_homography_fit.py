import numpy as np

from pipeline.edgefit import normalising
from pipeline.homography_fit import apply_h


def test_points_map_through_a_homography_as_the_matrix_says():
    H = np.array([[2.0, 0.5, 10.0], [-0.3, 1.5, 4.0], [0.01, 0.02, 1.0]])
    pts = np.random.default_rng(0).uniform(-50, 50, (30, 2))
    q = np.column_stack([pts, np.ones(30)]) @ H.T
    assert np.allclose(apply_h(H, pts), q[:, :2] / q[:, 2:])
    # any layout and dtype in, one point as a flat pair, no point at all
    assert np.allclose(apply_h(H.T.copy().T, pts[:, ::-1][:, ::-1]), q[:, :2] / q[:, 2:])
    assert apply_h(H.astype(np.float32), [1, 2]).shape == (1, 2)
    assert apply_h(H, np.zeros((0, 2))).shape == (0, 2)
    frozen = pts.copy()
    frozen.setflags(write=False)
    assert np.array_equal(apply_h(H, frozen), apply_h(H, pts))


def test_a_point_the_homography_sends_to_infinity_is_not_finite_and_no_error():
    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, -1.0]])  # w = x - 1
    out = apply_h(H, np.array([[1.0, 3.0], [2.0, 3.0]]))
    assert not np.all(np.isfinite(out[0])) and np.allclose(out[1], [2.0, 3.0])


def test_the_normalising_map_takes_points_to_unit_size_and_back():
    pts = np.array([[100.0, 40.0], [300.0, 40.0], [300.0, 90.0], [100.0, 90.0]])
    T, T_inv = normalising(pts)
    unit = apply_h(T, pts)
    assert np.allclose(unit.mean(axis=0), 0.0) and np.isclose(np.ptp(unit, axis=0).max(), 1.0)
    assert np.allclose(T @ T_inv, np.eye(3))
