"""Asking the vehicle for telemetry: which messages, how often, and when to ask again.

ArduPilot sends telemetry only when a ground station asks. The modern way is
MAV_CMD_SET_MESSAGE_INTERVAL per message; older firmware (and some radios' firmware
forwarding) only knows REQUEST_DATA_STREAM with ArduPilot's stream groups. The
:class:`StreamRequester` tries the first, falls back to the second when it is refused
or nothing flows, and starts over whenever the stream stops (a vehicle reboot).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

#: Telemetry requested with SET_MESSAGE_INTERVAL once the link is up (message: Hz).
DEFAULT_STREAM_RATES_HZ: Mapping[str, float] = {
    "ATTITUDE": 20.0,
    "LOCAL_POSITION_NED": 20.0,
    "GLOBAL_POSITION_INT": 10.0,
    "VFR_HUD": 4.0,
    "SYS_STATUS": 2.0,
    "GPS_RAW_INT": 2.0,
    "EKF_STATUS_REPORT": 2.0,
    "BATTERY_STATUS": 1.0,
    "RC_CHANNELS": 2.0,
    "DISTANCE_SENSOR": 10.0,
}

#: The REQUEST_DATA_STREAM fallback: ArduPilot's stream groups carrying the messages above.
DATA_STREAMS_HZ: tuple[tuple[int, int], ...] = (
    (mavlink2.MAV_DATA_STREAM_EXTENDED_STATUS, 2),  # SYS_STATUS, GPS_RAW_INT
    (mavlink2.MAV_DATA_STREAM_POSITION, 10),  # GLOBAL_POSITION_INT, LOCAL_POSITION_NED
    (mavlink2.MAV_DATA_STREAM_EXTRA1, 20),  # ATTITUDE
    (mavlink2.MAV_DATA_STREAM_EXTRA2, 4),  # VFR_HUD
    (mavlink2.MAV_DATA_STREAM_EXTRA3, 2),  # EKF_STATUS_REPORT, BATTERY_STATUS, DISTANCE_SENSOR
    (mavlink2.MAV_DATA_STREAM_RC_CHANNELS, 2),
)

CHECK_S = 2.0  # how long to wait for ATTITUDE before the fallback request
STALE_S = 5.0  # ask again when ATTITUDE has been silent this long while the link is up

Action = Literal["intervals", "data_streams"]


def check_rates(rates: Mapping[str, float]) -> dict[str, float]:
    """Validate ``{message name: Hz}``; ``ValueError`` naming ``stream_rates_hz``."""
    out: dict[str, float] = {}
    for name, hz in rates.items():
        if not isinstance(name, str) or f"MAVLINK_MSG_ID_{name}" not in vars(mavlink2):
            raise ValueError(f"stream_rates_hz: {name!r} is not a MAVLink message")
        if isinstance(hz, bool) or not isinstance(hz, int | float) or not 0 < hz <= 400:
            raise ValueError(f"stream_rates_hz[{name!r}] must be in (0, 400] Hz, got {hz!r}")
        out[name] = float(hz)
    return out


def interval_messages(target: tuple[int, int], rates: Mapping[str, float]) -> list[Any]:
    """One COMMAND_LONG MAV_CMD_SET_MESSAGE_INTERVAL per message (interval in us)."""
    return [
        mavlink2.MAVLink_command_long_message(
            target[0],
            target[1],
            mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL,
            0,
            getattr(mavlink2, f"MAVLINK_MSG_ID_{name}"),
            round(1e6 / hz),
            0,
            0,
            0,
            0,
            0,
        )
        for name, hz in rates.items()
    ]


def data_stream_messages(target: tuple[int, int]) -> list[Any]:
    """REQUEST_DATA_STREAM (start) for each of :data:`DATA_STREAMS_HZ`."""
    return [
        mavlink2.MAVLink_request_data_stream_message(target[0], target[1], stream, hz, 1)
        for stream, hz in DATA_STREAMS_HZ
    ]


class StreamRequester:
    """When to ask for telemetry; the caller sends what :meth:`due` names.

    Not thread-safe by itself: one housekeeping thread calls :meth:`due`; other
    threads may only call :meth:`reset` and :meth:`refused` (single assignments).
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Start over (the link has just come up)."""
        self._requested_at: float | None = None
        self._fallback_sent = False
        self._refused = False

    def refused(self) -> None:
        """The vehicle refused a SET_MESSAGE_INTERVAL: use the fallback at once."""
        self._refused = True

    def due(self, now: float, last_attitude_rx: float | None) -> Action | None:
        """What to send now, given the monotonic time ATTITUDE last arrived (or None)."""
        requested = self._requested_at
        if requested is None:
            self._requested_at = now
            self._fallback_sent = False
            self._refused = False
            return "intervals"
        fresh = last_attitude_rx is not None and last_attitude_rx >= requested
        if not fresh:
            if not self._fallback_sent and (self._refused or now - requested > CHECK_S):
                self._fallback_sent = True
                return "data_streams"
            if now - requested > STALE_S:
                self._requested_at = now  # nothing at all: ask again both ways
                self._fallback_sent = False
                self._refused = False
                return "intervals"
            return None
        if last_attitude_rx is not None and now - last_attitude_rx > STALE_S:
            self._requested_at = now  # the stream stopped (a reboot?): ask again
            self._fallback_sent = False
            return "intervals"
        return None
