"""Command results, acknowledgement tracking, and the checked builders of outgoing messages.

The builders are pure: they validate their arguments (``ValueError`` naming the
parameter) and return the fields of one MAVLink message. :class:`AckTracker` pairs
COMMAND_ACKs with the command waiting for them and collects the vehicle's reasons (its
"PreArm:"/"Arm:"/mode STATUSTEXTs) that arrive while the command is in flight.
"""

from __future__ import annotations

import math
import re
import struct
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

# Results made up locally, when nothing came back from the vehicle.
LINK_DOWN = "LINK_DOWN"
TIMEOUT = "TIMEOUT"
INVALID_ARGUMENT = "INVALID_ARGUMENT"
SENT = "SENT"
SEND_FAILED = "SEND_FAILED"
MISMATCH = "MISMATCH"

#: param2 of MAV_CMD_COMPONENT_ARM_DISARM that forces (skips checks / disarms in flight).
FORCE_MAGIC = 21196

# STATUSTEXTs that explain a refusal. ArduCopter prefixes them like this: "PreArm: ...",
# "Arm: ...", "Disarm: ...", "Mode change to X failed: ...", "Flight mode change failed".
_REASON_RE = re.compile(
    r"^\s*(PreArm|Arm|Disarm|Mode|Flight mode|Takeoff|Land|RTL|Guided|Plnd|PrecLand)\b",
    re.IGNORECASE,
)


def is_reason_text(text: str) -> bool:
    """Whether a STATUSTEXT reads like the reason for a refused command.

    >>> is_reason_text("PreArm: Need Position Estimate")
    True
    >>> is_reason_text("EKF3 IMU0 is using GPS")
    False
    """
    return bool(_REASON_RE.match(text))


def mav_result_name(result: int) -> str:
    """Name of a MAV_RESULT without its prefix: 4 -> 'FAILED'."""
    entry = mavlink2.enums["MAV_RESULT"].get(int(result))
    if entry is None:
        return f"RESULT_{int(result)}"
    return entry.name.removeprefix("MAV_RESULT_")


@dataclass(frozen=True)
class CommandResult:
    """What became of one command.

    Attributes
    ----------
    ok : bool
        True when the vehicle accepted it (or, for fire-and-forget messages, when sent).
    command : str
        The command's name, e.g. ``"arm"``.
    result : int or None
        The COMMAND_ACK MAV_RESULT, or None when no acknowledgement applies.
    result_name : str
        ``"ACCEPTED"``, ``"FAILED"``, ... or a local outcome: ``"LINK_DOWN"``,
        ``"TIMEOUT"``, ``"INVALID_ARGUMENT"``, ``"SENT"``, ``"SEND_FAILED"``,
        ``"MISMATCH"``.
    reasons : tuple of str
        The vehicle's own STATUSTEXTs explaining a refusal, verbatim.
    detail : str
        One sentence for the operator.
    elapsed_s : float
        Time from sending to the outcome.
    """

    ok: bool
    command: str
    result: int | None
    result_name: str
    reasons: tuple[str, ...] = ()
    detail: str = ""
    elapsed_s: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable form."""
        return {
            "ok": self.ok,
            "command": self.command,
            "result": self.result,
            "result_name": self.result_name,
            "reasons": list(self.reasons),
            "detail": self.detail,
            "elapsed_s": self.elapsed_s,
        }


# --------------------------------------------------------------------------- tracking


@dataclass
class PendingCommand:
    """A command waiting for its COMMAND_ACK; filled in by the reader thread."""

    command_id: int
    name: str
    sent_at: float = field(default_factory=time.monotonic)
    ack_result: int | None = None
    acked_at: float | None = None
    progress: int | None = None
    acks: int = 0  # every COMMAND_ACK for this command id, retransmissions' included
    texts: list[tuple[int, str]] = field(default_factory=list)
    event: threading.Event = field(default_factory=threading.Event)


class AckTracker:
    """Pairs COMMAND_ACKs and STATUSTEXTs with the commands in flight (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._pending: list[PendingCommand] = []
        self.unmatched_acks: list[tuple[int, int]] = []  # (command, result), last few

    def begin(self, command_id: int, name: str) -> PendingCommand:
        """Register a command about to be sent."""
        pending = PendingCommand(command_id=int(command_id), name=name)
        with self._lock:
            self._pending.append(pending)
        return pending

    def end(self, pending: PendingCommand) -> None:
        """Forget a command (its result has been taken)."""
        with self._lock:
            if pending in self._pending:
                self._pending.remove(pending)

    def on_ack(self, command_id: int, result: int, progress: int = 0) -> bool:
        """Deliver a COMMAND_ACK; returns whether a waiting command took it."""
        matched = False
        with self._lock:
            for pending in self._pending:
                if pending.command_id != command_id:
                    continue
                matched = True
                pending.acks += 1
                if (
                    pending.ack_result is None
                    or pending.ack_result == mavlink2.MAV_RESULT_IN_PROGRESS
                ):
                    pending.ack_result = int(result)
                    pending.progress = int(progress)
                    pending.acked_at = time.monotonic()
                pending.event.set()
            if not matched:
                self.unmatched_acks = [*self.unmatched_acks[-19:], (command_id, int(result))]
        return matched

    def on_statustext(self, severity: int, text: str) -> None:
        """Offer a STATUSTEXT to every command in flight."""
        with self._lock:
            for pending in self._pending:
                pending.texts.append((int(severity), text))

    def abort_all(self) -> None:
        """Wake every waiter (the link went down or is closing)."""
        with self._lock:
            for pending in self._pending:
                pending.event.set()


def select_reasons(texts: list[tuple[int, str]]) -> tuple[str, ...]:
    """Pick the refusal reasons out of the texts seen while a command was in flight.

    Texts that read like reasons win; when there are none, warnings and worse
    (severity <= MAV_SEVERITY_WARNING) are taken instead, since a refusal with an
    unusual wording is still better shown than hidden. Duplicates are dropped.
    """
    chosen = [t for _, t in texts if is_reason_text(t)]
    if not chosen:
        chosen = [t for s, t in texts if s <= mavlink2.MAV_SEVERITY_WARNING]
    return tuple(dict.fromkeys(chosen))


# --------------------------------------------------------------------------- builders

_UINT16_MAX = 65535
_IGNORE_ACC = (
    mavlink2.POSITION_TARGET_TYPEMASK_AX_IGNORE
    | mavlink2.POSITION_TARGET_TYPEMASK_AY_IGNORE
    | mavlink2.POSITION_TARGET_TYPEMASK_AZ_IGNORE
)
_IGNORE_POS = (
    mavlink2.POSITION_TARGET_TYPEMASK_X_IGNORE
    | mavlink2.POSITION_TARGET_TYPEMASK_Y_IGNORE
    | mavlink2.POSITION_TARGET_TYPEMASK_Z_IGNORE
)
_IGNORE_VEL = (
    mavlink2.POSITION_TARGET_TYPEMASK_VX_IGNORE
    | mavlink2.POSITION_TARGET_TYPEMASK_VY_IGNORE
    | mavlink2.POSITION_TARGET_TYPEMASK_VZ_IGNORE
)
_IGNORE_YAW = mavlink2.POSITION_TARGET_TYPEMASK_YAW_IGNORE
_IGNORE_YAW_RATE = mavlink2.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE

#: frames accepted for velocity targets, by name.
VELOCITY_FRAMES: Mapping[str, int] = {
    "local_ned": mavlink2.MAV_FRAME_LOCAL_NED,
    "body_offset_ned": mavlink2.MAV_FRAME_BODY_OFFSET_NED,
}


def finite(value: Any, name: str) -> float:
    """Return ``value`` as a finite float or raise ``ValueError`` naming ``name``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def check_altitude(altitude_m: Any) -> float:
    """Validate a take-off altitude: finite and > 0 metres."""
    alt = finite(altitude_m, "altitude_m")
    if alt <= 0:
        raise ValueError(f"altitude_m must be > 0, got {altitude_m!r}")
    return alt


def position_target(north: Any, east: Any, down: Any, *, yaw_deg: Any = None) -> dict[str, Any]:
    """Fields of a SET_POSITION_TARGET_LOCAL_NED position target (MAV_FRAME_LOCAL_NED)."""
    x, y, z = finite(north, "north"), finite(east, "east"), finite(down, "down")
    mask = _IGNORE_VEL | _IGNORE_ACC | _IGNORE_YAW_RATE
    yaw = 0.0
    if yaw_deg is None:
        mask |= _IGNORE_YAW
    else:
        yaw = math.radians(finite(yaw_deg, "yaw_deg"))
    return {
        "coordinate_frame": mavlink2.MAV_FRAME_LOCAL_NED,
        "type_mask": mask,
        "x": x,
        "y": y,
        "z": z,
        "vx": 0.0,
        "vy": 0.0,
        "vz": 0.0,
        "afx": 0.0,
        "afy": 0.0,
        "afz": 0.0,
        "yaw": yaw,
        "yaw_rate": 0.0,
    }


def velocity_target(
    vn: Any, ve: Any, vd: Any, *, yaw_rate_dps: Any = None, frame: str = "local_ned"
) -> dict[str, Any]:
    """Fields of a SET_POSITION_TARGET_LOCAL_NED velocity target.

    ``frame`` is ``"local_ned"`` (north/east/down) or ``"body_offset_ned"``
    (forward/right/down relative to the vehicle's heading).
    """
    if frame not in VELOCITY_FRAMES:
        raise ValueError(f"frame must be one of {sorted(VELOCITY_FRAMES)}, got {frame!r}")
    vx, vy, vz = finite(vn, "vn"), finite(ve, "ve"), finite(vd, "vd")
    mask = _IGNORE_POS | _IGNORE_ACC | _IGNORE_YAW
    rate = 0.0
    if yaw_rate_dps is None:
        mask |= _IGNORE_YAW_RATE
    else:
        rate = math.radians(finite(yaw_rate_dps, "yaw_rate_dps"))
    return {
        "coordinate_frame": VELOCITY_FRAMES[frame],
        "type_mask": mask,
        "x": 0.0,
        "y": 0.0,
        "z": 0.0,
        "vx": vx,
        "vy": vy,
        "vz": vz,
        "afx": 0.0,
        "afy": 0.0,
        "afz": 0.0,
        "yaw": 0.0,
        "yaw_rate": rate,
    }


#: PWM values accepted for an RC override besides 0 (release) and 65535 (ignore).
RC_PWM_RANGE = (800, 2200)


def rc_override_channels(channels: Mapping[int, int]) -> list[int]:
    """The 18 chanN_raw values of RC_CHANNELS_OVERRIDE for ``{channel: pwm}``.

    Channels are 1-based (1..18). ``pwm`` 0 releases the channel to the radio, 65535
    leaves it as it is, anything else must lie in 800..2200 us. Channels not named are
    left as they are. MAVLink spells 'release' and 'ignore' differently for channels
    9..18 (65534 and 0); this function does the translation.
    """
    if not isinstance(channels, Mapping) or not channels:
        raise ValueError("channels must be a non-empty mapping {channel: pwm}")
    values = [_UINT16_MAX] * 8 + [0] * 10
    for channel, pwm in channels.items():
        if isinstance(channel, bool) or not isinstance(channel, int) or not 1 <= channel <= 18:
            raise ValueError(f"channels: channel must be an int in 1..18, got {channel!r}")
        if isinstance(pwm, bool) or not isinstance(pwm, int):
            raise ValueError(f"channels: pwm for channel {channel} must be an int, got {pwm!r}")
        low, high = RC_PWM_RANGE
        if pwm not in (0, _UINT16_MAX) and not low <= pwm <= high:
            raise ValueError(
                f"channels: pwm for channel {channel} must be 0 (release), 65535 (ignore) "
                f"or {low}..{high}, got {pwm}"
            )
        if channel <= 8:
            values[channel - 1] = pwm
        elif pwm == 0:
            values[channel - 1] = _UINT16_MAX - 1  # release, channels 9..18
        elif pwm == _UINT16_MAX:
            values[channel - 1] = 0  # ignore, channels 9..18
        else:
            values[channel - 1] = pwm
    return values


def landing_target(
    x: Any,
    y: Any,
    z: Any,
    *,
    time_usec: Any,
    distance: Any = None,
    frame: int = mavlink2.MAV_FRAME_BODY_FRD,
    target_num: int = 0,
    size_x: Any = 0.0,
    size_y: Any = 0.0,
    target_type: int = mavlink2.LANDING_TARGET_TYPE_VISION_FIDUCIAL,
) -> dict[str, Any]:
    """Fields of a LANDING_TARGET with ``position_valid`` = 1.

    ``x, y, z`` in metres in ``frame`` (ArduCopter accepts MAV_FRAME_BODY_FRD only:
    forward, right, down from the vehicle), ``time_usec`` the capture time of the
    frame the target was seen in, ``distance`` defaults to the norm of ``(x, y, z)``.
    The angle fields are filled in as well, for consumers that read them.
    """
    fx, fy, fz = finite(x, "x"), finite(y, "y"), finite(z, "z")
    time_usec = check_time_usec(time_usec)
    if frame not in mavlink2.enums["MAV_FRAME"]:
        raise ValueError(f"frame must be a MAV_FRAME value, got {frame!r}")
    if distance is None:
        dist = math.sqrt(fx * fx + fy * fy + fz * fz)
    else:
        dist = finite(distance, "distance")
    if dist <= 0:
        raise ValueError(f"distance must be > 0, got {dist!r}")
    if not 0 <= int(target_num) <= 255:
        raise ValueError(f"target_num must be in 0..255, got {target_num!r}")
    # angles of the line of sight as ArduPilot defines them for position_valid=0
    angle_x = math.atan2(fy, fz) if fz > 0 else 0.0
    angle_y = -math.atan2(fx, fz) if fz > 0 else 0.0
    return {
        "time_usec": time_usec,
        "target_num": int(target_num),
        "frame": int(frame),
        "angle_x": angle_x,
        "angle_y": angle_y,
        "distance": dist,
        "size_x": finite(size_x, "size_x"),
        "size_y": finite(size_y, "size_y"),
        "x": fx,
        "y": fy,
        "z": fz,
        "q": [1.0, 0.0, 0.0, 0.0],
        "type": int(target_type),
        "position_valid": 1,
    }


def check_time_usec(time_usec: Any) -> int:
    """Validate a timestamp in microseconds: a non-negative int that fits in 64 bits."""
    if isinstance(time_usec, bool) or not isinstance(time_usec, int) or time_usec < 0:
        raise ValueError(f"time_usec must be a non-negative int, got {time_usec!r}")
    if time_usec >= 2**64:
        raise ValueError(f"time_usec must fit in 64 bits, got {time_usec!r}")
    return time_usec


#: MAV_CMD_SET_EKF_SOURCE_SET's source sets (EK3_SRC1_* .. EK3_SRC3_*).
EKF_SOURCE_SETS = (1, 2, 3)


def check_source_set(number: Any) -> int:
    """Validate an EKF source set number: 1, 2 or 3."""
    if isinstance(number, bool) or not isinstance(number, int) or number not in EKF_SOURCE_SETS:
        raise ValueError(f"source_set must be 1, 2 or 3, got {number!r}")
    return number


def _check_reset_counter(reset_counter: Any) -> int:
    if (
        isinstance(reset_counter, bool)
        or not isinstance(reset_counter, int)
        or not 0 <= reset_counter <= 255
    ):
        raise ValueError(f"reset_counter must be an int in 0..255, got {reset_counter!r}")
    return reset_counter


def vision_position_estimate(
    north: Any,
    east: Any,
    down: Any,
    roll: Any,
    pitch: Any,
    yaw: Any,
    *,
    time_usec: Any,
    reset_counter: Any = 0,
) -> dict[str, Any]:
    """Fields of a VISION_POSITION_ESTIMATE: the vehicle's position (m, NED of the EKF's
    origin: ArduPilot resets its estimate to it on a source switch) and attitude (rad),
    ``time_usec`` the frame's capture time on the vehicle's clock (ArduPilot corrects
    the transport jitter against its own clock). The covariance is unknown (NaN first
    element): ArduPilot then uses VISO_POS_M_NSE / VISO_YAW_M_NSE.
    """
    values = [
        finite(v, n)
        for v, n in (
            (north, "north"),
            (east, "east"),
            (down, "down"),
            (roll, "roll"),
            (pitch, "pitch"),
            (yaw, "yaw"),
        )
    ]
    return {
        "usec": check_time_usec(time_usec),
        "x": values[0],
        "y": values[1],
        "z": values[2],
        "roll": values[3],
        "pitch": values[4],
        "yaw": values[5],
        "covariance": [math.nan] + [0.0] * 20,
        "reset_counter": _check_reset_counter(reset_counter),
    }


def vision_speed_estimate(
    vn: Any, ve: Any, vd: Any, *, time_usec: Any, reset_counter: Any = 0
) -> dict[str, Any]:
    """Fields of a VISION_SPEED_ESTIMATE: the vehicle's velocity (m/s, NED), stamped like
    :func:`vision_position_estimate`; unknown covariance (VISO_VEL_M_NSE applies)."""
    return {
        "usec": check_time_usec(time_usec),
        "x": finite(vn, "vn"),
        "y": finite(ve, "ve"),
        "z": finite(vd, "vd"),
        "covariance": [math.nan] + [0.0] * 8,
        "reset_counter": _check_reset_counter(reset_counter),
    }


def check_param_name(name: Any) -> str:
    """Validate a parameter name: 1..16 printable ASCII characters."""
    if not isinstance(name, str) or not 1 <= len(name) <= 16:
        raise ValueError(f"name must be a parameter name of 1..16 characters, got {name!r}")
    if not name.isascii() or not name.isprintable() or " " in name:
        raise ValueError(f"name must be printable ASCII without spaces, got {name!r}")
    return name


def as_float32(value: float) -> float:
    """The value a MAVLink float field carries for ``value``."""
    return struct.unpack("<f", struct.pack("<f", value))[0]
