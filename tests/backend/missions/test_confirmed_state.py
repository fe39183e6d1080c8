"""Missions act on the vehicle's confirmed state, never on a stale armed flag or mode.

ArduCopter's HEARTBEAT (armed flag, mode) comes once a second, and genuine ArduCopter
has no position estimate for ~41 s after a boot and undoes a mode set while booting.
Flown against the stand-in in lockstep, and against a scripted vehicle on a real socket
for what the stand-in does not do (a mode undone, a take-off refused in silence).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import VehicleLink
from backend.missions import HoverConfig, HoverMission, LandConfig
from bench.scenarios.land import PAD_NE, LockstepDriver, RunSpec
from tests.backend.link.conftest import MavPeer

SPEC = RunSpec(0, 5, "guided", 20.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0, 25.0)
HOVER = HoverConfig(
    altitude_m=3.0,
    hold_s=1.0,
    land=LandConfig(strategy="guided", pad_north_m=PAD_NE[0], pad_east_m=PAD_NE[1]),
)


def _step_until(driver: LockstepDriver, mission: HoverMission, state: str, limit_s: float) -> None:
    end = driver.now() + limit_s
    while mission.state != state and not mission.done:
        assert driver.now() < end, f"still {mission.state}: {mission.record.states}"
        driver.advance(0.05)
        mission.step(driver.now())
    assert mission.state == state, mission.record.message


@pytest.mark.slow
def test_hover_started_just_after_a_disarm_waits_for_the_heartbeat_then_arms() -> None:
    driver = LockstepDriver(SPEC)
    try:
        driver.connect()
        link = driver.link
        while not link.telemetry.position_ready:
            driver.advance(0.1)
        assert link.set_mode("GUIDED").ok and link.arm().ok
        while not (link.telemetry.state_confirmed and link.telemetry.armed):
            driver.advance(0.05)
        assert link.disarm().ok
        tel = link.telemetry
        # what the issue saw: the last heartbeat still says armed
        assert tel.armed and not tel.state_confirmed
        mission = HoverMission(link, HOVER, now=driver.now())
        mission.step(driver.now())
        assert mission.state == "start"  # waits for a heartbeat after the disarm
        _step_until(driver, mission, "takeoff", 10.0)
        assert [s["state"] for s in mission.record.states] == ["preflight", "takeoff"]
        _step_until(driver, mission, "transit", 20.0)
        assert driver.server.truth().armed and -driver.server.truth().position_ned[2] > 2.5
    finally:
        driver.close()


@pytest.mark.slow
def test_hover_on_a_fresh_boot_waits_for_the_position_estimate() -> None:
    driver = LockstepDriver(SPEC, ready_after_scale=0.25)  # SITL's timeline, a quarter
    try:
        driver.connect(position=False)
        assert not driver.link.telemetry.position_ready
        mission = HoverMission(driver.link, HOVER, now=driver.now())
        _step_until(driver, mission, "preflight", 5.0)
        _step_until(driver, mission, "takeoff", 30.0)
        assert driver.sim.boot_s > 0.25 * 41  # not before the EKF used the GPS
        assert mission.record.states[0]["reason"] == "waiting for the vehicle's position estimate"
    finally:
        driver.close()


# ---------------------------------------------------------------- a scripted vehicle


@pytest.fixture
def scripted() -> Iterator[tuple[MavPeer, VehicleLink]]:
    peer = MavPeer(heartbeat_hz=10.0)
    link = VehicleLink(f"tcp:127.0.0.1:{peer.port}", command_timeout_s=2.0)
    link.start()
    try:
        assert link.wait_until(lambda t: t.state.value == "up", 10.0)
        peer.send(mavlink2.MAVLink_ekf_status_report_message(831, 0.1, 0.1, 0.1, 0.1, 0.0))
        peer.send(mavlink2.MAVLink_local_position_ned_message(50_000, 0, 0, 0, 0, 0, 0))
        assert link.wait_until(lambda t: t.position_ready and t.state_confirmed, 10.0)
        yield peer, link
    finally:
        link.close()
        peer.close()


def _run(link: VehicleLink, wall_limit_s: float = 20.0) -> HoverMission:
    mission = HoverMission(link, HOVER, now=time.monotonic())
    end = time.monotonic() + wall_limit_s
    while mission.state not in ("takeoff", "failed") and time.monotonic() < end:
        beats = link.telemetry.heartbeats
        link.wait_until(lambda t, n=beats: t.heartbeats > n, 1.0)  # a tick per heartbeat
        mission.step(time.monotonic())
    return mission


def test_a_mode_undone_by_the_vehicle_is_retried_then_reported(scripted: Any) -> None:
    peer, link = scripted

    def undo_mode(p: MavPeer, msg: Any) -> bool:
        if msg.get_type() == "COMMAND_LONG" and msg.command == mavlink2.MAV_CMD_DO_SET_MODE:
            p.ack(msg.command, mavlink2.MAV_RESULT_ACCEPTED)  # accepted, then undone
            return True
        return False

    peer.responder = undo_mode
    mission = _run(link)
    assert mission.outcome == "failed"
    assert mission.record.message == (
        "the vehicle accepted GUIDED 3 times but its heartbeat says STABILIZE "
        "(ArduCopter undoes a mode set while it is booting)"
    )
    commands = [m.command for m in peer.messages("COMMAND_LONG")]
    assert commands.count(mavlink2.MAV_CMD_DO_SET_MODE) == 3
    assert mavlink2.MAV_CMD_COMPONENT_ARM_DISARM not in commands  # never armed in STABILIZE


def test_a_silent_take_off_refusal_says_what_mode_the_vehicle_was_in(scripted: Any) -> None:
    peer, link = scripted

    def vehicle(p: MavPeer, msg: Any) -> bool:
        if msg.get_type() != "COMMAND_LONG":
            return False
        if msg.command == mavlink2.MAV_CMD_COMPONENT_ARM_DISARM:
            p.armed = True
        elif msg.command == mavlink2.MAV_CMD_NAV_TAKEOFF:
            p.custom_mode = 0  # what SITL did: back in STABILIZE, FAILED, no text
            p.send(p.heartbeat_msg())
            p.ack(msg.command, mavlink2.MAV_RESULT_FAILED)
            return True
        elif msg.command == mavlink2.MAV_CMD_DO_SET_MODE:
            p.custom_mode = int(msg.param2)
        p.ack(msg.command, mavlink2.MAV_RESULT_ACCEPTED)
        return True

    peer.responder = vehicle
    mission = _run(link)
    assert mission.outcome == "failed"
    assert mission.record.message == (
        "the vehicle refused to take off: refused by the vehicle (FAILED), without saying "
        "why; its latest heartbeat said STABILIZE, armed (ArduCopter takes off only when "
        "armed in GUIDED)"
    )
