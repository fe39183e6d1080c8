"""A scripted MAVLink peer on a real TCP socket, for the link's protocol-level tests.

The peer speaks real MAVLink 2 bytes (pymavlink's packer and parser): it plays a
vehicle whose answers each test chooses (acknowledge, refuse with reasons, stay
silent, send garbage), which the full stand-in ArduCopter cannot be asked to do.
"""

from __future__ import annotations

import contextlib
import select
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import VehicleLink

Responder = Callable[["MavPeer", Any], bool]


class MavPeer:
    """A vehicle impostor: TCP server on 127.0.0.1, one client at a time.

    It sends HEARTBEATs (sysid 1, compid 1, quadrotor, ArduPilot) while
    ``heartbeats`` is True, records every parsed message it receives, answers
    COMMAND_LONG with ACCEPTED and serves a small parameter table, unless a
    ``responder`` returns True for a message (meaning: handled).
    """

    def __init__(
        self,
        *,
        port: int = 0,
        signing_key: bytes | None = None,
        heartbeat_hz: float = 10.0,
        custom_mode: int = 0,
    ) -> None:
        self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind(("127.0.0.1", port))
        self.server.listen(1)
        self.port = self.server.getsockname()[1]
        self.signing_key = signing_key
        self.heartbeat_hz = heartbeat_hz
        self.heartbeats = True
        self.custom_mode = custom_mode
        self.armed = False
        self.responder: Responder | None = None
        self.params: dict[str, tuple[float, int]] = {
            "PLND_ENABLED": (0.0, mavlink2.MAV_PARAM_TYPE_INT8),
            "WPNAV_SPEED": (500.0, mavlink2.MAV_PARAM_TYPE_REAL32),
        }
        self.received: list[Any] = []
        self.received_at: list[float] = []  # time.monotonic() of each, as it arrived
        self.connections = 0
        self._client: socket.socket | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._tx = self._new_mav()
        self._rx = self._new_mav()
        self._thread = threading.Thread(target=self._run, name="mav-peer", daemon=True)
        self._thread.start()

    def _new_mav(self) -> Any:
        mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        mav.robust_parsing = True
        if self.signing_key is not None:
            mav.signing.secret_key = self.signing_key
            mav.signing.sign_outgoing = True
            mav.signing.link_id = 7
            mav.signing.timestamp = int((time.time() - 1420070400) * 1e5)
        return mav

    # ---------------------------------------------------------------- sending
    def pack(self, msg: Any) -> bytes:
        with self._lock:
            buf = msg.pack(self._tx)
            self._tx.seq = (self._tx.seq + 1) % 256
        return buf

    def send(self, msg: Any) -> None:
        self.send_raw(self.pack(msg))

    def send_raw(self, data: bytes) -> None:
        client = self._client
        if client is not None:
            with contextlib.suppress(OSError):
                client.sendall(data)

    def statustext(self, text: str, severity: int = mavlink2.MAV_SEVERITY_CRITICAL) -> None:
        self.send(mavlink2.MAVLink_statustext_message(severity, text.encode(), 0, 0))

    def ack(self, command: int, result: int) -> None:
        self.send(mavlink2.MAVLink_command_ack_message(command, result, 0, 0, 255, 190))

    def heartbeat_msg(self) -> Any:
        base = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if self.armed:
            base |= mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
        return mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_QUADROTOR,
            mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
            base,
            self.custom_mode,
            mavlink2.MAV_STATE_STANDBY,
            3,
        )

    # ---------------------------------------------------------------- inspection
    def messages(self, mtype: str) -> list[Any]:
        with self._lock:
            return [m for m in self.received if m.get_type() == mtype]

    def arrivals(self, mtype: str) -> list[float]:
        """When each message of ``mtype`` arrived (``time.monotonic()``)."""
        with self._lock:
            return [
                t
                for m, t in zip(self.received, self.received_at, strict=True)
                if m.get_type() == mtype
            ]

    def wait_for(
        self, mtype: str, timeout: float, where: Callable[[Any], bool] = lambda m: True
    ) -> Any:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for m in self.messages(mtype):
                if where(m):
                    return m
            time.sleep(0.01)
        return None

    def drop_client(self) -> None:
        client, self._client = self._client, None
        if client is not None:
            with contextlib.suppress(OSError):
                client.shutdown(socket.SHUT_RDWR)
            client.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.drop_client()
        self.server.close()

    # ---------------------------------------------------------------- loop
    def _run(self) -> None:
        next_hb = 0.0
        while not self._stop.is_set():
            client = self._client
            if client is None:
                ready, _, _ = select.select([self.server], [], [], 0.05)
                if ready:
                    conn, _ = self.server.accept()
                    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    self._rx = self._new_mav()
                    self._client = conn
                    self.connections += 1
                continue
            now = time.monotonic()
            if self.heartbeats and now >= next_hb:
                next_hb = now + 1.0 / self.heartbeat_hz
                self.send(self.heartbeat_msg())
            try:
                ready, _, _ = select.select([client], [], [], 0.01)
                data = client.recv(4096) if ready else b""
            except OSError:
                data, ready = b"", [client]
            if ready and not data:
                if self._client is client:
                    self._client = None
                client.close()
                continue
            if data:
                for msg in self._rx.parse_buffer(data) or []:
                    if msg.get_type() == "BAD_DATA":
                        continue
                    with self._lock:
                        self.received.append(msg)
                        self.received_at.append(time.monotonic())
                    self._respond(msg)

    def _respond(self, msg: Any) -> None:
        if self.responder is not None and self.responder(self, msg):
            return
        mtype = msg.get_type()
        if mtype == "COMMAND_LONG":
            if msg.command == mavlink2.MAV_CMD_DO_SET_MODE:
                self.custom_mode = int(msg.param2)
            self.ack(msg.command, mavlink2.MAV_RESULT_ACCEPTED)
        elif mtype in ("PARAM_REQUEST_READ", "PARAM_SET"):
            name = msg.param_id
            if name not in self.params:
                return  # ArduPilot stays silent about unknown parameters
            if mtype == "PARAM_SET":
                ptype = self.params[name][1]
                value = float(round(msg.param_value)) if ptype != 9 else msg.param_value
                self.params[name] = (value, ptype)
            value, ptype = self.params[name]
            self.send(
                mavlink2.MAVLink_param_value_message(
                    name.encode(), value, ptype, len(self.params), 0
                )
            )


@pytest.fixture
def make_peer() -> Iterator[Callable[..., MavPeer]]:
    """Build scripted peers (``MavPeer(**kwargs)``) that are always closed."""
    peers: list[MavPeer] = []

    def make(**kwargs: Any) -> MavPeer:
        p = MavPeer(**kwargs)
        peers.append(p)
        return p

    yield make
    for p in peers:
        p.close()


@pytest.fixture
def peer(make_peer: Callable[..., MavPeer]) -> MavPeer:
    return make_peer()


@pytest.fixture
def make_link(tmp_path: Any) -> Iterator[Callable[..., VehicleLink]]:
    """Build links (started unless ``start=False``: to subscribe before its first
    event) that are always closed, with fast timeouts for tests."""
    links: list[VehicleLink] = []

    def make(url: str, *, start: bool = True, **kwargs: Any) -> VehicleLink:
        kwargs.setdefault("tlog_dir", tmp_path / "tlogs")
        kwargs.setdefault("heartbeat_timeout_s", 1.0)
        kwargs.setdefault("command_timeout_s", 1.0)
        link = VehicleLink(url, **kwargs)
        links.append(link)
        if start:
            link.start()
        return link

    yield make
    for link in links:
        link.close()
    for thread in threading.enumerate():
        assert not thread.name.startswith("vehicle-link-"), f"{thread.name} still running"
