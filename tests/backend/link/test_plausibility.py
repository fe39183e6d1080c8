"""Well-formed MAVLink with impossible values: dropped, counted, never shown as real."""

from __future__ import annotations

import math
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import LinkState

m = mavlink2


def attitude(boot_ms: int, roll: float = 0.1, pitch: float = -0.05, yaw: float = 1.0) -> Any:
    return m.MAVLink_attitude_message(boot_ms, roll, pitch, yaw, 0.01, 0.02, 0.03)


IMPOSSIBLE = [
    attitude(10, roll=-7.26e16),
    attitude(11, pitch=math.nan),
    attitude(12, yaw=math.inf),
    m.MAVLink_attitude_message(13, 0, 0, 0, 1e9, 0, 0),
    m.MAVLink_local_position_ned_message(14, 0, 0, -1e7, 0, 0, 0),
    m.MAVLink_local_position_ned_message(15, math.nan, 0, 0, 0, 0, 0),
    m.MAVLink_local_position_ned_message(16, 0, 0, -3, 0, 0, 9000),
    m.MAVLink_global_position_int_message(17, 95 * 10**7, 0, 500_000, 2000, 0, 0, 0, 100),
    m.MAVLink_global_position_int_message(18, 0, 0, 2_000_000_000, 2000, 0, 0, 0, 100),
    m.MAVLink_sys_status_message(0, 0, 0, 500, 12000, 100, 101, 0, 0, 0, 0, 0, 0),
    m.MAVLink_gps_raw_int_message(0, 42, 0, 0, 0, 100, 100, 0, 0, 12),
    m.MAVLink_vfr_hud_message(0, 0, 9000, 0, 0, 0),
    m.MAVLink_rangefinder_message(math.nan, 0),
]


def test_impossible_values_are_dropped_and_counted(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert link.wait_until(lambda t: t.state == LinkState.UP, 20.0)
    peer.send(attitude(1))
    assert link.wait_until(lambda t: t.attitude_time_boot_ms == 1, 20.0)
    for msg in IMPOSSIBLE:
        peer.send(msg)
    peer.send(attitude(99))  # a good one after the bad: once it is in, all are handled
    assert link.wait_until(lambda t: t.attitude_time_boot_ms == 99, 20.0)
    tel = link.telemetry
    assert tel.implausible == len(IMPOSSIBLE)
    assert tel.last_implausible is not None and tel.last_implausible.startswith("RANGEFINDER")
    assert tel.attitude is not None and tel.attitude.roll == pytest.approx(0.1)
    assert tel.position_ned is None and tel.global_position is None and tel.gps is None
    assert tel.battery is None and tel.rangefinder_m is None
    assert link.latest("LOCAL_POSITION_NED") is None  # not even cached
    assert tel.handler_errors == 0


def test_an_absurd_mode_in_a_heartbeat_is_not_shown(make_peer, make_link) -> None:
    peer = make_peer(custom_mode=4)
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert link.wait_until(lambda t: t.mode == "GUIDED", 20.0)
    peer.custom_mode = 2090988876
    assert link.wait_until(lambda t: t.implausible >= 3, 20.0)
    assert link.telemetry.mode == "GUIDED" and link.telemetry.mode_number == 4
    assert "mode number 2090988876" in (link.telemetry.last_implausible or "")
