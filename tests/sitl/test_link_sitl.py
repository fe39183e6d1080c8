"""The project's VehicleLink against genuine ArduCopter 4.5.6 SITL."""

from __future__ import annotations

import math
import time

import pytest

from backend.link import VehicleLink
from tests.sitl.support import Flight, horizontal, requires_sitl, send_landing_target

pytestmark = [pytest.mark.sitl, requires_sitl]


def test_readiness_from_a_fresh_boot_with_refusals_verbatim(fresh_flight: Flight) -> None:
    f = fresh_flight
    link, obs = f.link, f.obs
    assert link.wait_until(lambda t: t.state.value == "up", f.wall(10))
    assert link.vehicle == (1, 1)
    refusals: list[tuple[float, tuple[str, ...], bool, float]] = []
    while True:
        # A mode set in the first second after boot is acknowledged, even reported by
        # the heartbeat, and then undone when the firmware finishes booting
        # ("ArduPilot Ready"): make sure of GUIDED before every attempt.
        if link.telemetry.mode != "GUIDED":
            f.mode("GUIDED")
        result = link.arm()
        # the vehicle's clock as the link knows it (the observer may lag under load)
        boot = (link.telemetry.attitude_time_boot_ms or 0) / 1000.0
        if result.ok:
            break
        assert result.result_name == "FAILED", result.detail
        assert result.reasons, result.detail
        had_position = link.telemetry.position_ned is not None
        refusals.append((boot, result.reasons, had_position, time.monotonic()))
        assert boot < 120, f"still refused after 120 s: {result.reasons}"
        f.wait_sim(1.0)
    armed_at = obs.boot_s or 0.0
    assert link.telemetry.mode == "GUIDED"
    using_gps = obs.wait_text(r"^EKF3 IMU0 is using GPS$", 0)
    assert using_gps is not None and using_gps.boot_s is not None
    # the firmware's own timeline: GPS in use ~41 s after boot, arming in GUIDED only then
    assert 30 < using_gps.boot_s < 60
    assert using_gps.boot_s <= armed_at
    assert any("Arm: Need Position Estimate" in reasons for _, reasons, _, _ in refusals)
    # no LOCAL_POSITION_NED while the EKF has no position: the link's position stays None
    assert all(not had for boot, _, had, _ in refusals if boot < using_gps.boot_s - 1.0)
    first_position = obs.first_seen("LOCAL_POSITION_NED")
    assert first_position is not None and first_position[0] >= using_gps.rx - 0.5
    # every reason, word for word, is a STATUSTEXT the vehicle sent (to the observer too,
    # once ArduPilot had heard from it: it sends texts only on ports that spoke to it)
    sent = {t.text for t in obs.texts()}
    assert obs.active_since is not None
    checked = [r for r in refusals if r[3] > obs.active_since + 0.5]
    assert checked
    for _, reasons, _, _ in checked:
        for reason in reasons:
            assert reason.startswith(("Arm: ", "PreArm: ")) and reason in sent, reason
    assert link.disarm().ok


def test_parameters_read_write_and_the_vehicles_own_rounding(flight: Flight) -> None:
    link = flight.link
    assert link.get_param("WPNAV_SPEED") == pytest.approx(1000.0)  # 4.5's default
    flight.set_param("WPNAV_SPEED", 750.0)
    assert link.get_param("WPNAV_SPEED") == pytest.approx(750.0)
    # DISARM_DELAY is an int8 on the vehicle: it keeps 7 and the link says so
    flight.set_param("DISARM_DELAY", 10)
    result = link.set_param("DISARM_DELAY", 7.4)
    assert not result.ok and result.result_name == "MISMATCH"
    assert "DISARM_DELAY = 7" in result.detail
    assert link.get_param("NO_SUCH_PARAM", timeout=1.0) is None
    unknown = link.set_param("NO_SUCH_PARAM", 1.0)
    assert not unknown.ok and unknown.result_name == "TIMEOUT"


def test_guided_arm_take_off_and_land_against_the_true_state(flight: Flight) -> None:
    link = flight.link
    start = flight.true_ned()
    flight.takeoff(4.0)
    flight.wait_sim(3.0)
    truth = flight.true_ned()
    tel = link.telemetry
    assert tel.armed and tel.mode == "GUIDED"
    assert -(truth[2] - start[2]) == pytest.approx(4.0, abs=0.4)
    assert tel.relative_alt_m == pytest.approx(-(truth[2] - start[2]), abs=0.4)
    assert tel.position_ned is not None
    assert horizontal((tel.position_ned.x, tel.position_ned.y), truth) < 0.3
    flight.land()
    texts = [t.text for t in flight.obs.texts()]
    assert any(t.startswith("SIM Hit ground at ") for t in texts)
    assert horizontal(flight.true_ned(), start) < 0.3


def test_the_true_state_streams_through_the_link_too(flight: Flight) -> None:
    # SIM_STATE is the simulator's own state; any ground station can ask for it
    with VehicleLink(
        flight.sitl.serial1_url, stream_rates_hz={"SIM_STATE": 10.0, "ATTITUDE": 10.0}
    ) as second:
        assert second.wait_until(lambda t: t.state.value == "up", flight.wall(10))
        assert flight.obs.wait(lambda: second.latest("SIM_STATE") is not None, flight.wall(5))
        msg = second.latest("SIM_STATE")
        truth = flight.obs.truth(flight.origin())
        assert truth is not None
        assert msg.lat_int * 1e-7 == pytest.approx(truth.lat_deg, abs=1e-6)
        assert math.isfinite(msg.alt) and abs(msg.alt - truth.alt_m) < 0.5


def test_sim_gps_disable_takes_the_fix_away_and_back(flight: Flight) -> None:
    link = flight.link
    assert link.telemetry.gps is not None and link.telemetry.gps.fix_type >= 3
    flight.set_param("SIM_GPS_DISABLE", 1)
    assert flight.wait_until(lambda t: t.gps is not None and t.gps.fix_type <= 1, 5)
    assert link.set_param("SIM_GPS_DISABLE", 0).ok
    assert flight.wait_until(lambda t: t.gps is not None and t.gps.fix_type >= 3, 20)


def test_reboot_drops_tcp_the_link_comes_back_and_plnd_type_takes_effect(flight: Flight) -> None:
    link, obs = flight.link, flight.obs
    flight.set_param("PLND_ENABLED", 1)
    flight.set_param("PLND_TYPE", 1)
    reconnects = link.telemetry.reconnects
    flight.reboot()
    assert link.telemetry.reconnects == reconnects + 1
    assert link.get_param("PLND_TYPE") == 1.0
    # the backend exists now: LANDING_TARGETs are taken ("PrecLand: Target Found")
    start = flight.true_ned()
    pad = (start[0] + 1.0, start[1] - 0.5)
    flight.takeoff(5.0)
    texts_from = obs.text_count
    assert link.land().ok
    while link.telemetry.armed:
        if -(flight.true_ned()[2] - start[2]) > 0.4:
            send_landing_target(flight, (pad[0], pad[1], start[2]))
        flight.wait_sim(0.1)
        assert (obs.boot_s or 0) < 400
    texts = [t.text for t in obs.texts(texts_from)]
    assert "PrecLand: Target Found" in texts and "PrecLand: Init Complete" in texts
    assert "PrecLand: Failsafe Measures" not in texts
    assert horizontal(flight.true_ned(), pad) < 0.1
