import numpy as np

from pipeline.draw import CYAN, annotate
from pipeline.result import FrameResult


def _result(corner):
    return FrameResult(True, np.array([corner]), (0.0,) * 7, 0.0, 0.0, None, {})


def test_marks_grow_with_the_picture():
    small = annotate(np.zeros((480, 640, 3), np.uint8), _result((320, 240)), None)
    big = annotate(np.zeros((2160, 3840, 3), np.uint8), _result((1920, 1080)), None)
    dots = [int(np.all(img == CYAN, axis=2).sum()) for img in (small, big)]
    # A 4K frame's marks are about six times wider: some thirty times the area.
    assert dots[1] > 20 * dots[0] > 0
