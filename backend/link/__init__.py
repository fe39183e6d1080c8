"""The vehicle link: ArduCopter over MAVLink (pymavlink), with telemetry, commands and tlog.

>>> from backend.link import VehicleLink
>>> link = VehicleLink("tcp:127.0.0.1:5760", tlog_dir="data/tlogs")  # doctest: +SKIP
>>> link.start()  # doctest: +SKIP
>>> link.wait_until(lambda t: t.state == "up", timeout=10)  # doctest: +SKIP
>>> link.set_mode("GUIDED").ok  # doctest: +SKIP
"""

from backend.link.commands import CommandResult, is_reason_text, mav_result_name
from backend.link.connection import ConnectionSpec, TlogWriter, parse_url
from backend.link.modes import COPTER_MODES, mode_name, mode_number
from backend.link.state import EVENT_KINDS, LinkEvent, LinkState
from backend.link.streams import DEFAULT_STREAM_RATES_HZ
from backend.link.telemetry import (
    Attitude,
    Battery,
    EkfStatus,
    GlobalPosition,
    GpsStatus,
    StatusText,
    Telemetry,
    Vec3,
)
from backend.link.vehicle_link import VehicleLink

__all__ = [
    "COPTER_MODES",
    "DEFAULT_STREAM_RATES_HZ",
    "EVENT_KINDS",
    "Attitude",
    "Battery",
    "CommandResult",
    "ConnectionSpec",
    "EkfStatus",
    "GlobalPosition",
    "GpsStatus",
    "LinkEvent",
    "LinkState",
    "StatusText",
    "Telemetry",
    "TlogWriter",
    "Vec3",
    "VehicleLink",
    "is_reason_text",
    "mav_result_name",
    "mode_name",
    "mode_number",
    "parse_url",
]
