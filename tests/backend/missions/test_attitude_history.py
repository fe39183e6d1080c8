"""A vision fix is turned by the vehicle's attitude when its frame was taken, not by the
latest one: the mission keeps the recent attitudes on the vehicle's clock."""

from __future__ import annotations

import math

import pytest

from backend.link import Telemetry
from backend.link.telemetry import Attitude
from backend.missions.mission import AttitudeHistory


def tel(ms: int | None, roll: float, pitch: float = 0.0, yaw: float = 0.0) -> Telemetry:
    return Telemetry(attitude=Attitude(roll, pitch, yaw, 0.0, 0.0, 0.0), attitude_time_boot_ms=ms)


def test_nothing_known_gives_none():
    h = AttitudeHistory()
    h.add(Telemetry())
    h.add(tel(None, 0.3))  # an attitude without its time cannot be placed
    assert h.at(1000) is None


def test_interpolates_between_the_attitudes_around_the_moment():
    h = AttitudeHistory()
    h.add(tel(1000, 0.0, 0.2, 1.0))
    h.add(tel(1000, 9.0))  # the same message seen again by the next step: ignored
    h.add(tel(1100, 0.1, 0.0, 1.2))
    assert h.at(1050) == pytest.approx((0.05, 0.1, 1.1))
    # Outside what is known: the nearest.
    assert h.at(900) == pytest.approx((0.0, 0.2, 1.0))
    assert h.at(1300) == pytest.approx((0.1, 0.0, 1.2))


def test_yaw_is_interpolated_the_short_way_round():
    h = AttitudeHistory()
    h.add(tel(0, 0.0, 0.0, math.pi - 0.1))
    h.add(tel(100, 0.0, 0.0, -math.pi + 0.1))
    yaw = h.at(50)[2]
    assert abs(math.remainder(yaw - math.pi, 2 * math.pi)) < 1e-9


def test_keeps_only_the_last_seconds_and_starts_again_after_a_reboot():
    h = AttitudeHistory(seconds=1.0)
    for ms in range(0, 5001, 100):
        h.add(tel(ms, ms / 1e4))
    assert h.at(0) == pytest.approx((0.4, 0.0, 0.0))  # 4.0 s: the oldest kept
    h.add(tel(200, -0.5))  # the clock went back by more than the span: a new boot
    assert h.at(5000) == pytest.approx((-0.5, 0.0, 0.0))
