"""The pattern comparison's compiled statistics against the numpy expressions they
replaced: the same masks, the same percentiles, the same medians."""

import cv2
import numpy as np
import pytest

from pipeline.template_kernels import board_and_paint, board_levels, masked_ncc


def _patch(seed: int, h: int = 61, w: int = 83):
    rng = np.random.default_rng(seed)
    pick = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32) * 255, (0, 0), 2.0)
    around = np.zeros((h, w), bool)
    around[3:-4, 5:-2] = True
    near = np.zeros((h, w), bool)
    near[12:-15, 14:-11] = True
    return rng, pick, around, near


@pytest.mark.parametrize("seed", range(6))
def test_masks_are_numpys(seed: int) -> None:
    _, pick, around, near = _patch(seed)
    low, high = np.percentile(pick[around], (5.0, 95.0))
    spread = high - low
    board, paint, off_paint = board_and_paint(pick, around, near, 5.0, 95.0, 0.25)
    assert np.array_equal(board, around & (pick <= low + 0.25 * spread))
    assert np.array_equal(paint, near & (pick >= high - 0.25 * spread))
    assert np.array_equal(off_paint, (~paint).astype(np.uint8))


def test_percentile_of_one_value() -> None:
    pick = np.full((5, 5), 7.0, np.float32)
    one = np.zeros((5, 5), bool)
    one[2, 2] = True
    board, paint, _ = board_and_paint(pick, one, one, 5.0, 95.0, 0.25)
    assert board[2, 2] and paint[2, 2] and board.sum() == 1


@pytest.mark.parametrize("seed", range(6))
def test_ncc_is_numpys(seed: int) -> None:
    rng, pick, _, near = _patch(seed)
    other = (pick * 0.7 + rng.normal(0, 20, pick.shape)).astype(np.float32)
    a, b = other[near] - other[near].mean(), pick[near] - pick[near].mean()
    want = float(np.dot(a, b) / np.sqrt(float(np.dot(a, a)) * float(np.dot(b, b))))
    assert masked_ncc(other, pick, near) == pytest.approx(want, abs=1e-6)


def test_ncc_of_a_flat_patch_is_nan() -> None:
    flat = np.full((9, 9), 3.0, np.float32)
    assert np.isnan(masked_ncc(flat, flat + np.eye(9, dtype=np.float32), np.ones((9, 9), bool)))
    assert np.isnan(masked_ncc(flat, flat, np.zeros((9, 9), bool)))


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("max_pixels", [1024, 50])
def test_board_levels_are_numpys(seed: int, max_pixels: int) -> None:
    rng, pick, around, near = _patch(seed)
    board, paint, off_paint = board_and_paint(pick, around, near, 5.0, 95.0, 0.25)
    h, w = pick.shape
    frame = rng.random((h, w, 3)).astype(np.float32) * 255
    ref = rng.random((h, w, 4)).astype(np.float32) * 255
    lumas = rng.random((h, w, 2)).astype(np.float32) * 300
    _, labels = cv2.distanceTransformWithLabels(
        off_paint, cv2.DIST_L2, 3, labelType=cv2.DIST_LABEL_PIXEL
    )
    got = board_levels(
        frame.reshape(-1, 3), ref.reshape(-1, 4), lumas.reshape(-1, 2),
        board.ravel(), paint.ravel(), labels.ravel(), max_pixels,
    )  # fmt: skip
    # What the comparison computed with numpy before.
    on_board = np.flatnonzero(board)
    some = on_board[:: max(1, -(-len(on_board) // max_pixels))]
    colours = np.median(np.hstack([frame.reshape(-1, 3)[some], ref.reshape(-1, 4)[some, :3]]), 0)
    nearest = np.flatnonzero(paint)[labels[board] - 1]
    b, p = lumas.reshape(-1, 2)[on_board], lumas.reshape(-1, 2)[nearest]
    ratios = np.median(b / np.maximum(np.maximum(b, p), 1.0), axis=0)
    assert np.array_equal(got[0], colours[:3]) and np.array_equal(got[1], colours[3:])
    assert np.array_equal(got[2], np.median(frame.reshape(-1, 3)[np.flatnonzero(paint)], axis=0))
    assert (got[3], got[4]) == (ratios[0], ratios[1])
