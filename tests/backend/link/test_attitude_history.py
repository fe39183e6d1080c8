"""A frame is judged by the vehicle's attitude when it was taken, not by the latest
one: the recent attitudes are kept by time (the mission's by the vehicle's clock, the
link's by this process's, as frames are stamped)."""

from __future__ import annotations

import math

import pytest

from backend.link.attitudes import AttitudeHistory


def test_nothing_known_gives_none():
    h = AttitudeHistory()
    assert h.at(1.0) is None
    h.add(math.nan, (0.3, 0.0, 0.0))  # an attitude without its time cannot be placed
    h.add(1.0, (math.inf, 0.0, 0.0))  # nor one that is no attitude
    assert h.at(1.0) is None


def test_interpolates_between_the_attitudes_around_the_moment():
    h = AttitudeHistory()
    h.add(1.0, (0.0, 0.2, 1.0))
    h.add(1.0, (9.0, 0.0, 0.0))  # the same message seen again: ignored
    h.add(1.1, (0.1, 0.0, 1.2))
    assert h.at(1.05) == pytest.approx((0.05, 0.1, 1.1))
    # Outside what is known: the nearest, unless farther than the gap allowed.
    assert h.at(0.9) == pytest.approx((0.0, 0.2, 1.0))
    assert h.at(1.3) == pytest.approx((0.1, 0.0, 1.2))
    assert h.at(1.3, max_gap=0.25) == pytest.approx((0.1, 0.0, 1.2))
    assert h.at(1.4, max_gap=0.25) is None
    assert h.at(0.7, max_gap=0.25) is None


def test_yaw_is_interpolated_the_short_way_round():
    h = AttitudeHistory()
    h.add(0.0, (0.0, 0.0, math.pi - 0.1))
    h.add(0.1, (0.0, 0.0, -math.pi + 0.1))
    yaw = h.at(0.05)[2]
    assert abs(math.remainder(yaw - math.pi, 2 * math.pi)) < 1e-9


def test_keeps_only_the_last_seconds_and_starts_again_when_the_clock_does():
    h = AttitudeHistory(seconds=1.0)
    for ms in range(0, 5001, 100):
        h.add(ms / 1000, (ms / 1e4, 0.0, 0.0))
    assert h.at(0.0) == pytest.approx((0.4, 0.0, 0.0))  # 4.0 s: the oldest kept
    h.add(0.2, (-0.5, 0.0, 0.0))  # the clock went back by more than the span: a new boot
    assert h.at(5.0) == pytest.approx((-0.5, 0.0, 0.0))


def test_a_span_that_is_no_span_is_refused():
    with pytest.raises(ValueError, match="seconds must be a positive number"):
        AttitudeHistory(seconds=0.0)
