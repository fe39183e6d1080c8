"""Telemetry that cannot be real is dropped and counted, never shown.

A message can pass MAVLink's checksum and still carry nonsense: a radio's bit error
after the CRC was computed, a buggy companion computer, a fuzzer. Shown as if real,
a roll of -7e16 rad or mode 2090988876 would mislead the operator and the missions.
:func:`implausible` names what is impossible about a message of a type the station
uses (``None`` when nothing is); the link drops such a message whole (the telemetry
keeps its last plausible values) and counts it (``Telemetry.implausible``, in the
status). The bounds are physical, far outside any flight: they catch corruption, not
an unusual day.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

_PI = math.pi + 1e-3  # ArduPilot reports angles in [-pi, pi]; a hair of rounding more
_MAX_RATE = 100.0  # rad/s: a copter flips at 10-20
_MAX_HORIZONTAL_M = 1e5  # 100 km from home
_ALT_M = (-1_000.0, 10_000.0)  # above home (local frame: down is positive)
_MSL_M = (-1_000.0, 20_000.0)  # above mean sea level
_MAX_SPEED = 150.0  # m/s
_MAX_MODE = 255  # ArduCopter's modes are numbered below 30; a byte is generous
_MAX_RANGE_M = 1_000.0


def _finite(*values: float) -> bool:
    return all(isinstance(v, int | float) and math.isfinite(v) for v in values)


def _within(value: float, low: float, high: float) -> bool:
    return _finite(value) and low <= value <= high


def _heartbeat(msg: Any) -> str | None:
    if msg.base_mode & mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED and msg.custom_mode > _MAX_MODE:
        return f"mode number {msg.custom_mode} is no flight mode"
    if msg.system_status > mavlink2.MAV_STATE_FLIGHT_TERMINATION:
        return f"system status {msg.system_status} is not a MAV_STATE"
    return None


def _attitude(msg: Any) -> str | None:
    if not (_within(msg.roll, -_PI, _PI) and _within(msg.pitch, -_PI, _PI)):
        return f"roll/pitch ({msg.roll!r}, {msg.pitch!r}) rad beyond +-pi"
    if not _within(msg.yaw, -2 * _PI, 2 * _PI):
        return f"yaw {msg.yaw!r} rad beyond +-2 pi"
    rates = (msg.rollspeed, msg.pitchspeed, msg.yawspeed)
    if not all(_within(r, -_MAX_RATE, _MAX_RATE) for r in rates):
        return f"body rates {rates!r} rad/s beyond {_MAX_RATE:g}"
    return None


def _local_position(msg: Any) -> str | None:
    if not all(_within(v, -_MAX_HORIZONTAL_M, _MAX_HORIZONTAL_M) for v in (msg.x, msg.y)):
        return f"position ({msg.x!r}, {msg.y!r}) m beyond {_MAX_HORIZONTAL_M:g} m from home"
    if not _within(-msg.z, *_ALT_M):
        return f"height {-msg.z!r} m beyond {_ALT_M}"
    if not all(_within(v, -_MAX_SPEED, _MAX_SPEED) for v in (msg.vx, msg.vy, msg.vz)):
        return f"velocity ({msg.vx!r}, {msg.vy!r}, {msg.vz!r}) m/s beyond {_MAX_SPEED:g}"
    return None


def _global_position(msg: Any) -> str | None:
    if abs(msg.lat) > 90e7 or abs(msg.lon) > 180e7:
        return f"latitude/longitude ({msg.lat * 1e-7}, {msg.lon * 1e-7}) off the Earth"
    if not _within(msg.alt * 1e-3, *_MSL_M) or not _within(msg.relative_alt * 1e-3, *_ALT_M):
        return f"altitude ({msg.alt * 1e-3}, {msg.relative_alt * 1e-3} relative) m out of range"
    # 0..35999 cdeg; 36000 is 360.00 degrees rounded up (as the stand-in may): the same as 0
    if msg.hdg != 65535 and msg.hdg > 36000:
        return f"heading {msg.hdg * 0.01} deg"
    return None


def _vfr_hud(msg: Any) -> str | None:
    if not _within(msg.heading, -360, 360):
        return f"heading {msg.heading} deg"
    if not _finite(msg.alt, msg.airspeed, msg.groundspeed, msg.climb):
        return "a speed or altitude that is not a number"
    return None


def _sys_status(msg: Any) -> str | None:
    if not -1 <= msg.battery_remaining <= 100:
        return f"battery remaining {msg.battery_remaining} %"
    return None


def _battery_status(msg: Any) -> str | None:
    if not -1 <= msg.battery_remaining <= 100:
        return f"battery remaining {msg.battery_remaining} %"
    return None


def _gps_raw(msg: Any) -> str | None:
    if msg.fix_type > mavlink2.GPS_FIX_TYPE_PPP:
        return f"GPS fix type {msg.fix_type}"
    if msg.satellites_visible != 255 and msg.satellites_visible > 100:
        return f"{msg.satellites_visible} satellites"
    return None


def _ekf_status(msg: Any) -> str | None:
    variances = (
        msg.velocity_variance,
        msg.pos_horiz_variance,
        msg.pos_vert_variance,
        msg.compass_variance,
        msg.terrain_alt_variance,
    )
    if not all(_within(v, 0.0, 1e6) for v in variances):
        return f"EKF variances {variances!r}"
    return None


def _rangefinder(msg: Any) -> str | None:
    if not _within(msg.distance, 0.0, _MAX_RANGE_M):
        return f"range {msg.distance!r} m"
    return None


_CHECKS: dict[str, Callable[[Any], str | None]] = {
    "HEARTBEAT": _heartbeat,
    "ATTITUDE": _attitude,
    "LOCAL_POSITION_NED": _local_position,
    "GLOBAL_POSITION_INT": _global_position,
    "VFR_HUD": _vfr_hud,
    "SYS_STATUS": _sys_status,
    "BATTERY_STATUS": _battery_status,
    "GPS_RAW_INT": _gps_raw,
    "EKF_STATUS_REPORT": _ekf_status,
    "RANGEFINDER": _rangefinder,
}


def implausible(msg: Any) -> str | None:
    """What is physically impossible about ``msg`` (a pymavlink message), or None.

    >>> from pymavlink.dialects.v20 import ardupilotmega as m
    >>> implausible(m.MAVLink_attitude_message(0, 0.1, -0.2, 3.0, 0, 0, 0)) is None
    True
    >>> implausible(m.MAVLink_attitude_message(0, -7.26e16, 0, 0, 0, 0, 0))
    'roll/pitch (-7.26e+16, 0) rad beyond +-pi'
    """
    check = _CHECKS.get(msg.get_type())
    return None if check is None else check(msg)
