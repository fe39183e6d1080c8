"""What a frame's search remembers of the marks it turned down."""

import numpy as np

from pipeline.find import REJUDGE_BELOW_PX, Tally


def test_a_mark_turned_down_is_not_judged_again_where_it_lies():
    tally = Tally()
    box = np.array([100.0, 80.0, 160.0, 130.0])
    assert not tally.judged(box)
    tally.turn_down(box)
    assert tally.judged(box + 2.0)  # another threshold's outline of the same mark
    assert not tally.judged(box + np.array([30.0, 0.0, 30.0, 0.0]))  # another mark
    assert not tally.judged(np.array([100.0, 80.0, 200.0, 160.0]))  # a larger one there


def test_a_small_mark_is_judged_in_every_view():
    tally = Tally()
    small = np.array([10.0, 10.0, 10.0 + REJUDGE_BELOW_PX - 1.0, 20.0])
    tally.turn_down(small)
    assert not tally.judged(small)  # a finer view may show what this one could not


def test_a_mark_small_on_a_shrunk_view_is_judged_again_on_a_finer_one():
    # A 1280 x 720 frame is searched shrunk to half first: a mark of 30 frame pixels
    # spans 15 there, too few to judge it for good.
    tally = Tally()
    box = np.array([100.0, 80.0, 130.0, 100.0])
    tally.turn_down(box, scale=0.5)
    assert not tally.judged(box)
    tally.turn_down(box, scale=1.0)  # (refused at the frame's own resolution too)
    assert tally.judged(box)
