"""The link over UDP (both directions) and over a real serial device (a pseudo-terminal)."""

from __future__ import annotations

import contextlib
import os
import select
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import LinkState, VehicleLink
from tests.backend.link.udp import wait_udp_bound


def _vehicle_heartbeat(mav: Any, custom_mode: int = 5) -> bytes:
    msg = mavlink2.MAVLink_heartbeat_message(
        mavlink2.MAV_TYPE_QUADROTOR,
        mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
        mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        custom_mode,
        mavlink2.MAV_STATE_STANDBY,
        3,
    )
    buf = msg.pack(mav)
    mav.seq = (mav.seq + 1) % 256
    return buf


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Beacon:
    """Sends vehicle heartbeats from a thread at 20 Hz while ``on`` is set."""

    def __init__(self, send: Any) -> None:
        self.on = threading.Event()
        self.on.set()
        self._send = send
        self._stop = threading.Event()
        self._mav = mavlink2.MAVLink(None, 1, 1)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.05):
            if self.on.is_set():
                with contextlib.suppress(OSError):
                    self._send(_vehicle_heartbeat(self._mav))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)


def _parse_all(data: bytes) -> list[Any]:
    parser = mavlink2.MAVLink(None)
    parser.robust_parsing = True
    return [m for m in parser.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]


@pytest.fixture
def udp_vehicle() -> Iterator[socket.socket]:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.2)
    yield sock
    sock.close()


def test_udpin_link_up_lost_and_resumed(make_link, udp_vehicle: socket.socket) -> None:
    port = _free_udp_port()
    link = make_link(f"udpin:127.0.0.1:{port}", heartbeat_timeout_s=0.5)
    assert wait_udp_bound(port)  # the link listens before the vehicle speaks
    beacon = _Beacon(lambda b: udp_vehicle.sendto(b, ("127.0.0.1", port)))
    try:
        assert link.wait_until(lambda t: t.state == LinkState.UP, 20.0)
        assert link.telemetry.mode == "LOITER"
        # the link answers to where the vehicle's packets came from
        got: list[Any] = []
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline and not any(m.get_type() == "HEARTBEAT" for m in got):
            with contextlib.suppress(TimeoutError):
                got += _parse_all(udp_vehicle.recv(4096))
        assert any(m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 255 for m in got)
        # garbage datagrams are counted, not fatal
        for _ in range(10):
            udp_vehicle.sendto(os.urandom(100), ("127.0.0.1", port))
        assert link.wait_until(lambda t: t.crc_errors >= 1, 20.0)
        assert link.telemetry.state == LinkState.UP
        beacon.on.clear()  # the vehicle goes silent (radio out of range)
        assert link.wait_until(lambda t: t.state == LinkState.LOST, 20.0)
        beacon.on.set()  # packets return: the same socket, no reopen
        assert link.wait_until(lambda t: t.state == LinkState.UP, 20.0)
        assert link.telemetry.reconnects == 0
    finally:
        beacon.close()


def test_udpout_link(make_link, udp_vehicle: socket.socket) -> None:
    port = udp_vehicle.getsockname()[1]
    link = make_link(f"udpout:127.0.0.1:{port}")
    # the link speaks first: its heartbeat tells the vehicle where the GCS is
    data, addr = b"", None
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline and not data:
        with contextlib.suppress(TimeoutError):
            data, addr = udp_vehicle.recvfrom(4096)
    assert any(m.get_type() == "HEARTBEAT" for m in _parse_all(data))
    beacon = _Beacon(lambda b: udp_vehicle.sendto(b, addr))
    try:
        assert link.wait_until(lambda t: t.state == LinkState.UP, 20.0)
    finally:
        beacon.close()


def test_serial_link_over_a_pseudo_terminal(make_link) -> None:
    master, slave = os.openpty()
    slave_path = os.ttyname(slave)
    os.close(slave)  # the link opens the device by its path, like /dev/ttyUSB0
    beacon = _Beacon(lambda b: os.write(master, b))
    try:
        link = make_link(f"{slave_path},57600", heartbeat_timeout_s=0.5)
        assert link.wait_until(lambda t: t.state == LinkState.UP, 20.0)
        assert link.telemetry.mode == "LOITER"
        # our heartbeat comes out of the device, as real MAVLink 2 bytes
        got: list[Any] = []
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline and not got:
            if select.select([master], [], [], 0.1)[0]:
                got += [m for m in _parse_all(os.read(master, 4096)) if m.get_type() == "HEARTBEAT"]
        assert got and got[0].get_srcSystem() == 255
        assert link.rc_override({3: 1500}).ok
        os.write(master, os.urandom(300))  # line noise on the radio
        assert link.wait_until(lambda t: t.crc_errors > 0, 20.0)
        assert link.telemetry.state == LinkState.UP
    finally:
        beacon.close()
        os.close(master)  # the radio is unplugged: the device fails, the link says so
    assert link.wait_until(lambda t: t.state == LinkState.LOST, 20.0)
    assert link.telemetry.last_error


def test_missing_serial_device_keeps_trying(make_link, tmp_path) -> None:
    link = make_link(str(tmp_path / "ttyNOPE") + ",57600")
    assert link.wait_until(lambda t: t.last_error is not None, 20.0)
    assert link.state == LinkState.CONNECTING and "cannot open" in link.telemetry.last_error


def test_connect_timeout_is_bounded() -> None:
    # 10.255.255.1 is unroutable here: the TCP connect must give up on its own
    link = VehicleLink("tcp:10.255.255.1:5760", connect_timeout_s=0.3)
    link.start()
    try:
        assert link.wait_until(lambda t: t.last_error is not None, 30.0)
    finally:
        link.close()  # gives up the connect under way: no thread is left waiting on it
    assert not [t for t in threading.enumerate() if t.name.startswith("vehicle-link-")]


def test_regular_file_is_not_a_serial_device(make_link, tmp_path) -> None:
    path = tmp_path / "not-a-tty"
    path.write_bytes(b"\xfe\x09" * 100)
    link = make_link(f"{path},57600")
    assert link.wait_until(lambda t: t.last_error is not None, 20.0)
    assert link.state == LinkState.CONNECTING and "cannot open" in link.telemetry.last_error
