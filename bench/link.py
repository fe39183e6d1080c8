"""Benchmark of the vehicle link over loopback TCP; prints one JSON object.

``python -m bench.link [--messages 20000] [--commands 200] [--latency-samples 250]``

A bench vehicle (a thread with a listening socket, real MAVLink 2 bytes) sends vehicle
HEARTBEATs, answers every COMMAND_LONG with an immediate COMMAND_ACK, and on request
blasts ATTITUDE messages. Measured:

- ``receive``: ATTITUDE messages per second through parse, cache, handler and
  snapshot, when the vehicle sends as fast as the socket allows;
- ``telemetry_latency_ms``: from the vehicle writing an ATTITUDE to the snapshot
  showing it, at 50 Hz (what the simulated camera and the mission controller wait);
- ``command_round_trip_ms``: ``set_mode`` from call to CommandResult with an
  instantly answering vehicle (the link's own overhead, not the vehicle's).
"""

from __future__ import annotations

import argparse
import json
import platform
import select
import socket
import statistics
import threading
import time
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import Telemetry
from backend.link.vehicle_link import VehicleLink


class _BenchVehicle:
    def __init__(self) -> None:
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.client: socket.socket | None = None
        self._mav = mavlink2.MAVLink(None, 1, 1)
        self._parser = mavlink2.MAVLink(None)
        self._parser.robust_parsing = True
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def pack(self, msg: Any) -> bytes:
        with self._lock:
            buf = msg.pack(self._mav)
            self._mav.seq = (self._mav.seq + 1) % 256
        return buf

    def send(self, data: bytes) -> None:
        if self.client is not None:
            self.client.sendall(data)

    def _run(self) -> None:
        self.server.settimeout(5.0)
        self.client, _ = self.server.accept()
        self.client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_hb:
                next_hb = now + 0.1
                self.send(
                    self.pack(
                        mavlink2.MAVLink_heartbeat_message(
                            2, 3, mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0, 3, 3
                        )
                    )
                )
            if not select.select([self.client], [], [], 0.02)[0]:
                continue
            try:
                data = self.client.recv(65536)
            except OSError:  # the link closed first
                return
            if not data:
                return
            for msg in self._parser.parse_buffer(data) or []:
                if msg.get_type() == "COMMAND_LONG":
                    ack = mavlink2.MAVLink_command_ack_message(msg.command, 0, 0, 0, 255, 190)
                    self.send(self.pack(ack))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        if self.client is not None:
            self.client.close()
        self.server.close()


def _attitude(vehicle: _BenchVehicle, stamp: int) -> bytes:
    return vehicle.pack(mavlink2.MAVLink_attitude_message(stamp, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))


def _percentiles(values: list[float]) -> dict[str, float]:
    values = sorted(values)
    return {
        "p50": round(statistics.median(values), 3),
        "p95": round(values[int(0.95 * (len(values) - 1))], 3),
        "max": round(values[-1], 3),
    }


def run(messages: int, commands: int, latency_samples: int = 250) -> dict[str, Any]:
    """Run the three measurements; returns the JSON-ready result."""
    vehicle = _BenchVehicle()
    link = VehicleLink(f"tcp:127.0.0.1:{vehicle.port}", stream_rates_hz={"ATTITUDE": 1.0})
    link.start()
    try:
        if not link.wait_until(lambda t: t.state == "up", 5.0):
            raise RuntimeError("bench link did not come up")
        # receive throughput: pre-packed burst, written as fast as the socket takes it
        burst = b"".join(_attitude(vehicle, i + 1) for i in range(messages))
        cpu0, t0 = time.process_time(), time.perf_counter()
        vehicle.send(burst)
        done = link.wait_until(lambda t: t.attitude_time_boot_ms == messages, 120.0)
        wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
        if not done:
            raise RuntimeError("the burst did not get through")
        # latency at 50 Hz
        latencies = []
        for i in range(latency_samples):
            stamp = 10_000_000 + i
            sent = time.perf_counter()
            vehicle.send(_attitude(vehicle, stamp))
            if link.wait_until(_boot_ms_is(stamp), 1.0):
                latencies.append((time.perf_counter() - sent) * 1e3)
            time.sleep(0.02)
        # command round trip
        trips = []
        for _ in range(commands):
            started = time.perf_counter()
            result = link.set_mode("GUIDED")
            if result.ok:
                trips.append((time.perf_counter() - started) * 1e3)
        crc_errors = link.telemetry.crc_errors
    finally:
        link.close()
        vehicle.close()
    return {
        "benchmark": "backend.link",
        "python": platform.python_version(),
        "machine": platform.machine(),
        "receive": {
            "messages": messages,
            "msgs_per_s": round(messages / wall, 1),
            "cpu_s_per_1000_msgs": round(1000 * cpu / messages, 4),
        },
        "telemetry_latency_ms": {"samples": len(latencies), **_percentiles(latencies)},
        "command_round_trip_ms": {"samples": len(trips), **_percentiles(trips)},
        "crc_errors": crc_errors,
        "note": "cpu counts every thread of this process, the bench vehicle's included",
    }


def _boot_ms_is(stamp: int) -> Callable[[Telemetry], bool]:
    """Whether the snapshot holds the ATTITUDE stamped ``stamp``."""
    return lambda t: t.attitude_time_boot_ms == stamp


def main(argv: list[str] | None = None) -> int:
    """Command-line entry: print the measurements as JSON."""
    parser = argparse.ArgumentParser(prog="python -m bench.link", description=__doc__)
    parser.add_argument("--messages", type=int, default=20000, help="ATTITUDE burst size")
    parser.add_argument("--commands", type=int, default=200, help="set_mode round trips")
    parser.add_argument(
        "--latency-samples", type=int, default=250, help="ATTITUDE messages timed at 50 Hz"
    )
    args = parser.parse_args(argv)
    if min(args.messages, args.commands, args.latency_samples) < 1:
        parser.error("--messages, --commands and --latency-samples must be >= 1")
    print(json.dumps(run(args.messages, args.commands, args.latency_samples), indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
