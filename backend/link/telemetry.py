"""The vehicle's telemetry as one immutable snapshot, and the handlers that update it.

Each handler is a pure function ``(msg, rx_monotonic) -> dict of changed fields``; the
link applies the changes with :func:`dataclasses.replace` so readers always see a whole,
consistent snapshot. Handlers raise on malformed messages and the link counts that,
so one bad message can never stall the link.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields, is_dataclass
from typing import Any, NamedTuple

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link.modes import mode_name
from backend.link.state import LinkState

#: How many recent STATUSTEXTs a snapshot keeps.
STATUSTEXT_HISTORY = 50
#: The vehicle's clock going back by more than this (ms) is a reboot (a reordered
#: message is a few ms behind at most).
REBOOT_BACKSTEP_MS = 1000
#: LOCAL_POSITION_NED silent this long on the vehicle's own clock is stale (ms), unless
#: three intervals of the rate asked for are longer: ArduCopter stops sending it when the
#: EKF loses its position (an EKF failsafe) and only starts ~41 s into a boot.
POSITION_STALE_MS = 1500
#: The messages that carry the vehicle's clock (time_boot_ms): the pose streams ArduPilot
#: fills from one clock. (Others, e.g. a DISTANCE_SENSOR from a driver, may send 0.)
CLOCK_MESSAGES = frozenset({"ATTITUDE", "LOCAL_POSITION_NED", "GLOBAL_POSITION_INT", "SYSTEM_TIME"})

# SYS_STATUS bit that ArduPilot sets in onboard_control_sensors_health when the
# pre-arm checks pass (MAV_SYS_STATUS_PREARM_CHECK).
_PREARM_BIT = mavlink2.MAV_SYS_STATUS_PREARM_CHECK
_UINT16_MAX = 65535

# EKF_STATUS_REPORT flags (EKF_STATUS_FLAGS).
_EKF_ATTITUDE = mavlink2.EKF_ATTITUDE
_EKF_VEL_HORIZ = mavlink2.EKF_VELOCITY_HORIZ
_EKF_POS_HORIZ_REL = mavlink2.EKF_POS_HORIZ_REL
_EKF_POS_HORIZ_ABS = mavlink2.EKF_POS_HORIZ_ABS
_EKF_POS_VERT_ABS = mavlink2.EKF_POS_VERT_ABS
_EKF_CONST_POS_MODE = mavlink2.EKF_CONST_POS_MODE
_EKF_UNINITIALIZED = mavlink2.EKF_UNINITIALIZED
# ArduCopter's EKF failsafe threshold (FS_EKF_THRESH default): variances above it are bad.
_EKF_VARIANCE_LIMIT = 0.8


@dataclass(frozen=True)
class Attitude:
    """Euler angles (rad) and body rates (rad/s) from ATTITUDE."""

    roll: float
    pitch: float
    yaw: float
    rollspeed: float
    pitchspeed: float
    yawspeed: float


@dataclass(frozen=True)
class Vec3:
    """A vector in the local NED frame (metres or metres per second)."""

    x: float
    y: float
    z: float


@dataclass(frozen=True)
class GlobalPosition:
    """WGS84 position from GLOBAL_POSITION_INT."""

    lat_deg: float
    lon_deg: float
    alt_msl_m: float


@dataclass(frozen=True)
class GpsStatus:
    """GPS_RAW_INT summary; ``None`` where the receiver reports 'unknown'."""

    fix_type: int
    satellites: int | None
    hdop: float | None


@dataclass(frozen=True)
class EkfStatus:
    """EKF_STATUS_REPORT summary.

    ``healthy``: attitude, horizontal velocity, relative horizontal and absolute vertical
    position are all valid, the filter is initialised and every variance is below 0.8
    (ArduCopter's FS_EKF_THRESH). ``pos_horiz_ok``: an absolute horizontal position
    estimate exists and the filter is not in constant-position mode (what GUIDED needs).
    """

    flags: int
    healthy: bool
    pos_horiz_ok: bool


@dataclass(frozen=True)
class Battery:
    """Battery state; ``None`` where the vehicle reports 'unknown'."""

    voltage_v: float | None
    current_a: float | None
    remaining_pct: int | None


class StatusText(NamedTuple):
    """One STATUSTEXT: UNIX receive time, MAV_SEVERITY, text."""

    time: float
    severity: int
    text: str


@dataclass(frozen=True)
class Telemetry:
    """One immutable snapshot of everything the link knows about the vehicle.

    Fields are ``None`` until the vehicle has reported them. Time stamps: the
    ``*_time_boot_ms`` fields are the vehicle's clock, the ``*_rx_monotonic`` fields
    this process's :func:`time.monotonic` when the message arrived.
    """

    state: LinkState = LinkState.CONNECTING
    vehicle_sysid: int | None = None
    armed: bool = False
    mode: str | None = None
    mode_number: int | None = None
    system_status: int | None = None
    attitude: Attitude | None = None
    position_ned: Vec3 | None = None
    velocity_ned: Vec3 | None = None
    relative_alt_m: float | None = None
    global_position: GlobalPosition | None = None
    heading_deg: float | None = None
    gps: GpsStatus | None = None
    ekf: EkfStatus | None = None
    battery: Battery | None = None
    rangefinder_m: float | None = None
    prearm_ok: bool | None = None
    statustexts: tuple[StatusText, ...] = ()
    # link quality
    msgs_per_s: float = 0.0
    crc_errors: int = 0
    heartbeat_age_s: float | None = None
    packets_lost_pct: float = 0.0
    handler_errors: int = 0
    #: Messages dropped because their values cannot be real (link.plausibility).
    implausible: int = 0
    last_implausible: str | None = None
    reconnects: int = 0
    last_error: str | None = None
    # time stamps of the pose messages, for latency-aware consumers
    attitude_time_boot_ms: int | None = None
    attitude_rx_monotonic: float | None = None
    local_position_time_boot_ms: int | None = None
    local_position_rx_monotonic: float | None = None
    # the vehicle's clock (time_boot_ms of its latest time-stamped message) and what
    # was counted: reboots seen (the clock went back: every vehicle field was reset),
    # HEARTBEATs (a command's effect is confirmed by one that came after its
    # COMMAND_ACK) and STATUSTEXTs (an index into the texts that came since a moment)
    vehicle_time_boot_ms: int | None = None
    boots: int = 0
    heartbeats: int = 0
    statustexts_received: int = 0
    #: A HEARTBEAT came after the latest accepted command that changes the armed state or
    #: mode (ArduCopter's heartbeat is 1 Hz: until then ``armed``/``mode`` are the old ones).
    state_confirmed: bool = False
    #: LOCAL_POSITION_NED stopped: ``position_ned`` and ``velocity_ned`` were dropped.
    position_stale: bool = False
    # what the GCS sent for precision landing (ArduPilot reports nothing back)
    landing_targets_sent: int = 0
    last_landing_target: dict[str, float] | None = None

    @property
    def position_ready(self) -> bool:
        """The EKF has a horizontal position: LOCAL_POSITION_NED is current and
        EKF_STATUS_REPORT says so. What GUIDED needs to arm and fly."""
        return self.position_ned is not None and self.ekf is not None and self.ekf.pos_horiz_ok

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable form (non-finite floats become ``None``)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "statustexts":
                out[f.name] = [
                    {"time": s.time, "severity": s.severity, "text": s.text} for s in value
                ]
            else:
                out[f.name] = _jsonable(value)
        return out


def _jsonable(value: Any) -> Any:
    if isinstance(value, LinkState):
        return value.value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if is_dataclass(value) and not isinstance(value, type):
        return {f.name: _jsonable(getattr(value, f.name)) for f in fields(value)}
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


#: Commands whose acceptance makes the HEARTBEAT's armed flag and mode out of date.
STATE_COMMANDS = frozenset(
    {
        mavlink2.MAV_CMD_COMPONENT_ARM_DISARM,
        mavlink2.MAV_CMD_DO_SET_MODE,
        mavlink2.MAV_CMD_NAV_TAKEOFF,
        mavlink2.MAV_CMD_NAV_LAND,
        mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH,
    }
)

#: What the vehicle reported, forgotten when it reboots (the link's own figures, the
#: texts and what the GCS sent stay).
_VEHICLE_FIELDS = (
    "armed",
    "mode",
    "mode_number",
    "system_status",
    "attitude",
    "position_ned",
    "velocity_ned",
    "relative_alt_m",
    "global_position",
    "heading_deg",
    "gps",
    "ekf",
    "battery",
    "rangefinder_m",
    "prearm_ok",
    "attitude_time_boot_ms",
    "attitude_rx_monotonic",
    "local_position_time_boot_ms",
    "local_position_rx_monotonic",
    "position_stale",
    "state_confirmed",
)
_DEFAULTS = {f.name: f.default for f in fields(Telemetry)}


def clock_changes(
    tel: Telemetry, boot_ms: int, stale_ms: float, *, reboot_asked: bool = False
) -> dict[str, Any]:
    """What the vehicle's clock reading ``boot_ms`` changes in ``tel``.

    Going back is a reboot: every vehicle field returns to "not reported" (a position
    from before the reboot is not where the new boot thinks it is). Going on past
    ``stale_ms`` since the latest LOCAL_POSITION_NED drops the position.
    ``reboot_asked``: a reboot was accepted and its new boot not yet heard; then the
    clock going back by half counts too (a boot rebooted a second after it began goes
    back less than ``REBOOT_BACKSTEP_MS``; a reordered message of the old boot, a few
    ms behind, does not go back by half).
    """
    last = tel.vehicle_time_boot_ms
    step = REBOOT_BACKSTEP_MS
    if reboot_asked and last is not None:
        step = min(step, last // 2)
    if last is not None and boot_ms < last - step:
        changes: dict[str, Any] = {name: _DEFAULTS[name] for name in _VEHICLE_FIELDS}
        changes.update(vehicle_time_boot_ms=boot_ms, boots=tel.boots + 1)
        return changes
    changes = {"vehicle_time_boot_ms": boot_ms if last is None else max(last, boot_ms)}
    stamp = tel.local_position_time_boot_ms
    if tel.position_ned is not None and stamp is not None and boot_ms - stamp > stale_ms:
        changes.update(position_ned=None, velocity_ned=None, position_stale=True)
    return changes


# --------------------------------------------------------------------------- handlers


def _on_heartbeat(msg: Any, now: float) -> dict[str, Any]:
    custom = bool(msg.base_mode & mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
    number = int(msg.custom_mode) if custom else None
    return {
        "armed": bool(msg.base_mode & mavlink2.MAV_MODE_FLAG_SAFETY_ARMED),
        "mode_number": number,
        "mode": mode_name(number),
        "system_status": int(msg.system_status),
        "vehicle_sysid": msg.get_srcSystem(),
    }


def _on_attitude(msg: Any, now: float) -> dict[str, Any]:
    return {
        "attitude": Attitude(
            float(msg.roll),
            float(msg.pitch),
            float(msg.yaw),
            float(msg.rollspeed),
            float(msg.pitchspeed),
            float(msg.yawspeed),
        ),
        "attitude_time_boot_ms": int(msg.time_boot_ms),
        "attitude_rx_monotonic": now,
    }


def _on_local_position(msg: Any, now: float) -> dict[str, Any]:
    return {
        "position_ned": Vec3(float(msg.x), float(msg.y), float(msg.z)),
        "velocity_ned": Vec3(float(msg.vx), float(msg.vy), float(msg.vz)),
        "local_position_time_boot_ms": int(msg.time_boot_ms),
        "local_position_rx_monotonic": now,
        "position_stale": False,
    }


def _on_global_position(msg: Any, now: float) -> dict[str, Any]:
    changes: dict[str, Any] = {
        "global_position": GlobalPosition(msg.lat * 1e-7, msg.lon * 1e-7, msg.alt * 1e-3),
        "relative_alt_m": msg.relative_alt * 1e-3,
    }
    if msg.hdg != _UINT16_MAX:
        changes["heading_deg"] = msg.hdg * 0.01
    return changes


def _on_vfr_hud(msg: Any, now: float) -> dict[str, Any]:
    # GLOBAL_POSITION_INT.hdg is the primary source; VFR_HUD keeps the heading shown
    # when only the extra streams are requested.
    return {"heading_deg": float(msg.heading)}


def _on_sys_status(msg: Any, now: float) -> dict[str, Any]:
    present = bool(msg.onboard_control_sensors_present & _PREARM_BIT)
    return {
        "prearm_ok": bool(msg.onboard_control_sensors_health & _PREARM_BIT) if present else None,
        "battery": Battery(
            voltage_v=None if msg.voltage_battery == _UINT16_MAX else msg.voltage_battery * 1e-3,
            current_a=None if msg.current_battery == -1 else msg.current_battery * 1e-2,
            remaining_pct=None if msg.battery_remaining == -1 else int(msg.battery_remaining),
        ),
    }


def _on_battery_status(msg: Any, now: float) -> dict[str, Any]:
    if msg.id != 0:  # only the first battery is shown
        return {}
    cells = [v for v in msg.voltages if v != _UINT16_MAX]
    return {
        "battery": Battery(
            voltage_v=sum(cells) * 1e-3 if cells else None,
            current_a=None if msg.current_battery == -1 else msg.current_battery * 1e-2,
            remaining_pct=None if msg.battery_remaining == -1 else int(msg.battery_remaining),
        )
    }


def _on_gps_raw(msg: Any, now: float) -> dict[str, Any]:
    return {
        "gps": GpsStatus(
            fix_type=int(msg.fix_type),
            satellites=None if msg.satellites_visible == 255 else int(msg.satellites_visible),
            hdop=None if msg.eph == _UINT16_MAX else msg.eph * 0.01,
        )
    }


def _on_ekf_status(msg: Any, now: float) -> dict[str, Any]:
    flags = int(msg.flags)
    needed = _EKF_ATTITUDE | _EKF_VEL_HORIZ | _EKF_POS_HORIZ_REL | _EKF_POS_VERT_ABS
    variances = (
        msg.velocity_variance,
        msg.pos_horiz_variance,
        msg.pos_vert_variance,
        msg.compass_variance,
    )
    healthy = (
        flags & needed == needed
        and not flags & _EKF_UNINITIALIZED
        and all(math.isfinite(v) and v < _EKF_VARIANCE_LIMIT for v in variances)
    )
    pos_ok = bool(flags & _EKF_POS_HORIZ_ABS) and not flags & _EKF_CONST_POS_MODE
    return {"ekf": EkfStatus(flags=flags, healthy=bool(healthy), pos_horiz_ok=pos_ok)}


def _on_distance_sensor(msg: Any, now: float) -> dict[str, Any]:
    if msg.orientation != mavlink2.MAV_SENSOR_ROTATION_PITCH_270:  # only the downward one
        return {}
    in_range = msg.min_distance <= msg.current_distance <= msg.max_distance
    return {"rangefinder_m": msg.current_distance * 0.01 if in_range else None}


def _on_rangefinder(msg: Any, now: float) -> dict[str, Any]:
    return {"rangefinder_m": float(msg.distance)}


Handler = Callable[[Any, float], dict[str, Any]]

#: MAVLink message type -> handler updating the snapshot.
TELEMETRY_HANDLERS: dict[str, Handler] = {
    "HEARTBEAT": _on_heartbeat,
    "ATTITUDE": _on_attitude,
    "LOCAL_POSITION_NED": _on_local_position,
    "GLOBAL_POSITION_INT": _on_global_position,
    "VFR_HUD": _on_vfr_hud,
    "SYS_STATUS": _on_sys_status,
    "BATTERY_STATUS": _on_battery_status,
    "GPS_RAW_INT": _on_gps_raw,
    "EKF_STATUS_REPORT": _on_ekf_status,
    "DISTANCE_SENSOR": _on_distance_sensor,
    "RANGEFINDER": _on_rangefinder,
}


class StatusTextAssembler:
    """Joins MAVLink 2 STATUSTEXT chunks (``id`` != 0) into whole texts.

    A text longer than 50 characters arrives as chunks sharing an ``id``; the last
    chunk is shorter than 50 characters. Single-message texts (``id`` == 0) pass
    straight through. An unfinished text is given up when a new id starts.
    """

    _CHUNK = 50

    def __init__(self) -> None:
        self._parts: dict[tuple[int, int], list[str]] = {}

    def feed(self, msg: Any) -> str | None:
        """Return the complete text, or None while a chunked text is incomplete."""
        text = str(msg.text)
        chunk_id = int(getattr(msg, "id", 0) or 0)
        if chunk_id == 0:
            return text
        key = (msg.get_srcSystem(), chunk_id)
        # a different id from the same sender means the older one will never finish
        for other in [k for k in self._parts if k[0] == key[0] and k != key]:
            del self._parts[other]
        parts = self._parts.setdefault(key, [])
        parts.append(text)
        if len(text) < self._CHUNK or len(parts) > 20:
            del self._parts[key]
            return "".join(parts)
        return None
