"""Fuzzing the MAVLink link: a "vehicle" on TCP that sends garbage among its heartbeats.

Inputs (one each, at random): random bytes; a well-formed frame of any message of the
dialect with a random payload; one of the station's own telemetry types with extreme
field values (NaN, infinities, type limits); a mutated frame (bits flipped, cut,
lengthened); a MAVLink 1 frame; a heartbeat with random fields; a frame from another
system. A real :class:`~backend.link.VehicleLink` reads them. Afterwards a marker
ATTITUDE proves it still parses, and no telemetry snapshot taken along the way may
show an impossible value.
"""

from __future__ import annotations

import math
import random
import re
import select
import socket
import struct
import threading
import time
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import LinkState, Telemetry, VehicleLink
from bench.fuzz.watch import Watch

VEHICLE = (1, 1)
MARKER_MS = 0xC0FFEE
_MESSAGES = sorted(mavlink2.mavlink_map.items())
_STATION_TYPES = [
    mavlink2.MAVLink_heartbeat_message,
    mavlink2.MAVLink_attitude_message,
    mavlink2.MAVLink_local_position_ned_message,
    mavlink2.MAVLink_global_position_int_message,
    mavlink2.MAVLink_vfr_hud_message,
    mavlink2.MAVLink_sys_status_message,
    mavlink2.MAVLink_battery_status_message,
    mavlink2.MAVLink_gps_raw_int_message,
    mavlink2.MAVLink_ekf_status_report_message,
    mavlink2.MAVLink_distance_sensor_message,
    mavlink2.MAVLink_rangefinder_message,
    mavlink2.MAVLink_statustext_message,
    mavlink2.MAVLink_command_ack_message,
    mavlink2.MAVLink_param_value_message,
    mavlink2.MAVLink_rc_channels_message,
]
_FLOATS = (math.nan, math.inf, -math.inf, 3.4e38, -7.26e16, 0.0, 1e-45, -1.0, 1e9)
_INT_RANGES = {
    "b": (-128, 127),
    "B": (0, 255),
    "h": (-32768, 32767),
    "H": (0, 65535),
    "i": (-(2**31), 2**31 - 1),
    "I": (0, 2**32 - 1),
    "q": (-(2**63), 2**63 - 1),
    "Q": (0, 2**64 - 1),
}


def frame(
    msgid: int, crc_extra: int, payload: bytes, *, src: tuple[int, int], seq: int, v1: bool = False
) -> bytes:
    """A MAVLink frame with a correct checksum around ``payload``."""
    if v1:
        header = struct.pack("<BBBBBB", 0xFE, len(payload), seq, src[0], src[1], msgid & 0xFF)
    else:
        header = struct.pack(
            "<BBBBBBBHB", 0xFD, len(payload), 0, 0, seq, src[0], src[1], msgid & 0xFFFF, msgid >> 16
        )
    crc = mavlink2.x25crc(header[1:] + payload)
    crc.accumulate(struct.pack("B", crc_extra))
    return header + payload + struct.pack("<H", crc.crc)


def _extreme(code: str, rng: random.Random) -> Any:
    if code in "fd":
        return rng.choice(_FLOATS) if rng.random() < 0.8 else rng.uniform(-1e6, 1e6)
    low, high = _INT_RANGES[code]
    return rng.choice((low, high, 0, max(low, -1), rng.randint(low, high)))


def extreme_payload(cls: Any, rng: random.Random) -> bytes:
    """A payload for message class ``cls`` with extreme values in every field."""
    fmt = cls.unpacker.format
    values: list[Any] = []
    for count, code in re.findall(r"(\d*)([a-zA-Z])", fmt[1:]):
        n = int(count or 1)
        if code == "s":
            values.append(rng.randbytes(n))
        else:
            values.extend(_extreme(code, rng) for _ in range(n))
    return struct.pack(fmt, *values)


class Inputs:
    """The fuzzed byte strings, one :meth:`next` at a time."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.seq = 0
        self.kinds: dict[str, int] = {}

    def _frame(self, msgid: int, crc: int, payload: bytes, **kw: Any) -> bytes:
        self.seq = (self.seq + 1) % 256
        return frame(msgid, crc, payload, seq=self.seq, **{"src": VEHICLE, **kw})

    def heartbeat(self) -> bytes:
        msg = mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_QUADROTOR,
            mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
            mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            4,
            mavlink2.MAV_STATE_ACTIVE,
            3,
        )
        cls = type(msg)
        return self._frame(cls.id, cls.crc_extra, msg.pack(mavlink2.MAVLink(None))[10:-2])

    def next(self) -> bytes:
        rng = self.rng
        roll = rng.random()
        if roll < 0.15:
            kind, data = "random_bytes", rng.randbytes(rng.randint(1, 300))
        elif roll < 0.40:
            msgid, cls = rng.choice(_MESSAGES)
            size = struct.calcsize(cls.unpacker.format)
            payload = rng.randbytes(rng.randint(1, size) if rng.random() < 0.3 else size)
            kind, data = "random_frame", self._frame(msgid, cls.crc_extra, payload)
        elif roll < 0.70:
            cls = rng.choice(_STATION_TYPES)
            payload = extreme_payload(cls, rng)
            kind, data = "extreme_values", self._frame(cls.id, cls.crc_extra, payload)
        elif roll < 0.85:
            msgid, cls = rng.choice(_MESSAGES)
            size = struct.calcsize(cls.unpacker.format)
            good = bytearray(self._frame(msgid, cls.crc_extra, rng.randbytes(size)))
            how = rng.random()
            if how < 0.5:
                for _ in range(rng.randint(1, 4)):
                    good[rng.randrange(len(good))] ^= 1 << rng.randrange(8)
            elif how < 0.75:
                del good[rng.randrange(1, len(good)) :]
            else:
                good[1] = rng.randrange(256)  # the length byte lies
            kind, data = "mutated_frame", bytes(good)
        elif roll < 0.92:
            msgid, cls = rng.choice([(i, c) for i, c in _MESSAGES if i < 256])
            size = struct.calcsize(cls.unpacker.format)
            kind, data = "v1_frame", self._frame(msgid, cls.crc_extra, rng.randbytes(size), v1=True)
        else:
            msgid, cls = rng.choice(_MESSAGES)
            size = struct.calcsize(cls.unpacker.format)
            src = (rng.randrange(256), rng.randrange(256))
            kind, data = (
                "foreign_frame",
                self._frame(msgid, cls.crc_extra, rng.randbytes(size), src=src),
            )
        self.kinds[kind] = self.kinds.get(kind, 0) + 1
        return data


def shown_problems(tel: Telemetry) -> list[str]:
    """Impossible values a telemetry snapshot shows (none, if the link filters)."""
    out = []
    a = tel.attitude
    if a is not None and not (abs(a.roll) <= 3.2 and abs(a.pitch) <= 3.2 and abs(a.yaw) <= 6.3):
        out.append(f"attitude {a}")
    p = tel.position_ned
    if p is not None and not all(math.isfinite(v) and abs(v) <= 1e5 for v in (p.x, p.y, p.z)):
        out.append(f"position {p}")
    if tel.mode_number is not None and not 0 <= tel.mode_number <= 255:
        out.append(f"mode {tel.mode_number}")
    b = tel.battery
    if b is not None and b.remaining_pct is not None and not -1 <= b.remaining_pct <= 100:
        out.append(f"battery {b.remaining_pct}")
    if tel.gps is not None and tel.gps.fix_type > 8:
        out.append(f"gps fix {tel.gps.fix_type}")
    return out


def run(n: int, seed: int) -> dict[str, Any]:
    """Send ``n`` fuzzed inputs to a real link; what it made of them."""
    rng = random.Random(seed)
    inputs = Inputs(rng)
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", 0))
    listener.listen(1)
    stop = threading.Event()
    t0 = time.perf_counter()
    problems: list[str] = []
    with Watch() as watch:
        link = VehicleLink(
            f"tcp:127.0.0.1:{listener.getsockname()[1]}",
            heartbeat_timeout_s=60.0,
            command_timeout_s=1.0,
            stream_rates_hz={},
        )
        link.start()
        conn, _ = listener.accept()
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

        def drain() -> None:  # what the link sends us (heartbeats) is read and dropped
            while not stop.is_set():
                ready, _, _ = select.select([conn], [], [], 0.1)
                if ready and not conn.recv(65536):
                    return

        drainer = threading.Thread(target=drain, name="fuzz-drain", daemon=True)
        drainer.start()
        try:
            conn.sendall(inputs.heartbeat())
            if not link.wait_until(lambda t: t.state == LinkState.UP, 10.0):
                raise RuntimeError("the link did not come up")
            for i in range(n):
                conn.sendall(inputs.next())
                if i % 50 == 49:
                    conn.sendall(inputs.heartbeat())
                    problems += shown_problems(link.telemetry)
            marker = mavlink2.MAVLink_attitude_message(MARKER_MS, 0.1, 0.2, 0.3, 0, 0, 0)
            cls = type(marker)
            payload = marker.pack(mavlink2.MAVLink(None))[10:-2]
            # A lying length byte may hold the parser until enough bytes come: the marker
            # goes again until it is read (or a minute has passed).
            deadline = time.monotonic() + 60.0
            alive = False
            while not alive and time.monotonic() < deadline:
                conn.sendall(inputs.heartbeat() + inputs._frame(cls.id, cls.crc_extra, payload))
                alive = link.wait_until(lambda t: t.attitude_time_boot_ms == MARKER_MS, 0.2)
            tel = link.telemetry
            problems += shown_problems(tel)
        finally:
            stop.set()
            drainer.join(2.0)
            conn.close()
            link.close()
            listener.close()
    return {
        "inputs": n,
        "by_kind": dict(sorted(inputs.kinds.items())),
        "unhandled_exceptions": watch.count,
        "samples": watch.samples,
        "still_parsing": bool(alive),
        "handler_errors": tel.handler_errors,
        "crc_errors": tel.crc_errors,
        "implausible_dropped": tel.implausible,
        "impossible_values_shown": len(problems),
        "wall_s": round(time.perf_counter() - t0, 2),
    }
