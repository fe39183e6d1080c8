"""The station's missions against genuine ArduCopter SITL: confirmed state, readiness.

Genuine ArduCopter has no position estimate for ~41 s after a boot, undoes a mode set
while it boots, and sends its HEARTBEAT (armed flag, mode) once a second. The hover
mission must wait for the first and confirm each step by the last, on the vehicle's
own clock (the driver paces the mission on it).
"""

from __future__ import annotations

import pytest

from backend.missions import HoverConfig, HoverMission, LandConfig
from bench.scenarios.land import PAD_NE
from bench.scenarios.observed import ObservedDriver
from tests.sitl.support import Flight, requires_sitl

pytestmark = [pytest.mark.sitl, requires_sitl]

HOVER = HoverConfig(
    altitude_m=3.0,
    hold_s=1.0,
    land=LandConfig(strategy="guided", pad_north_m=PAD_NE[0], pad_east_m=PAD_NE[1]),
)


def _fly_until(f: Flight, driver: ObservedDriver, mission: HoverMission, state: str) -> None:
    end = driver.now() + 120.0
    while mission.state != state and not mission.done:
        assert driver.now() < end, mission.record.states
        driver.advance(0.1)
        mission.step(driver.now())
    assert mission.state == state, mission.record.message


def test_hover_from_a_fresh_boot_waits_for_the_position_estimate(fresh_flight: Flight) -> None:
    f = fresh_flight
    driver = ObservedDriver(f.link, f.obs)
    driver.connect(f.wall(30))
    assert not f.link.telemetry.position_ready  # just booted
    mission = HoverMission(f.link, HOVER, now=driver.now())
    _fly_until(f, driver, mission, "transit")
    states = [s["state"] for s in mission.record.states]
    assert states == ["preflight", "takeoff", "transit"]
    using_gps = f.obs.wait_text(r"^EKF3 IMU0 is using GPS$", 0)
    assert using_gps is not None and using_gps.boot_s is not None
    took_off_at = mission.started + mission.record.states[1]["t"]
    assert took_off_at > using_gps.boot_s  # not a moment before the EKF had a position
    assert f.link.telemetry.mode == "GUIDED" and f.link.telemetry.armed


def test_hover_right_after_a_disarm_waits_for_the_heartbeat(flight: Flight) -> None:
    f = flight
    f.mode("GUIDED")
    assert f.link.arm().ok
    assert f.wait_until(lambda t: t.state_confirmed and t.armed, 5)
    assert f.link.disarm().ok
    tel = f.link.telemetry
    assert tel.armed and not tel.state_confirmed  # the last heartbeat is from before
    driver = ObservedDriver(f.link, f.obs)
    driver.connect(f.wall(10))
    mission = HoverMission(f.link, HOVER, now=driver.now())
    _fly_until(f, driver, mission, "transit")
    assert [s["state"] for s in mission.record.states] == ["preflight", "takeoff", "transit"]
    assert f.link.telemetry.armed and -f.true_ned()[2] > 2.0  # flying, truly
