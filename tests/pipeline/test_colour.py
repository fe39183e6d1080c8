import numpy as np
import pytest

from pipeline.colour import GRAY, Projection, contrast, learn_projection
from pipeline.preprocess import to_channel


def _pad(h_bgr, board_bgr, ground_bgr=(120, 120, 120)):
    img = np.full((60, 60, 3), ground_bgr, np.uint8)
    img[5:55, 5:55] = board_bgr
    img[15:45, 15:22] = img[15:45, 38:45] = img[27:33, 22:38] = h_bgr
    h = np.zeros((60, 60), bool)
    h[16:44, 16:21] = True
    board = np.zeros((60, 60), bool)
    board[6:14, 6:54] = True
    return img, h, board


@pytest.mark.parametrize(
    ("h_bgr", "board_bgr"),
    [
        ((236, 238, 238), (28, 27, 30)),  # the seed's white H on black
        ((35, 30, 30), (225, 228, 230)),  # dark H on paper
        ((240, 235, 235), (30, 110, 235)),  # white H on an orange disc
        ((40, 40, 200), (20, 20, 20)),  # red H on black
    ],
)
def test_the_h_is_bright_and_its_board_dark_on_the_learned_channel(h_bgr, board_bgr):
    img, h, board = _pad(h_bgr, board_bgr)
    p = learn_projection(img, h, board)
    chan = p.apply(img)
    assert chan.dtype == np.uint8 and chan.shape == img.shape[:2]
    assert contrast(chan, h, board) > 60


def test_polarity_follows_the_h_against_its_board_in_gray():
    img, h, board = _pad((35, 30, 30), (225, 228, 230))
    assert learn_projection(img, h, board).polarity == "dark"
    img, h, board = _pad((236, 238, 238), (28, 27, 30))
    assert learn_projection(img, h, board).polarity == "bright"


def test_no_exposure_clips_the_channel():
    p = Projection((0.7, 0.2, -0.1))
    cube = np.array([[[b, g, r] for b in (0, 255) for g in (0, 255) for r in (0, 255)]], np.uint8)
    out = p.apply(cube).astype(int)
    assert out.min() == 0 and out.max() == 255


def test_a_gray_camera_gets_the_luma_contrast_with_the_references_polarity():
    img, h, board = _pad((240, 235, 235), (30, 110, 235))
    p = learn_projection(img, h, board)
    gray = np.repeat(np.mean(img, axis=2, keepdims=True).astype(np.uint8), 3, axis=2)
    chan = to_channel(gray, p)  # no colour: the projection falls back to luma
    assert contrast(chan, h, board) > 30


def test_identical_colours_are_refused():
    img = np.full((20, 20, 3), 100, np.uint8)
    mask = np.zeros((20, 20), bool)
    mask[:10] = True
    with pytest.raises(ValueError, match="same mean colour"):
        learn_projection(img, mask, ~mask)


def test_gray_is_luma():
    img = np.array([[[50, 100, 200]]], np.uint8)
    assert int(GRAY.apply(img)[0, 0]) == round(0.114 * 50 + 0.587 * 100 + 0.299 * 200)
