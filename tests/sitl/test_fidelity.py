"""Fidelity: the same checks against the project's ArduCopter stand-in and genuine SITL.

Each test runs twice: ``[standin]`` (always) and ``[sitl]`` (marker ``sitl``, skipped
without ../shared/sitl). What the missions rely on must hold on both: the readiness
timeline, defaults, the precision-landing failsafe and announcements, home moving
on arming, GPS loss and landing on ExternalNav. Every vehicle is fresh (a new boot).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from backend.missions.extnav import ARMING_CHECK_ALL_BUT_VISION
from sim.vehicle import ParamStore
from sim.vision_feed import VisionStandIn
from tests.sitl.support import (
    SITL_KIND,
    Flight,
    horizontal,
    running_flight,
    send_landing_target,
)

MAV_CMD_SET_EKF_SOURCE_SET = 42007

KINDS = [
    pytest.param("standin", id="standin"),
    SITL_KIND,
]


@pytest.fixture(params=KINDS)
def vehicle(request: pytest.FixtureRequest) -> Iterator[Flight]:
    with running_flight(request.param) as flight:
        yield flight


def texts_since(f: Flight, index: int) -> list[str]:
    return [t.text for t in f.obs.texts(index)]


def true_alt(f: Flight, ground_d: float) -> float:
    return ground_d - f.true_ned()[2]


# ---------------------------------------------------------------------- readiness


def test_local_position_only_once_the_ekf_uses_gps(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    origin = f.obs.wait_text(r"^EKF3 IMU0 origin set$", 0)
    using = f.obs.wait_text(r"^EKF3 IMU0 is using GPS$", 0)
    assert origin is not None and using is not None
    assert origin.boot_s is not None and using.boot_s is not None
    assert 15 < origin.boot_s < using.boot_s and 35 < using.boot_s < 50
    first = f.obs.first_seen("LOCAL_POSITION_NED")
    assert first is not None and first[0] >= using.rx - 0.5
    assert f.obs.first_seen("GPS_GLOBAL_ORIGIN") is not None


def test_defaults_match_and_there_is_no_rangefinder(vehicle: Flight) -> None:
    f = vehicle
    assert f.link.wait_until(lambda t: t.state.value == "up", f.wall(10))
    for info in ParamStore().all():
        if info.name.startswith(("SYSID_", "BATT_")):
            continue
        got = f.link.get_param(info.name)
        assert got is not None and got == pytest.approx(info.value, rel=1e-5), info.name
    f.wait_sim(3.0)
    assert f.link.latest("DISTANCE_SENSOR") is None and f.link.telemetry.rangefinder_m is None


# ---------------------------------------------------------------------- precision landing


def test_precland_without_its_backend_stops_7s_then_lands_blind(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    # PLND_TYPE is read at boot: set without a reboot there is no backend
    f.set_param("PLND_ENABLED", 1)
    f.set_param("PLND_TYPE", 1)
    ground = f.true_ned()[2]
    f.takeoff(5.0)
    f.wait_sim(2.0)
    mark = f.obs.text_count
    assert f.link.land().ok
    assert f.obs.wait_text(r"^PrecLand: Failsafe Measures$", f.wall(2), since=mark)
    start_alt = true_alt(f, ground)
    f.wait_sim(5.5)
    assert abs(true_alt(f, ground) - start_alt) < 0.3  # held for the failsafe's 7 s
    f.wait_sim(4.0)
    assert true_alt(f, ground) < start_alt - 0.8  # then descends
    assert f.wait_until(lambda t: not t.armed, 40)
    texts = texts_since(f, mark)
    assert "PrecLand: Target Found" not in texts


def test_precland_announces_found_init_and_lost_and_descends(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    f.set_param("PLND_ENABLED", 1)
    f.set_param("PLND_TYPE", 1)
    f.reboot()
    start = f.true_ned()
    pad = (start[0] + 1.0, start[1] + 0.5, start[2])
    f.takeoff(6.0)
    f.wait_sim(2.0)
    mark = f.obs.text_count
    assert f.link.land().ok
    while true_alt(f, start[2]) > 2.5:
        send_landing_target(f, pad)
        f.wait_sim(0.1)
        assert f.link.telemetry.armed
    # the pad leaves the view at 2.5 m: no rangefinder, so no retry: it descends
    assert f.wait_until(lambda t: not t.armed, 40)
    texts = [t for t in texts_since(f, mark) if t.startswith("PrecLand")]
    assert texts == ["PrecLand: Target Found", "PrecLand: Init Complete", "PrecLand: Target Lost"]
    assert horizontal(f.true_ned(), pad) < 0.25


# ---------------------------------------------------------------------- home


def test_home_moves_to_where_it_arms_and_the_local_frame_stays(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    start = f.true_ned()
    f.takeoff(3.0)
    assert f.link.goto_local_ned(start[0] + 4.0, start[1], start[2] - 3.0).ok
    assert f.obs.wait(
        lambda: horizontal(f.true_ned(), (start[0] + 4.0, start[1])) < 0.2, f.wall(20)
    )
    f.land()
    home_before = f.obs.latest("HOME_POSITION")
    f.mode("GUIDED")
    assert f.link.arm().ok
    moved = f.obs.wait_message("HOME_POSITION", f.wall(5), lambda m: abs(m.x - home_before.x) > 3.0)
    assert moved is not None, "home did not move on arming"
    pos = f.link.telemetry.position_ned
    assert pos is not None
    assert math.hypot(moved.x - pos.x, moved.y - pos.y) < 0.5
    assert pos.x == pytest.approx(start[0] + 4.0, abs=0.5)  # the origin did not move
    assert f.link.telemetry.relative_alt_m == pytest.approx(0.0, abs=0.3)
    assert f.link.disarm().ok


# ---------------------------------------------------------------------- GPS loss


def test_gps_loss_without_externalnav_ends_in_the_ekf_failsafe_landing(vehicle: Flight) -> None:
    f = vehicle
    f.wait_ready()
    f.takeoff(5.0)
    f.wait_sim(2.0)
    mark = f.obs.text_count
    f.set_param("SIM_GPS_DISABLE", 1)
    assert f.obs.wait_text(r"^EKF Failsafe: changed to LAND Mode$", f.wall(15), since=mark)
    assert f.wait_until(lambda t: t.mode == "LAND", 2)
    texts = texts_since(f, mark)
    assert texts.index("EKF variance") < texts.index("EKF Failsafe: changed to LAND Mode")
    assert f.wait_until(lambda t: not t.armed, 40)
    # no position after the failsafe: LOCAL_POSITION_NED stopped
    last = f.link.telemetry.local_position_rx_monotonic
    f.wait_sim(2.0)
    assert f.link.telemetry.local_position_rx_monotonic == last


def _externalnav(f: Flight) -> VisionStandIn:
    f.wait_ready()
    for name, value in (
        ("VISO_TYPE", 1),
        ("EK3_SRC2_POSXY", 6),
        ("EK3_SRC2_VELXY", 6),
        ("EK3_SRC2_POSZ", 1),
        ("EK3_SRC2_YAW", 1),
    ):
        f.set_param(name, value)
    f.reboot()
    f.mode("GUIDED")
    refused = f.link.arm()
    assert not refused.ok and "Arm: VisOdom: not healthy" in refused.reasons
    vision = VisionStandIn(f.obs, f.origin()).start()
    # ArduCopter says when its pre-arm checks pass (SYS_STATUS): with vision flowing, on
    # a loaded machine that may take longer than a fixed wait
    if not f.wait_until(lambda t: t.prearm_ok, 30.0):
        vision.close()
        pytest.fail("the pre-arm checks never passed with the vision stand-in's estimates")
    return vision


def test_visodom_arming_check_can_be_left_out(vehicle: Flight) -> None:
    # the station's external-navigation set-up: the pad is not in view on the ground
    f = vehicle
    f.wait_ready()
    f.set_param("VISO_TYPE", 1)
    f.set_param("ARMING_CHECK", ARMING_CHECK_ALL_BUT_VISION)
    f.reboot()
    f.mode("GUIDED")
    arm = f.link.arm()
    assert arm.ok, arm.detail
    assert f.link.disarm().ok


def test_gps_lost_over_the_pad_lands_on_externalnav(vehicle: Flight) -> None:
    f = vehicle
    vision = _externalnav(f)
    try:
        start = f.true_ned()
        pad = (start[0] + 2.0, start[1] + 1.0)
        f.takeoff(5.0)
        assert f.link.goto_local_ned(pad[0], pad[1], start[2] - 5.0).ok
        assert f.obs.wait(lambda: horizontal(f.true_ned(), pad) < 0.15, f.wall(20))
        assert f.obs.command(MAV_CMD_SET_EKF_SOURCE_SET, (2,), f.wall(2)) == 0
        f.wait_sim(2.0)
        mark = f.obs.text_count
        f.set_param("SIM_GPS_DISABLE", 1)
        assert f.wait_until(lambda t: t.gps is not None and t.gps.fix_type <= 1, 5)
        worst = 0.0
        for _ in range(20):
            f.wait_sim(0.5)
            worst = max(worst, horizontal(f.true_ned(), pad))
        assert worst < 0.2
        f.land()
        assert horizontal(f.true_ned(), pad) < 0.1
        assert "EKF variance" not in texts_since(f, mark)
    finally:
        vision.close()


def test_vision_lost_without_gps_ends_in_the_ekf_failsafe(vehicle: Flight) -> None:
    f = vehicle
    vision = _externalnav(f)
    try:
        f.takeoff(5.0)
        assert f.obs.command(MAV_CMD_SET_EKF_SOURCE_SET, (2,), f.wall(2)) == 0
        f.set_param("SIM_GPS_DISABLE", 1)
        f.wait_sim(3.0)
        mark = f.obs.text_count
        vision.on.clear()  # the pad leaves the view
        failsafe = f.obs.wait_text(r"^EKF Failsafe: changed to LAND Mode$", f.wall(16), since=mark)
        assert failsafe is not None
        assert f.wait_until(lambda t: t.mode == "LAND", 2)
        assert f.wait_until(lambda t: not t.armed, 40)
    finally:
        vision.close()
