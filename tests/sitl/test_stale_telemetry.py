"""Stale telemetry, against the stand-in and genuine SITL alike: after a reboot the link
forgets everything the vehicle said before it (the position most of all, which genuine
ArduCopter only sends again ~41 s into the new boot), and a position the vehicle stopped
sending (the EKF failsafe after a GPS loss) is dropped, not shown frozen."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.sitl.support import SITL_KIND, Flight, running_flight

KINDS = [
    pytest.param("standin", id="standin", marks=pytest.mark.slow),
    SITL_KIND,
]


@pytest.fixture(params=KINDS)
def vehicle(request: pytest.FixtureRequest) -> Iterator[Flight]:
    with running_flight(request.param) as flight:
        yield flight


def test_a_reboot_resets_what_the_vehicle_said(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    assert f.wait_until(lambda t: t.position_ready, 5)
    before = f.link.telemetry
    assert before.boots == 0
    assert f.link.reboot().ok
    assert f.wait_until(lambda t: t.boots == 1, 20), "the link did not see the reboot"
    after = f.link.telemetry
    # nothing from before the reboot (the new boot's first EKF report may be in already)
    assert after.position_ned is None and not after.position_ready
    assert after.ekf is None or not after.ekf.pos_horiz_ok
    assert after.vehicle_time_boot_ms is not None
    assert after.vehicle_time_boot_ms < before.vehicle_time_boot_ms
    f.wait_ready()  # the position comes back only with the new boot's readiness
    assert f.wait_until(lambda t: t.position_ready, 5) and f.link.telemetry.boots == 1


def test_a_position_the_vehicle_stopped_sending_is_dropped(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    f.takeoff(5.0)
    f.set_param("SIM_GPS_DISABLE", 1)
    assert f.obs.wait_text(r"^EKF Failsafe: changed to LAND Mode$", f.wall(15))
    # genuine ArduCopter stops LOCAL_POSITION_NED at "EKF3 IMU0 stopped aiding", ~7 s on
    assert f.wait_until(lambda t: t.position_stale, 30)
    tel = f.link.telemetry
    assert tel.position_ned is None and tel.velocity_ned is None and not tel.position_ready
    assert tel.attitude is not None  # the rest keeps coming
