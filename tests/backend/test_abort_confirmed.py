"""ABORT right after the vehicle accepted arming: its last HEARTBEAT still says disarmed
(1 Hz), so the station holds it anyway rather than say "nothing to hold"."""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.framebus import FrameBus
from backend.link import VehicleLink
from backend.missions.manager import MissionManager
from backend.services.abort import AbortService
from backend.services.events import EventLog
from tests.backend.link.conftest import MavPeer


def test_abort_just_after_an_accepted_arm_holds_the_vehicle() -> None:
    peer = MavPeer(heartbeat_hz=0.2)  # one heartbeat every 5 s: the flag is old for long
    link = VehicleLink(
        f"tcp:127.0.0.1:{peer.port}", command_timeout_s=2.0, heartbeat_timeout_s=30.0
    )
    link.start()
    try:
        assert link.wait_until(lambda t: t.state.value == "up" and t.state_confirmed, 10.0)
        arm = link.arm()
        assert arm.ok
        tel = link.telemetry
        assert not tel.armed and not tel.state_confirmed
        events = EventLog(None)
        missions = MissionManager(link, FrameBus("results"), None, events.emit)
        outcome = AbortService(link, missions, events).abort()
        sent = [m.command for m in peer.messages("COMMAND_LONG")]
        assert mavlink2.MAV_CMD_DO_SET_MODE in sent, outcome.detail
        assert "disarmed" not in outcome.detail
    finally:
        link.close()
        peer.close()
