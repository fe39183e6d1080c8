"""Honest precision landing, against genuine SITL.

PLND_ENABLED and PLND_TYPE set without the reboot (by another ground station: one the
station cannot know about; its own writes it refuses to land on until a reboot):
ArduCopter has no precision-landing backend ("PrecLand: Failsafe Measures", a 7 s hold,
then a plain descent where it is). The land mission flies its "plnd" strategy over the
real link with the camera rendered from the simulator's truth, and must report a blind
landing, never a precision-landing success. Then the same with the reboot: ArduCopter
announces the targets and the run is a precision landing. Each vehicle is fresh.

The stand-in's side of both is flown in lockstep (simulated time) in
tests/backend/missions/test_land.py. Its real-time flights here once ran to the mission's
time limit on loaded machines, chasing the pad in align: each fix was turned by the
attitude of when it was processed, not of when its frame was taken, and the renderer
stamped frames late. Both are fixed (`AttitudeHistory`, `ObservedDriver.time_usec`);
the lockstep test of a slow ground station there fails without the first.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.missions import LandConfig, LandMission
from bench.scenarios.land import PAD_NE, RunSpec, camera_config, fly, fly_to_start
from bench.scenarios.observed import ObservedDriver
from tests.sitl.support import SITL_KIND, Flight, assert_landed_blind, running_flight

pytestmark = pytest.mark.slow

KINDS = [SITL_KIND]

SPEC = RunSpec(0, 3, "plnd", 30.0, PAD_NE[0] + 0.8, PAD_NE[1] + 0.4, 4.0, 30.0, 0, 0, 0, 28.0)


@pytest.fixture(params=KINDS)
def vehicle(request: pytest.FixtureRequest) -> Iterator[Flight]:
    with running_flight(request.param) as flight:
        yield flight


def _set_by_another_gcs(f: Flight, name: str, value: float) -> None:
    """PARAM_SET through the observer's port, as another ground station would."""
    t0 = time.monotonic()
    f.obs.send(
        mavlink2.MAVLink_param_set_message(1, 1, name.encode(), value, mavlink2.MAV_PARAM_TYPE_INT8)
    )
    echo = f.obs.wait_message(
        "PARAM_VALUE", f.wall(5), lambda m: m.param_id == name and m.param_value == value, since=t0
    )
    assert echo is not None, f"no echo of {name}"


def _driver(f: Flight) -> ObservedDriver:
    server = getattr(f.sitl, "server", None)

    def set_speedup(value: float) -> None:
        if server is not None:
            server.speedup = value
        else:
            assert f.link.set_param("SIM_SPEEDUP", value).ok

    driver = ObservedDriver(f.link, f.obs, set_speedup=set_speedup, flight_speedup=1.0)
    driver.connect(f.wall(30))
    return driver


def _land(driver: ObservedDriver) -> LandMission:
    driver.begin_landing()
    config = LandConfig(
        strategy="plnd",
        pad_north_m=PAD_NE[0],
        pad_east_m=PAD_NE[1],
        pad_heading_deg=SPEC.pad_heading_deg,
        pad_down_m=driver.ground_ekf_d,
    )
    mission = LandMission(driver.link, config, now=driver.now(), touchdown_truth=driver.touchdown)
    fly(driver, mission, camera_config(SPEC, pad_down_m=driver.ground_true_d))
    return mission


def test_plnd_set_without_the_reboot_is_reported_as_a_blind_landing(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    _set_by_another_gcs(f, "PLND_ENABLED", 1)
    _set_by_another_gcs(f, "PLND_TYPE", 1)  # read at boot: no backend until a reboot
    driver = _driver(f)
    fly_to_start(driver, SPEC, precland=False)
    mission = _land(driver)
    assert_landed_blind(mission)
    stored = mission.record.to_dict()
    assert stored["outcome"] == "landed_blind" and stored["precland"] == "failsafe"


def test_plnd_after_the_reboot_is_a_precision_landing(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    driver = _driver(f)
    fly_to_start(driver, SPEC)  # PLND parameters, reboot, readiness
    mission = _land(driver)
    rec = mission.record
    assert mission.outcome == "landed", (rec.message, rec.states)
    assert rec.precland == "accepted"
    assert rec.precland_texts[:2] == ["PrecLand: Target Found", "PrecLand: Init Complete"]
    assert rec.touchdown is not None and rec.touchdown.source == "truth"
    assert rec.touchdown.error_m < 0.10
