"""The link against a scripted MAVLink peer on a real TCP socket.

Each test makes the peer answer one way (acknowledge, refuse with reasons, stay
silent, drop the connection, send garbage) and checks what the link makes of it.
"""

from __future__ import annotations

import math
import os
import random
import threading
import time
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import LinkEvent, LinkState, VehicleLink, streams


def _up(link: VehicleLink, timeout: float = 5.0) -> bool:
    return link.wait_until(lambda t: t.state == LinkState.UP, timeout)


def _wait_count(peer: Any, mtype: str, n: int, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while len(peer.messages(mtype)) < n:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def _events(link: VehicleLink) -> list[LinkEvent]:
    seen: list[LinkEvent] = []
    link.subscribe(seen.append)
    return seen


def _wait_event(seen: list[LinkEvent], kind: str, timeout: float = 5.0) -> LinkEvent | None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for event in list(seen):
            if event.kind == kind:
                return event
        time.sleep(0.01)
    return None


def test_connects_sends_gcs_heartbeat_and_requests_streams(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    assert link.vehicle == (1, 1)
    hb = peer.wait_for("HEARTBEAT", 20.0)
    assert hb is not None
    assert hb.get_srcSystem() == 255 and hb.type == mavlink2.MAV_TYPE_GCS
    assert hb.autopilot == mavlink2.MAV_AUTOPILOT_INVALID
    interval = peer.wait_for(
        "COMMAND_LONG",
        3.0,
        lambda m: (
            m.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL
            and m.param1 == mavlink2.MAVLINK_MSG_ID_ATTITUDE
        ),
    )
    assert interval is not None and interval.param2 == pytest.approx(50_000)  # 20 Hz
    assert interval.target_system == 1 and interval.target_component == 1
    t = link.telemetry
    assert t.state == LinkState.UP and t.mode == "STABILIZE" and not t.armed
    assert t.heartbeat_age_s is not None and t.heartbeat_age_s >= 0.0
    # heartbeats at 1 Hz: three of them take two seconds at least (a loaded machine can
    # only make them later, never closer)
    assert _wait_count(peer, "HEARTBEAT", 3, timeout=20.0)
    stamps = peer.arrivals("HEARTBEAT")
    assert stamps[2] - stamps[0] >= 1.5


def test_falls_back_to_request_data_stream(peer: Any, make_link) -> None:
    def refuse_intervals(p: Any, msg: Any) -> bool:
        if (
            msg.get_type() == "COMMAND_LONG"
            and msg.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL
        ):
            p.ack(msg.command, mavlink2.MAV_RESULT_UNSUPPORTED)
            return True
        return False

    peer.responder = refuse_intervals
    make_link(f"tcp:127.0.0.1:{peer.port}")
    req = peer.wait_for(
        "REQUEST_DATA_STREAM", 3.0, lambda m: m.req_stream_id == mavlink2.MAV_DATA_STREAM_EXTRA1
    )
    assert req is not None and req.start_stop == 1 and req.req_message_rate == 20


def test_no_fallback_when_telemetry_flows(peer: Any, make_link) -> None:
    stop = threading.Event()

    def stream() -> None:
        while not stop.wait(0.05):
            peer.send(mavlink2.MAVLink_attitude_message(1, 0, 0, 0, 0, 0, 0))

    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    thread = threading.Thread(target=stream)
    thread.start()
    try:
        assert _up(link)
        # the fallback would be sent CHECK_S after the interval requests: wait past that
        # (an absence: waiting longer only makes the check stronger)
        assert link.wait_until(lambda t: t.attitude is not None, 20.0)
        time.sleep(streams.CHECK_S + 0.6)
        assert peer.messages("REQUEST_DATA_STREAM") == []
        assert link.telemetry.msgs_per_s > 0
    finally:
        stop.set()
        thread.join()


def test_telemetry_snapshot_from_messages(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    bit = mavlink2.MAV_SYS_STATUS_PREARM_CHECK
    peer.custom_mode = 4
    peer.armed = True
    for msg in (
        mavlink2.MAVLink_attitude_message(1234, 0.01, 0.02, 1.0, 0.0, 0.0, 0.1),
        mavlink2.MAVLink_local_position_ned_message(1250, 1.0, 2.0, -5.0, 0.5, 0.0, -0.1),
        mavlink2.MAVLink_global_position_int_message(
            1250, -353632620, 1491652370, 589000, 5000, 0, 0, 0, 4500
        ),
        mavlink2.MAVLink_sys_status_message(bit, bit, bit, 0, 12400, 500, 90, 0, 0, 0, 0, 0, 0),
        mavlink2.MAVLink_gps_raw_int_message(0, 3, 0, 0, 0, 90, 65535, 0, 0, 12),
        mavlink2.MAVLink_ekf_status_report_message(63, 0.1, 0.1, 0.1, 0.1, 0.0),
        mavlink2.MAVLink_distance_sensor_message(0, 20, 700, 480, 10, 0, 25, 0),
    ):
        peer.send(msg)
    assert link.wait_until(
        lambda t: t.rangefinder_m is not None and t.armed and t.mode == "GUIDED", 3.0
    )
    t = link.telemetry
    assert t.attitude is not None and t.attitude.yaw == pytest.approx(1.0)
    assert t.attitude_time_boot_ms == 1234 and t.attitude_rx_monotonic <= time.monotonic()
    assert t.position_ned is not None and t.position_ned.z == pytest.approx(-5.0)
    assert t.velocity_ned is not None and t.velocity_ned.x == pytest.approx(0.5)
    assert t.local_position_time_boot_ms == 1250
    assert t.relative_alt_m == pytest.approx(5.0) and t.heading_deg == pytest.approx(45.0)
    assert t.prearm_ok is True and t.battery is not None and t.battery.remaining_pct == 90
    assert t.gps is not None and t.gps.satellites == 12
    assert t.ekf is not None and t.ekf.healthy
    assert t.rangefinder_m == pytest.approx(4.8)
    assert link.latest("attitude").time_boot_ms == 1234
    assert link.latest("NO_SUCH_MESSAGE") is None


def test_refused_arm_returns_the_reasons_verbatim(peer: Any, make_link) -> None:
    def refuse_arm(p: Any, msg: Any) -> bool:
        if msg.get_type() == "COMMAND_LONG" and msg.command == 400 and msg.param1 == 1:
            p.statustext("PreArm: Need Position Estimate")
            p.statustext("EKF3 IMU0 initialised", mavlink2.MAV_SEVERITY_INFO)  # not a reason
            p.statustext("Arm: Throttle too high")
            p.ack(msg.command, mavlink2.MAV_RESULT_FAILED)
            p.statustext("PreArm: Compass not calibrated")  # trails the ACK
            return True
        return False

    peer.responder = refuse_arm
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    seen = _events(link)
    assert _up(link)
    result = link.arm()
    assert not result.ok
    assert result.result == mavlink2.MAV_RESULT_FAILED and result.result_name == "FAILED"
    assert result.reasons == (
        "PreArm: Need Position Estimate",
        "Arm: Throttle too high",
        "PreArm: Compass not calibrated",
    )
    assert "PreArm: Need Position Estimate" in result.detail
    texts = [s.text for s in link.telemetry.statustexts]
    assert "EKF3 IMU0 initialised" in texts
    event = _wait_event(seen, "command")
    assert event is not None and event.data["reasons"] == list(result.reasons)
    assert _wait_event(seen, "statustext") is not None


def _restart(p: Any, msg: Any) -> bool:
    """A peer's answer to a reboot: acknowledged, then silent (no heartbeats)."""
    if msg.get_type() == "COMMAND_LONG" and msg.command == 246:
        p.heartbeats = False
        p.ack(msg.command, mavlink2.MAV_RESULT_ACCEPTED)
        return True
    return False


def test_an_accepted_reboot_takes_the_link_down_at_once(peer: Any, make_link) -> None:
    # The vehicle acknowledges, then goes silent while it restarts: a command sent in
    # that silence is answered at once as link-down, not sent to time out (what the
    # fuzz met: a LAND after a reboot got 504 "no COMMAND_ACK within 3 s").
    peer.responder = _restart
    link = make_link(f"tcp:127.0.0.1:{peer.port}", heartbeat_timeout_s=30.0)
    assert _up(link)
    assert link.reboot().ok
    assert link.telemetry.state == LinkState.LOST
    landing = link.land()
    assert landing.result_name == "LINK_DOWN" and "rebooting" in landing.detail
    assert not [m for m in peer.messages("COMMAND_LONG") if m.command == 21]  # none sent
    peer.heartbeats = True  # booted
    assert _up(link, 20.0)
    assert link.land().ok


def test_a_reboot_asked_a_second_into_a_boot_is_told_by_its_clock(peer: Any, make_link) -> None:
    # The e2e suite, loaded, rebooted the stand-in a second after its last boot: the
    # clock went back from ~1000 ms to a few ms, less than REBOOT_BACKSTEP_MS, and the
    # new boot was never counted (a page waited for it for a minute).
    link = make_link(f"tcp:127.0.0.1:{peer.port}", heartbeat_timeout_s=30.0)
    assert _up(link)
    peer.send(mavlink2.MAVLink_attitude_message(1000, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    assert link.wait_until(lambda t: t.vehicle_time_boot_ms == 1000, 20.0)
    peer.responder = _restart
    assert link.reboot().ok
    # the boot being left answers a last time, a message a few ms out of order: not
    # the new boot
    peer.send(peer.heartbeat_msg())
    peer.send(mavlink2.MAVLink_attitude_message(990, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    assert link.wait_until(lambda t: t.attitude_time_boot_ms == 990, 20.0)
    assert link.telemetry.boots == 0
    peer.heartbeats = True  # booted
    peer.send(mavlink2.MAVLink_attitude_message(30, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    assert link.wait_until(lambda t: t.boots == 1 and t.vehicle_time_boot_ms == 30, 20.0)
    assert _up(link, 20.0)


def test_heartbeats_of_the_boot_being_left_do_not_bring_the_link_back(peer: Any, make_link) -> None:
    # ArduPilot answers the reboot and restarts a moment later: its last heartbeats
    # must not say the link is up again while the vehicle goes away.
    link = make_link(f"tcp:127.0.0.1:{peer.port}", heartbeat_timeout_s=30.0, start=False)
    seen = _events(link)  # before it starts (a loaded machine may connect it at once)
    link.start()
    assert _wait_event(seen, "link_up", 20.0) is not None  # connected
    seen.clear()
    asked = time.monotonic()
    assert link.reboot().ok  # the peer acknowledges and keeps its 10 Hz heartbeats
    back = _wait_event(seen, "link_up", 20.0)
    assert back is not None
    assert time.monotonic() - asked >= 1.0  # held for the hold, at least
    lost = [e for e in seen if e.kind == "link_lost"]
    assert lost and lost[0].data["reason"] == "the vehicle is rebooting"
    assert seen.index(lost[0]) < seen.index(back)


def test_accepted_commands_and_their_wire_format(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    assert link.arm().ok
    result = link.set_mode("guided")
    assert result.ok and result.result_name == "ACCEPTED" and result.command == "set_mode GUIDED"
    sm = peer.wait_for("COMMAND_LONG", 20.0, lambda m: m.command == mavlink2.MAV_CMD_DO_SET_MODE)
    assert sm.param1 == mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED and sm.param2 == 4
    assert link.wait_until(lambda t: t.mode == "GUIDED", 20.0)
    assert link.takeoff(5.0).ok
    to = peer.wait_for("COMMAND_LONG", 20.0, lambda m: m.command == mavlink2.MAV_CMD_NAV_TAKEOFF)
    assert to.param7 == pytest.approx(5.0)
    assert link.land().ok and link.rtl().ok
    fd = link.force_disarm()
    assert fd.ok
    fdm = peer.wait_for(
        "COMMAND_LONG", 1, lambda m: m.command == 400 and m.param1 == 0 and m.param2 == 21196
    )
    assert fdm is not None
    assert link.disarm().ok
    plain = [m for m in peer.messages("COMMAND_LONG") if m.command == 400 and m.param1 == 0]
    assert [m.param2 for m in plain] == [21196, 0]  # disarm is not forced


def test_fire_and_forget_messages(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    r = link.set_velocity_ned(1.0, -0.5, 0.2, frame="body_offset_ned")
    assert r.ok and r.result_name == "SENT" and "not GUIDED" in r.detail
    r = link.goto_local_ned(3, 4, -5, yaw_deg=90)
    assert r.ok
    targets = peer.wait_for("SET_POSITION_TARGET_LOCAL_NED", 20.0, lambda m: m.x == 3)
    assert targets is not None and targets.z == pytest.approx(-5) and targets.target_system == 1
    vel = peer.messages("SET_POSITION_TARGET_LOCAL_NED")[0]
    assert vel.coordinate_frame == mavlink2.MAV_FRAME_BODY_OFFSET_NED
    assert vel.vx == pytest.approx(1.0) and vel.vy == pytest.approx(-0.5)
    r = link.rc_override({3: 1500, 1: 1600, 12: 0})
    assert r.ok
    rc = peer.wait_for("RC_CHANNELS_OVERRIDE", 20.0)
    assert (rc.chan1_raw, rc.chan2_raw, rc.chan3_raw, rc.chan12_raw) == (1600, 65535, 1500, 65534)
    r = link.send_landing_target(0.4, -0.2, 3.0, time_usec=987654321)
    assert r.ok
    lt = peer.wait_for("LANDING_TARGET", 20.0)
    assert lt.position_valid == 1 and lt.frame == mavlink2.MAV_FRAME_BODY_FRD
    assert lt.time_usec == 987654321 and lt.x == pytest.approx(0.4) and lt.distance > 3.0
    t = link.telemetry
    assert t.landing_targets_sent == 1 and t.last_landing_target["time_usec"] == 987654321


def test_bad_arguments_are_refused_before_sending(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    before = len(peer.received)
    for result, name in (
        (link.takeoff(0), "altitude_m"),
        (link.takeoff(-3), "altitude_m"),
        (link.takeoff(float("nan")), "altitude_m"),
        (link.set_mode("HOVER"), "GUIDED"),
        (link.set_mode("MODE_8"), "LOITER"),
        (link.set_velocity_ned(float("inf"), 0, 0), "vn"),
        (link.goto_local_ned(0, 0, 0, yaw_deg=float("nan")), "yaw_deg"),
        (link.rc_override({0: 1500}), "channel"),
        (link.send_landing_target(0, 0, 3, time_usec=-1), "time_usec"),
        (link.set_param("THIS_NAME_IS_TOO_LONG", 1), "name"),
        (link.set_param("PLND_ENABLED", float("nan")), "value"),
    ):
        assert not result.ok and result.result_name == "INVALID_ARGUMENT", result
        assert name in result.detail
    with pytest.raises(ValueError, match="name"):
        link.get_param("")
    # a barrier: the peer answers this read after everything the link sent before it
    assert link.get_param("WPNAV_SPEED") == pytest.approx(500.0)
    housekeeping = ("HEARTBEAT", "REQUEST_DATA_STREAM", "PARAM_REQUEST_READ")
    sent = [
        m.get_type()
        for m in peer.received[before:]
        if m.get_type() not in housekeeping
        and not (
            m.get_type() == "COMMAND_LONG" and m.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL
        )
    ]
    assert sent == []


def test_command_timeout_retransmits_once(peer: Any, make_link) -> None:
    peer.responder = lambda p, m: m.get_type() == "COMMAND_LONG" and m.command == 400
    link = make_link(f"tcp:127.0.0.1:{peer.port}", command_timeout_s=0.6)
    assert _up(link)
    started = time.monotonic()
    result = link.arm()
    assert time.monotonic() - started >= 0.6  # it waited its timeout (never less)
    assert not result.ok and result.result_name == "TIMEOUT" and result.result is None
    arms = [m for m in peer.messages("COMMAND_LONG") if m.command == 400]
    assert [m.confirmation for m in arms] == [0, 1]


def test_in_progress_then_final_ack(peer: Any, make_link) -> None:
    def slow_ack(p: Any, msg: Any) -> bool:
        if msg.get_type() == "COMMAND_LONG" and msg.command == mavlink2.MAV_CMD_NAV_TAKEOFF:
            p.ack(msg.command, mavlink2.MAV_RESULT_IN_PROGRESS)
            threading.Timer(0.2, p.ack, (msg.command, mavlink2.MAV_RESULT_DENIED)).start()
            return True
        return False

    peer.responder = slow_ack
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    result = link.takeoff(3)
    assert not result.ok and result.result_name == "DENIED" and result.reasons == ()


def test_ack_for_another_gcs_is_ignored(peer: Any, make_link) -> None:
    def other_gcs(p: Any, msg: Any) -> bool:
        if msg.get_type() == "COMMAND_LONG" and msg.command == 400:
            p.send(mavlink2.MAVLink_command_ack_message(400, 0, 0, 0, 254, 190))  # for sysid 254
            p.ack(400, mavlink2.MAV_RESULT_TEMPORARILY_REJECTED)
            return True
        return False

    peer.responder = other_gcs
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    result = link.arm()
    assert result.result_name == "TEMPORARILY_REJECTED" and not result.ok


def test_parameters_read_write_and_verify(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    assert link.get_param("WPNAV_SPEED") == pytest.approx(500.0)
    result = link.set_param("PLND_ENABLED", 1)
    assert result.ok, result
    assert peer.params["PLND_ENABLED"][0] == 1.0
    assert link.get_param("PLND_ENABLED") == 1.0
    # the peer rounds an integer parameter: the echo differs and the link says so
    result = link.set_param("PLND_ENABLED", 1.4)
    assert not result.ok and result.result_name == "MISMATCH" and "kept" in result.detail
    # unknown parameter: ArduPilot stays silent
    started = time.monotonic()
    assert link.get_param("NO_SUCH_PARAM", timeout=0.4) is None
    assert time.monotonic() - started >= 0.4  # it waited its timeout (never less)
    result = link.set_param("NO_SUCH_PARAM", 3)
    assert not result.ok and result.result_name == "TIMEOUT"
    reads = [m for m in peer.messages("PARAM_REQUEST_READ") if m.param_id == "NO_SUCH_PARAM"]
    assert len(reads) == 2  # resent once halfway


def test_command_while_link_down_returns_at_once(make_link) -> None:
    # nothing listens on this port: the link keeps trying, commands fail at once
    # a command that waited for an answer would take its minute: these return at once
    link = make_link("tcp:127.0.0.1:9", command_timeout_s=60.0)
    assert link.wait_until(lambda t: "cannot open" in (t.last_error or ""), 20.0)
    t = link.telemetry
    assert t.state == LinkState.CONNECTING
    for call in (
        link.arm,
        link.land,
        lambda: link.set_mode("LOITER"),
        lambda: link.takeoff(5),
        lambda: link.set_param("PLND_ENABLED", 1),
        lambda: link.rc_override({3: 1500}),
    ):
        result = call()
        assert not result.ok and result.result_name == "LINK_DOWN"
        assert "nothing was sent" in result.detail
    assert link.get_param("PLND_ENABLED") is None


def test_heartbeat_loss_and_return(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}", heartbeat_timeout_s=0.5)
    seen = _events(link)
    assert _up(link)
    peer.heartbeats = False
    assert link.wait_until(lambda t: t.state == LinkState.LOST, 20.0)
    lost = _wait_event(seen, "link_lost")
    assert lost is not None and "no heartbeat" in lost.data["reason"]
    assert link.telemetry.heartbeat_age_s > 0.5
    result = link.arm()
    assert result.result_name == "LINK_DOWN" and "lost" in result.detail
    peer.heartbeats = True
    assert _up(link, 20.0)
    deadline = time.monotonic() + 20.0  # events come on their own thread
    while time.monotonic() < deadline and seen[-1].kind != "link_up":
        time.sleep(0.01)
    kinds = [e.kind for e in seen if e.kind.startswith("link_")]
    assert kinds[-2:] == ["link_lost", "link_up"]
    assert peer.connections == 1  # same socket all along


def test_tcp_drop_and_reconnect(peer: Any, make_link, make_peer) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    seen = _events(link)
    assert _up(link)
    port = peer.port
    peer.close()  # the vehicle goes away entirely
    assert link.wait_until(lambda t: t.state == LinkState.LOST, 20.0)
    lost = _wait_event(seen, "link_lost")
    assert lost is not None and lost.data["reason"].startswith("TCP connection")  # closed or reset
    # a reconnect refused while nobody listens
    assert link.wait_until(lambda t: "cannot open" in (t.last_error or ""), 20.0)
    make_peer(port=port)
    assert _up(link, 20.0)
    assert link.telemetry.reconnects >= 1
    assert link.arm().ok  # commands work on the new connection


def test_raising_subscriber_does_not_kill_the_link(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")

    def bad(event: LinkEvent) -> None:
        raise RuntimeError("subscriber bug")

    link.subscribe(bad)
    seen = _events(link)
    assert _up(link)
    assert link.arm().ok
    assert _wait_event(seen, "command") is not None
    unsubscribe = link.subscribe(seen.append)
    unsubscribe()


def test_handler_fault_is_isolated(peer: Any, make_link, monkeypatch) -> None:
    from backend.link import telemetry

    def broken(msg: Any, now: float) -> dict:
        raise ZeroDivisionError("handler bug")

    monkeypatch.setitem(telemetry.TELEMETRY_HANDLERS, "ATTITUDE", broken)
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    for _ in range(3):
        peer.send(mavlink2.MAVLink_attitude_message(1, 0, 0, 0, 0, 0, 0))
    peer.send(mavlink2.MAVLink_gps_raw_int_message(0, 3, 0, 0, 0, 90, 65535, 0, 0, 12))
    assert link.wait_until(lambda t: t.gps is not None and t.handler_errors >= 3, 20.0)
    assert link.telemetry.state == LinkState.UP
    assert link.latest("ATTITUDE") is not None  # the cache is not the handler


def test_garbage_is_counted_and_skipped(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    rng = random.Random(1)
    good = peer.pack(mavlink2.MAVLink_attitude_message(42, 0, 0, 0.5, 0, 0, 0))
    corrupt = bytearray(good)
    corrupt[12] ^= 0xFF  # payload byte flipped: CRC fails
    for i in range(50):
        peer.send_raw(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 200))))
        peer.send_raw(good[: rng.randrange(1, len(good))])  # truncated packet
        peer.send_raw(bytes(corrupt))
        if i % 5 == 0:
            peer.send(peer.heartbeat_msg())
    peer.send_raw(os.urandom(4096))
    # after the noise, a clean stream is understood again. (A false start marker in the
    # noise can claim up to 280 following bytes, as in any MAVLink parser, so the
    # stream runs a little while rather than one packet.)
    for _ in range(20):
        peer.send(mavlink2.MAVLink_attitude_message(4242, 0, 0, 1.25, 0, 0, 0))
        time.sleep(0.01)
    assert link.wait_until(lambda t: t.attitude_time_boot_ms == 4242 and t.crc_errors > 50, 20.0), (
        link.telemetry
    )
    assert link.telemetry.state == LinkState.UP
    assert link.telemetry.attitude.yaw == pytest.approx(1.25)
    assert link.arm().ok  # still responsive


def test_signing(make_link, make_peer) -> None:
    key = bytes(range(32))
    peer = make_peer(signing_key=key)
    link = make_link(f"tcp:127.0.0.1:{peer.port}", signing_key=key)
    assert _up(link)
    hb = peer.wait_for("HEARTBEAT", 20.0)
    assert hb is not None and hb.get_signed()
    assert link.arm().ok
    arm = peer.wait_for("COMMAND_LONG", 20.0, lambda m: m.command == 400)
    assert arm.get_signed()


def test_wrong_or_missing_signing_key_is_rejected(make_link, make_peer) -> None:
    peer = make_peer(signing_key=bytes(range(32)))
    link = make_link(f"tcp:127.0.0.1:{peer.port}", signing_key=bytes([7]) * 32)
    assert not _up(link, 1.0)
    assert link.wait_until(lambda t: t.crc_errors >= 5, 20.0)
    # and the peer rejects what the link signs with the wrong key
    assert peer.messages("HEARTBEAT") == []
    # a signing vehicle and an unsigned link: the vehicle ignores the link
    unsigned = make_link(f"tcp:127.0.0.1:{peer.port}")
    time.sleep(0.5)
    assert peer.messages("HEARTBEAT") == []
    assert unsigned.telemetry is not None


def test_tlog_records_both_directions(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    assert link.arm().ok
    path = link.tlog_path
    assert path is not None and path.suffix == ".tlog"
    link.close()
    log = mavutil.mavlink_connection(str(path))
    sources = set()
    types = set()
    while (msg := log.recv_match()) is not None:
        if msg.get_type() == "BAD_DATA":
            pytest.fail(f"bad data in tlog: {msg}")
        sources.add((msg.get_srcSystem(), msg.get_type()))
        types.add(msg.get_type())
    assert (255, "HEARTBEAT") in sources and (1, "HEARTBEAT") in sources
    assert (255, "COMMAND_LONG") in sources and (1, "COMMAND_ACK") in sources


def test_close_is_prompt_and_idempotent(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    seen = _events(link)
    assert _up(link)
    link.close()
    link.close()
    assert link.state == LinkState.CLOSED
    assert not [t for t in threading.enumerate() if t.name.startswith("vehicle-link-")]
    assert [e.kind for e in seen][-1] == "link_closed"
    assert link.arm().result_name == "LINK_DOWN"


def test_ack_of_a_retransmission_is_not_taken_by_the_next_command(peer: Any, make_link) -> None:
    arms: list[int] = []

    def slow_vehicle(p: Any, msg: Any) -> bool:
        if msg.get_type() != "COMMAND_LONG" or msg.command != 400:
            return False
        arms.append(msg.confirmation)
        first_call = len([c for c in arms if c == 0]) == 1
        if first_call:  # the original and its retransmission are both refused, late
            threading.Timer(0.7, p.ack, (400, mavlink2.MAV_RESULT_FAILED)).start()
        else:
            threading.Timer(0.3, p.ack, (400, mavlink2.MAV_RESULT_ACCEPTED)).start()
        return True

    peer.responder = slow_vehicle
    link = make_link(f"tcp:127.0.0.1:{peer.port}", command_timeout_s=1.0)
    assert _up(link)
    first = link.arm()
    assert first.result_name == "FAILED"
    second = link.arm()
    assert second.ok, second  # not the FAILED that answered the retransmission
    assert arms == [0, 1, 0]


def test_external_navigation_messages_and_the_source_set_command(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    r = link.send_vision_position(1.5, -2.25, -4.0, 0.01, -0.02, 1.2, time_usec=123456789)
    assert r.ok and r.result_name == "SENT"
    vp = peer.wait_for("VISION_POSITION_ESTIMATE", 20.0)
    assert vp.usec == 123456789
    assert (vp.x, vp.y, vp.z) == pytest.approx((1.5, -2.25, -4.0))
    assert (vp.roll, vp.pitch, vp.yaw) == pytest.approx((0.01, -0.02, 1.2))
    assert math.isnan(vp.covariance[0]) and vp.reset_counter == 0
    r = link.send_vision_speed(0.25, -0.5, 0.0, time_usec=123456790, reset_counter=3)
    assert r.ok
    vs = peer.wait_for("VISION_SPEED_ESTIMATE", 20.0)
    assert vs.usec == 123456790 and (vs.x, vs.y, vs.z) == pytest.approx((0.25, -0.5, 0.0))
    assert math.isnan(vs.covariance[0]) and vs.reset_counter == 3
    assert link.vision_positions_sent == 1 and link.vision_speeds_sent == 1
    r = link.set_ekf_source_set(2)
    assert r.ok and r.result_name == "ACCEPTED" and r.command == "set_ekf_source_set 2"
    cl = peer.wait_for(
        "COMMAND_LONG", 20.0, lambda m: m.command == mavlink2.MAV_CMD_SET_EKF_SOURCE_SET
    )
    assert cl.command == 42007 and cl.param1 == 2


def test_source_set_refusal_is_reported_verbatim(peer: Any, make_link) -> None:
    def refuse(p: Any, msg: Any) -> bool:
        if msg.get_type() == "COMMAND_LONG" and msg.command == 42007:
            p.ack(msg.command, mavlink2.MAV_RESULT_DENIED)
            return True
        return False

    peer.responder = refuse
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    r = link.set_ekf_source_set(3)
    assert not r.ok and r.result_name == "DENIED" and "DENIED" in r.detail


def test_external_navigation_arguments_are_checked_before_sending(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    before = len(peer.messages("VISION_POSITION_ESTIMATE"))
    for result, name in (
        (link.send_vision_position(0, 0, float("nan"), 0, 0, 0, time_usec=1), "down"),
        (link.send_vision_position(0, 0, 0, 0, 0, 0, time_usec=-5), "time_usec"),
        (link.send_vision_position(0, 0, 0, 0, 0, 0, time_usec=1, reset_counter=256), "reset"),
        (link.send_vision_speed(float("inf"), 0, 0, time_usec=1), "vn"),
        (link.set_ekf_source_set(4), "source_set"),
        (link.set_ekf_source_set(True), "source_set"),  # type: ignore[arg-type]
    ):
        assert not result.ok and result.result_name == "INVALID_ARGUMENT", result
        assert name in result.detail
    assert link.get_param("WPNAV_SPEED") == pytest.approx(500.0)  # barrier
    assert len(peer.messages("VISION_POSITION_ESTIMATE")) == before
    assert not [m for m in peer.messages("COMMAND_LONG") if m.command == 42007]
    assert link.vision_positions_sent == 0


def test_stale_position_is_dropped_and_a_reboot_resets_the_vehicle_fields(
    peer: Any, make_link
) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    peer.custom_mode = 4
    peer.armed = True
    peer.send(mavlink2.MAVLink_ekf_status_report_message(831, 0.1, 0.1, 0.1, 0.1, 0.0))
    peer.send(mavlink2.MAVLink_attitude_message(60_000, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    peer.send(mavlink2.MAVLink_local_position_ned_message(60_000, 1.0, 2.0, -5.0, 0, 0, 0))
    assert link.wait_until(lambda t: t.position_ready and t.armed and t.mode == "GUIDED", 3.0)
    beats = link.telemetry.heartbeats
    assert link.wait_until(lambda t: t.heartbeats > beats, 3.0)
    # the vehicle's clock goes on, LOCAL_POSITION_NED does not: the position is dropped
    peer.send(mavlink2.MAVLink_attitude_message(61_000, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    assert link.wait_until(lambda t: t.vehicle_time_boot_ms == 61_000, 3.0)
    assert link.telemetry.position_ned is not None  # 1 s: not stale yet
    peer.send(mavlink2.MAVLink_attitude_message(61_600, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    assert link.wait_until(lambda t: t.position_stale, 3.0)
    t = link.telemetry
    assert t.position_ned is None and t.velocity_ned is None and not t.position_ready
    peer.send(mavlink2.MAVLink_local_position_ned_message(61_700, 1.0, 2.0, -5.0, 0, 0, 0))
    assert link.wait_until(lambda t: t.position_ned is not None and not t.position_stale, 3.0)
    # a reboot: the clock goes back; nothing from before it is kept
    peer.heartbeats = False
    peer.armed = False
    peer.custom_mode = 0
    peer.send(mavlink2.MAVLink_attitude_message(900, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0))
    assert link.wait_until(lambda t: t.boots == 1, 3.0)
    t = link.telemetry
    assert t.vehicle_time_boot_ms == 900 and t.position_ned is None and t.ekf is None
    assert t.mode is None and not t.armed and t.attitude is not None  # the new ATTITUDE
    assert link.latest("LOCAL_POSITION_NED") is None and link.latest("ATTITUDE") is not None
    assert t.state.value == "up"
    peer.heartbeats = True
    assert link.wait_until(lambda t: t.mode == "STABILIZE", 3.0)


def test_statustexts_and_heartbeats_are_counted(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    for i in range(60):
        peer.statustext(f"text {i}", mavlink2.MAV_SEVERITY_INFO)
    assert link.wait_until(lambda t: t.statustexts_received == 60, 3.0)
    t = link.telemetry
    assert len(t.statustexts) == 50 and t.statustexts[-1].text == "text 59"
    assert t.heartbeats >= 1


def test_set_yaw_sends_condition_yaw_absolute_shortest_way(peer: Any, make_link) -> None:
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    result = link.set_yaw(-30.0, rate_dps=10.0)
    assert result.ok, result.detail
    sent = peer.wait_for("COMMAND_LONG", 3.0, lambda m: m.command == mavlink2.MAV_CMD_CONDITION_YAW)
    assert (sent.param1, sent.param2, sent.param3, sent.param4) == (330.0, 10.0, 0.0, 0.0)
    assert link.set_yaw(10.0, rate_dps=-1).result_name == "INVALID_ARGUMENT"
    assert link.set_yaw(math.nan).result_name == "INVALID_ARGUMENT"


def test_the_attitude_at_a_frames_moment(peer: Any, make_link) -> None:
    """What the vision is told of the camera's tilt is the attitude when its frame was
    taken: the link keeps the attitudes it received by their arrival (this process's
    clock, as frames are stamped), and has none for a moment long after the last."""
    link = make_link(f"tcp:127.0.0.1:{peer.port}")
    assert _up(link)
    assert link.attitude_at(time.monotonic()) is None
    arrived = []
    for ms, roll in ((1000, 0.1), (1100, 0.3)):
        peer.send(mavlink2.MAVLink_attitude_message(ms, roll, -0.05, 1.0, 0.0, 0.0, 0.0))
        assert link.wait_until(lambda t, ms=ms: t.attitude_time_boot_ms == ms, 5.0)
        arrived.append(link.telemetry.attitude_rx_monotonic)
    t1, t2 = arrived
    assert link.attitude_at(t1) == pytest.approx((0.1, -0.05, 1.0))
    assert link.attitude_at((t1 + t2) / 2) == pytest.approx((0.2, -0.05, 1.0))
    assert link.attitude_at(t2 + 0.4) == pytest.approx((0.3, -0.05, 1.0))
    # An attitude no vehicle can have is dropped before it is kept.
    peer.send(mavlink2.MAVLink_attitude_message(1200, 1e9, 0.0, 1.0, 0.0, 0.0, 0.0))
    assert link.wait_until(lambda t: t.implausible >= 1, 5.0)
    assert link.attitude_at(t2 + 0.4) == pytest.approx((0.3, -0.05, 1.0))
    # Half a second and more away from every attitude received: not known.
    assert link.attitude_at(t2 + 0.6) is None
    assert link.attitude_at(t1 - 0.6) is None
