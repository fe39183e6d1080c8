"""Pure parts of the link: modes, connection strings, builders, handlers, tlog format."""

from __future__ import annotations

import math
import struct
from datetime import UTC, datetime

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import (
    COPTER_MODES,
    LinkState,
    Telemetry,
    TlogWriter,
    VehicleLink,
    mode_name,
    mode_number,
    parse_url,
)
from backend.link import commands as cmd
from backend.link.telemetry import TELEMETRY_HANDLERS, StatusTextAssembler, clock_changes


def test_mode_table_is_exactly_the_quad_modes() -> None:
    assert set(COPTER_MODES) == set(range(29)) - {8, 10, 12, 26}
    assert 29 not in COPTER_MODES
    assert mode_name(4) == "GUIDED" and mode_name(9) == "LAND" and mode_name(27) == "AUTO_RTL"
    for absent in (8, 10, 12, 26, 29, None):
        assert mode_name(absent) is None
    assert mode_number("loiter") == 5 and mode_number(" Guided ") == 4


@pytest.mark.parametrize("bad", ["HOVER", "", "MODE_8", "auto_tune"])
def test_unknown_mode_names_the_valid_ones(bad: str) -> None:
    with pytest.raises(ValueError, match="name") as info:
        mode_number(bad)
    assert "GUIDED" in str(info.value) and "LOITER" in str(info.value)


def test_mode_number_rejects_non_strings() -> None:
    with pytest.raises(ValueError, match="name"):
        mode_number(4)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("url", "kind", "host", "port", "device", "baud"),
    [
        ("tcp:127.0.0.1:5760", "tcp", "127.0.0.1", 5760, None, None),
        ("udpin:0.0.0.0:14550", "udpin", "0.0.0.0", 14550, None, None),
        ("udp:127.0.0.1:14550", "udpin", "127.0.0.1", 14550, None, None),
        ("udpout:10.0.0.2:14550", "udpout", "10.0.0.2", 14550, None, None),
        ("/dev/ttyUSB0,57600", "serial", None, None, "/dev/ttyUSB0", 57600),
        ("/dev/ttyACM0", "serial", None, None, "/dev/ttyACM0", 115200),
    ],
)
def test_parse_url(url: str, kind: str, host: str, port: int, device: str, baud: int) -> None:
    spec = parse_url(url, baud=115200)
    assert (spec.kind, spec.host, spec.port, spec.device) == (kind, host, port, device)
    if kind == "serial":
        assert spec.baud == baud


@pytest.mark.parametrize(
    "url",
    [
        "",
        "   ",
        "tcp:",
        "tcp:host",
        "tcp:host:0",
        "tcp:host:99999",
        "tcp::5760",
        "udpin:x:port",
        "http://example.com",
        "/dev/ttyUSB0,fast",
        "/dev/ttyUSB0,-5",
        None,
        5760,
    ],
)
def test_parse_url_rejects(url: object) -> None:
    with pytest.raises(ValueError, match="url"):
        parse_url(url)  # type: ignore[arg-type]


def test_link_constructor_validates() -> None:
    with pytest.raises(ValueError, match="url"):
        VehicleLink("nonsense:1:2:3")
    with pytest.raises(ValueError, match="signing_key"):
        VehicleLink("tcp:127.0.0.1:5760", signing_key=b"short")
    with pytest.raises(ValueError, match="source_system"):
        VehicleLink("tcp:127.0.0.1:5760", source_system=0)
    with pytest.raises(ValueError, match="heartbeat_timeout_s"):
        VehicleLink("tcp:127.0.0.1:5760", heartbeat_timeout_s=0)
    with pytest.raises(ValueError, match="command_timeout_s"):
        VehicleLink("tcp:127.0.0.1:5760", command_timeout_s=math.nan)
    with pytest.raises(ValueError, match="stream_rates_hz"):
        VehicleLink("tcp:127.0.0.1:5760", stream_rates_hz={"NOT_A_MESSAGE": 5})
    with pytest.raises(ValueError, match="stream_rates_hz"):
        VehicleLink("tcp:127.0.0.1:5760", stream_rates_hz={"ATTITUDE": 0})


def test_link_not_started_refuses_commands_at_once() -> None:
    link = VehicleLink("tcp:127.0.0.1:9")
    result = link.arm()
    assert not result.ok and result.result_name == "LINK_DOWN"
    assert "nothing was sent" in result.detail
    assert link.state == LinkState.CONNECTING and link.tlog_path is None
    link.close()
    link.close()  # idempotent
    assert link.state == LinkState.CLOSED
    with pytest.raises(RuntimeError):
        link.start()


def test_position_and_velocity_targets() -> None:
    f = cmd.position_target(1, -2, -3)
    assert (f["x"], f["y"], f["z"]) == (1, -2, -3)
    assert f["coordinate_frame"] == mavlink2.MAV_FRAME_LOCAL_NED
    assert f["type_mask"] == 0b0000_1101_1111_1000  # velocity, accel, yaw, yaw rate ignored
    f = cmd.position_target(0, 0, -5, yaw_deg=90)
    assert not f["type_mask"] & mavlink2.POSITION_TARGET_TYPEMASK_YAW_IGNORE
    assert f["yaw"] == pytest.approx(math.pi / 2)
    v = cmd.velocity_target(1, 0, -0.5)
    assert (v["vx"], v["vy"], v["vz"]) == (1, 0, -0.5)
    assert v["type_mask"] == 0b0000_1101_1100_0111  # position, accel, yaw, yaw rate ignored
    v = cmd.velocity_target(1, 0, 0, yaw_rate_dps=30, frame="body_offset_ned")
    assert v["coordinate_frame"] == mavlink2.MAV_FRAME_BODY_OFFSET_NED
    assert v["yaw_rate"] == pytest.approx(math.radians(30))
    assert not v["type_mask"] & mavlink2.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: cmd.position_target(math.nan, 0, 0), "north"),
        (lambda: cmd.position_target(0, "x", 0), "east"),
        (lambda: cmd.position_target(0, 0, math.inf), "down"),
        (lambda: cmd.position_target(0, 0, 0, yaw_deg=math.nan), "yaw_deg"),
        (lambda: cmd.velocity_target(0, 0, 0, frame="global"), "frame"),
        (lambda: cmd.velocity_target(None, 0, 0), "vn"),
        (lambda: cmd.check_altitude(0), "altitude_m"),
        (lambda: cmd.check_altitude(-5), "altitude_m"),
        (lambda: cmd.check_altitude(math.inf), "altitude_m"),
        (lambda: cmd.check_altitude("ten"), "altitude_m"),
    ],
)
def test_builders_name_the_bad_argument(call: object, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        call()  # type: ignore[operator]


def test_rc_override_translates_release_and_ignore() -> None:
    values = cmd.rc_override_channels({1: 1600, 3: 1500, 4: 0, 9: 1200, 10: 0, 11: 65535})
    assert len(values) == 18
    assert values[:8] == [1600, 65535, 1500, 0, 65535, 65535, 65535, 65535]
    assert values[8] == 1200
    assert values[9] == 65534  # release on channels 9..18
    assert values[10] == 0  # ignore on channels 9..18
    assert values[11:] == [0] * 7


@pytest.mark.parametrize(
    "channels",
    [
        {},
        {0: 1500},
        {19: 1500},
        {1: 700},
        {1: 2500},
        {1: 1500.0},
        {"1": 1500},
        {True: 1500},
        [1500],
    ],
)
def test_rc_override_rejects(channels: object) -> None:
    with pytest.raises(ValueError, match="channel"):
        cmd.rc_override_channels(channels)  # type: ignore[arg-type]


def test_landing_target_fields() -> None:
    f = cmd.landing_target(0.5, -0.25, 4.0, time_usec=123456)
    assert f["position_valid"] == 1 and f["frame"] == mavlink2.MAV_FRAME_BODY_FRD
    assert f["distance"] == pytest.approx(math.sqrt(0.25 + 0.0625 + 16))
    # ArduPilot's line of sight from the angles: normalize(-tan(angle_y), tan(angle_x), 1)
    assert -math.tan(f["angle_y"]) * 4.0 == pytest.approx(0.5)
    assert math.tan(f["angle_x"]) * 4.0 == pytest.approx(-0.25)
    msg = mavlink2.MAVLink_landing_target_message(**f)
    mav = mavlink2.MAVLink(None, 255, 190)
    parsed = mavlink2.MAVLink(None).parse_char(msg.pack(mav))
    assert parsed.position_valid == 1 and parsed.z == pytest.approx(4.0)  # extensions survive


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"time_usec": -1}, "time_usec"),
        ({"time_usec": 1.5}, "time_usec"),
        ({"time_usec": 2**64}, "time_usec"),
        ({"time_usec": 0, "frame": 99}, "frame"),
        ({"time_usec": 0, "distance": 0}, "distance"),
        ({"time_usec": 0, "x": math.nan}, "x"),
    ],
)
def test_landing_target_rejects(kwargs: dict, name: str) -> None:
    args = {"x": 0.0, "y": 0.0, "z": 3.0}
    for axis in "xyz":
        if axis in kwargs:
            args[axis] = kwargs.pop(axis)
    with pytest.raises(ValueError, match=name):
        cmd.landing_target(args["x"], args["y"], args["z"], **kwargs)


def test_reason_selection() -> None:
    texts = [
        (6, "EKF3 IMU0 is using GPS"),
        (2, "PreArm: Need Position Estimate"),
        (2, "Arm: Throttle too high"),
        (2, "PreArm: Need Position Estimate"),
    ]
    assert cmd.select_reasons(texts) == ("PreArm: Need Position Estimate", "Arm: Throttle too high")
    assert cmd.select_reasons([(6, "info"), (4, "Odd refusal")]) == ("Odd refusal",)
    assert cmd.select_reasons([(6, "just info")]) == ()
    assert cmd.is_reason_text("Mode change to FOLLOW failed: requires position")
    assert cmd.is_reason_text("Flight mode change failed")
    assert not cmd.is_reason_text("Armed? no: arming_check")  # 'Armed' is not 'Arm'
    assert cmd.mav_result_name(4) == "FAILED" and cmd.mav_result_name(250) == "RESULT_250"


def _msg(cls: type, *args: object, src: int = 1) -> object:
    """Round-trip through real bytes so handlers see what the wire gives."""
    mav = mavlink2.MAVLink(None, src, 1)
    return mavlink2.MAVLink(None).parse_char(cls(*args).pack(mav))


def test_telemetry_handlers() -> None:
    h = TELEMETRY_HANDLERS
    base = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
    hb = h["HEARTBEAT"](_msg(mavlink2.MAVLink_heartbeat_message, 2, 3, base, 4, 4, 3), 1.0)
    assert hb["armed"] and hb["mode"] == "GUIDED" and hb["mode_number"] == 4
    hb = h["HEARTBEAT"](_msg(mavlink2.MAVLink_heartbeat_message, 2, 3, 1, 8, 3, 3), 1.0)
    assert hb["mode"] is None and hb["mode_number"] == 8 and not hb["armed"]
    att = h["ATTITUDE"](
        _msg(mavlink2.MAVLink_attitude_message, 500, 0.1, -0.2, 1.5, 0, 0, 0.3), 7.0
    )
    assert att["attitude"].yaw == pytest.approx(1.5) and att["attitude_time_boot_ms"] == 500
    assert att["attitude_rx_monotonic"] == 7.0
    lpn = h["LOCAL_POSITION_NED"](
        _msg(mavlink2.MAVLink_local_position_ned_message, 900, 1, 2, -3, 0.5, 0, -1), 8.0
    )
    assert lpn["position_ned"].z == pytest.approx(-3)
    assert lpn["velocity_ned"].z == pytest.approx(-1) and lpn["local_position_time_boot_ms"] == 900
    gpi = h["GLOBAL_POSITION_INT"](
        _msg(
            mavlink2.MAVLink_global_position_int_message,
            1,
            -353632620,
            1491652370,
            589000,
            5000,
            0,
            0,
            0,
            9000,
        ),
        0.0,
    )
    assert gpi["relative_alt_m"] == pytest.approx(5.0) and gpi["heading_deg"] == pytest.approx(90)
    assert gpi["global_position"].lat_deg == pytest.approx(-35.363262)
    gpi = h["GLOBAL_POSITION_INT"](
        _msg(mavlink2.MAVLink_global_position_int_message, 1, 0, 0, 0, 0, 0, 0, 0, 65535), 0.0
    )
    assert "heading_deg" not in gpi
    bit = mavlink2.MAV_SYS_STATUS_PREARM_CHECK
    ss = h["SYS_STATUS"](
        _msg(
            mavlink2.MAVLink_sys_status_message, bit, bit, bit, 0, 12600, 150, 80, 0, 0, 0, 0, 0, 0
        ),
        0.0,
    )
    assert ss["prearm_ok"] is True and ss["battery"].voltage_v == pytest.approx(12.6)
    assert ss["battery"].current_a == pytest.approx(1.5) and ss["battery"].remaining_pct == 80
    ss = h["SYS_STATUS"](
        _msg(mavlink2.MAVLink_sys_status_message, bit, bit, 0, 0, 65535, -1, -1, 0, 0, 0, 0, 0, 0),
        0.0,
    )
    assert ss["prearm_ok"] is False and ss["battery"].voltage_v is None
    assert ss["battery"].remaining_pct is None
    gps = h["GPS_RAW_INT"](
        _msg(mavlink2.MAVLink_gps_raw_int_message, 0, 3, 0, 0, 0, 121, 65535, 0, 0, 10), 0.0
    )
    assert gps["gps"].fix_type == 3 and gps["gps"].hdop == pytest.approx(1.21)
    assert gps["gps"].satellites == 10
    good = 1 | 2 | 4 | 8 | 16 | 32
    ekf = h["EKF_STATUS_REPORT"](
        _msg(mavlink2.MAVLink_ekf_status_report_message, good, 0.1, 0.1, 0.1, 0.1, 0.0), 0.0
    )
    assert ekf["ekf"].healthy and ekf["ekf"].pos_horiz_ok
    ekf = h["EKF_STATUS_REPORT"](
        _msg(mavlink2.MAVLink_ekf_status_report_message, good | 128, 0.1, 0.9, 0.1, 0.1, 0.0), 0.0
    )
    assert not ekf["ekf"].healthy and not ekf["ekf"].pos_horiz_ok
    down = mavlink2.MAV_SENSOR_ROTATION_PITCH_270
    ds = h["DISTANCE_SENSOR"](
        _msg(mavlink2.MAVLink_distance_sensor_message, 0, 20, 700, 345, 10, 0, down, 0), 0.0
    )
    assert ds["rangefinder_m"] == pytest.approx(3.45)
    ds = h["DISTANCE_SENSOR"](
        _msg(mavlink2.MAVLink_distance_sensor_message, 0, 20, 700, 701, 10, 0, down, 0), 0.0
    )
    assert ds["rangefinder_m"] is None
    assert (
        h["DISTANCE_SENSOR"](
            _msg(mavlink2.MAVLink_distance_sensor_message, 0, 20, 700, 345, 10, 0, 0, 0), 0.0
        )
        == {}
    )


def test_statustext_chunks_are_joined() -> None:
    asm = StatusTextAssembler()
    long_text = "PreArm: " + "x" * 70
    first = _msg(mavlink2.MAVLink_statustext_message, 2, long_text[:50].encode(), 7, 0)
    second = _msg(mavlink2.MAVLink_statustext_message, 2, long_text[50:].encode(), 7, 1)
    assert asm.feed(first) is None
    assert asm.feed(second) == long_text
    single = _msg(mavlink2.MAVLink_statustext_message, 6, b"Arming motors", 0, 0)
    assert asm.feed(single) == "Arming motors"


def test_telemetry_to_dict_is_json() -> None:
    import json

    from backend.link import Attitude, StatusText

    t = Telemetry(
        state=LinkState.UP,
        attitude=Attitude(0.0, 0.0, math.nan, 0.0, 0.0, 0.0),
        statustexts=(StatusText(1.0, 2, "PreArm: x"),),
    )
    d = json.loads(json.dumps(t.to_dict(), allow_nan=False))
    assert d["state"] == "up" and d["attitude"]["yaw"] is None
    assert d["statustexts"] == [{"time": 1.0, "severity": 2, "text": "PreArm: x"}]


def test_tlog_writer_format_replays(tmp_path) -> None:
    start = datetime(2026, 11, 22, 11, 40, 0, tzinfo=UTC)
    writer = TlogWriter(tmp_path, start=start)
    second = TlogWriter(tmp_path, start=start)
    assert writer.path.name == "2026-11-22T11-40-00Z.tlog"
    assert second.path.name == "2026-11-22T11-40-00Z-1.tlog"
    mav = mavlink2.MAVLink(None, 1, 1)
    hb = mavlink2.MAVLink_heartbeat_message(2, 3, 1, 0, 3, 3).pack(mav)
    writer.write(hb, t=1_700_000_000.0)
    writer.close()
    writer.write(hb)  # after close: dropped, no error
    second.close()
    raw = writer.path.read_bytes()
    assert len(raw) == 8 + len(hb)
    assert struct.unpack(">Q", raw[:8])[0] == 1_700_000_000_000_000
    log = mavutil.mavlink_connection(str(writer.path))
    msg = log.recv_match(type="HEARTBEAT")
    assert msg is not None and msg.get_srcSystem() == 1


def test_stream_requester_decisions() -> None:
    from backend.link.streams import CHECK_S, STALE_S, StreamRequester

    s = StreamRequester()
    assert s.due(100.0, None) == "intervals"
    assert s.due(100.5, None) is None  # give the vehicle time to answer
    assert s.due(100.0 + CHECK_S + 0.1, None) == "data_streams"  # nothing came: fall back
    assert s.due(100.0 + CHECK_S + 0.2, None) is None  # once
    assert s.due(100.0 + STALE_S + 0.1, None) == "intervals"  # still nothing: start over
    # telemetry flows: nothing to do until it stops
    s.reset()
    assert s.due(200.0, None) == "intervals"
    assert s.due(203.0, 202.9) is None
    assert s.due(202.9 + STALE_S + 0.1, 202.9) == "intervals"  # the stream stopped (reboot)
    # a refused SET_MESSAGE_INTERVAL triggers the fallback at once
    s.reset()
    assert s.due(300.0, None) == "intervals"
    s.refused()
    assert s.due(300.1, None) == "data_streams"


def test_stream_messages_and_rates() -> None:
    from backend.link import streams

    msgs = streams.interval_messages((1, 1), {"ATTITUDE": 20.0, "VFR_HUD": 4.0})
    assert [m.param1 for m in msgs] == [mavlink2.MAVLINK_MSG_ID_ATTITUDE, 74]
    assert [m.param2 for m in msgs] == [50_000, 250_000]
    assert all(m.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL for m in msgs)
    reqs = streams.data_stream_messages((1, 1))
    assert {r.req_stream_id for r in reqs} >= {mavlink2.MAV_DATA_STREAM_EXTRA1}
    assert all(r.start_stop == 1 for r in reqs)
    assert streams.check_rates({"ATTITUDE": 50}) == {"ATTITUDE": 50.0}
    for bad in ({"ATTITUDE": 0}, {"ATTITUDE": 1000}, {"ATTITUDE": "fast"}, {"NOPE": 1}):
        with pytest.raises(ValueError, match="stream_rates_hz"):
            streams.check_rates(bad)


@pytest.mark.parametrize(
    ("last", "now", "asked", "reboot"),
    [
        (60_000, 58_000, False, True),  # back by more than REBOOT_BACKSTEP_MS
        (60_000, 59_500, False, False),  # a reordered message
        (60_000, 59_500, True, False),  # ... even with a reboot asked
        (1_000, 30, False, False),  # a second into a boot, no reboot asked: not told
        (1_000, 30, True, True),  # ... a reboot asked: back by more than half
        (1_000, 990, True, False),  # the boot being left, a few ms out of order
    ],
)
def test_the_clock_going_back_is_a_reboot(last: int, now: int, asked: bool, reboot: bool) -> None:
    changes = clock_changes(Telemetry(vehicle_time_boot_ms=last), now, 1500.0, reboot_asked=asked)
    assert (changes.get("boots") == 1) == reboot
