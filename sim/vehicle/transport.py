"""Byte transports for the stand-in, addressed like SITL's serial ports.

- ``tcp:HOST:PORT``: listen and accept GCS connections (several at once; one
  leaving does not stop the others or the listener). Port 0 picks a free port.
- ``udp:HOST:PORT``: send to that address from an ephemeral local port; replies go
  to whoever sent last (SITL's ``udpclient``).
- ``/dev/...[,BAUD]``: a serial device, e.g. one end of a pseudo-terminal.

All reading happens in one I/O thread (`poll`); writing (`send`) may come from
another thread and is serialised by a lock.
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import threading
from dataclasses import dataclass

import serial

SEND_TIMEOUT_S = 2.0


@dataclass(frozen=True)
class Endpoint:
    """A parsed connection string."""

    kind: str  # "tcp", "udp" or "serial"
    host: str = ""
    port: int = 0
    path: str = ""
    baud: int = 115200


def parse_url(url: str) -> Endpoint:
    """Parse ``tcp:HOST:PORT``, ``udp:HOST:PORT`` or ``/dev/PATH[,BAUD]``.

    Raises
    ------
    ValueError
        If ``url`` is not one of these forms.
    """
    if not isinstance(url, str) or not url:
        raise ValueError(f"url must be a non-empty string, got {url!r}")
    if url.startswith(("tcp:", "udp:")):
        kind, _, rest = url.partition(":")
        host, sep, port_s = rest.rpartition(":")
        if not sep or not host:
            raise ValueError(f"url must look like {kind}:HOST:PORT, got {url!r}")
        try:
            port = int(port_s)
        except ValueError:
            raise ValueError(f"url port must be an integer, got {port_s!r} in {url!r}") from None
        if not 0 <= port <= 65535 or (kind == "udp" and port == 0):
            raise ValueError(f"url port out of range in {url!r}")
        return Endpoint(kind, host=host, port=port)
    if url.startswith("/"):
        path, sep, baud_s = url.partition(",")
        baud = 115200
        if sep:
            try:
                baud = int(baud_s)
            except ValueError:
                raise ValueError(f"url baud must be an integer, got {baud_s!r}") from None
            if baud <= 0:
                raise ValueError(f"url baud must be positive, got {baud}")
        return Endpoint("serial", path=path, baud=baud)
    raise ValueError(f"url must be tcp:HOST:PORT, udp:HOST:PORT or a /dev path, got {url!r}")


class Transport:
    """Base class: ``open()`` returns the address, ``poll()`` returns received chunks."""

    address: str = ""

    def open(self) -> str:
        raise NotImplementedError

    def poll(self, timeout: float) -> list[tuple[object, bytes]]:
        """Wait up to ``timeout`` s; return (peer, bytes) chunks and handle peers."""
        raise NotImplementedError

    def send(self, data: bytes) -> None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    @property
    def peers(self) -> int:
        """Connected peers (TCP clients; 1 for a UDP peer that has spoken or a port)."""
        return 0


class TcpServerTransport(Transport):
    """Listening TCP socket with any number of clients."""

    def __init__(self, host: str, port: int) -> None:
        self._host, self._port = host, port
        self._listener: socket.socket | None = None
        self._clients: list[socket.socket] = []
        self._lock = threading.Lock()
        self.connections = 0

    def open(self) -> str:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((self._host, self._port))
        except OSError:
            s.close()
            raise
        s.listen(4)
        s.setblocking(False)
        self._listener = s
        host, port = s.getsockname()[:2]
        self.address = f"tcp:{host}:{port}"
        return self.address

    def poll(self, timeout: float) -> list[tuple[object, bytes]]:
        if self._listener is None:
            return []
        with self._lock:
            socks = [self._listener, *self._clients]
        try:
            readable, _, _ = select.select(socks, [], [], timeout)
        except (OSError, ValueError):
            return []  # a socket closed under us: next poll sees the new list
        out: list[tuple[object, bytes]] = []
        for s in readable:
            if s is self._listener:
                try:
                    conn, _ = s.accept()
                except OSError:
                    continue
                conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                conn.settimeout(SEND_TIMEOUT_S)
                with self._lock:
                    self._clients.append(conn)
                self.connections += 1
                continue
            try:
                data = s.recv(65536)
            except (OSError, TimeoutError):
                data = b""
            if data:
                out.append((s, data))
            else:
                self._drop(s)
                out.append((s, b""))  # tells the owner to forget this peer's parser
        return out

    def _drop(self, s: socket.socket) -> None:
        with self._lock:
            if s in self._clients:
                self._clients.remove(s)
        with contextlib.suppress(OSError):
            s.close()

    def send(self, data: bytes) -> None:
        with self._lock:
            clients = list(self._clients)
        for c in clients:
            try:
                c.sendall(data)
            except (OSError, TimeoutError):
                # A GCS that stopped reading or went away: drop it, keep serving others.
                self._drop(c)

    def close(self) -> None:
        with self._lock:
            clients, self._clients = self._clients, []
        for c in clients:
            with contextlib.suppress(OSError):
                c.shutdown(socket.SHUT_RDWR)
            with contextlib.suppress(OSError):
                c.close()
        if self._listener is not None:
            with contextlib.suppress(OSError):
                self._listener.close()
            self._listener = None

    @property
    def peers(self) -> int:
        with self._lock:
            return len(self._clients)


class UdpClientTransport(Transport):
    """Sends to a fixed address until someone else speaks; then replies to them."""

    def __init__(self, host: str, port: int) -> None:
        self._dest = (host, port)
        self._sock: socket.socket | None = None
        self._lock = threading.Lock()
        self._heard = False

    def open(self) -> str:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        loopback = self._dest[0] in ("localhost",) or self._dest[0].startswith("127.")
        s.bind(("127.0.0.1" if loopback else "0.0.0.0", 0))
        s.setblocking(False)
        self._sock = s
        self.local_address = s.getsockname()[:2]
        self.address = f"udp:{self._dest[0]}:{self._dest[1]}"
        return self.address

    def poll(self, timeout: float) -> list[tuple[object, bytes]]:
        if self._sock is None:
            return []
        try:
            readable, _, _ = select.select([self._sock], [], [], timeout)
        except (OSError, ValueError):
            return []
        out: list[tuple[object, bytes]] = []
        while readable:
            try:
                data, addr = self._sock.recvfrom(65536)
            except (BlockingIOError, OSError):
                break
            with self._lock:
                self._dest = addr[:2]
                self._heard = True
            out.append((addr[:2], data))
        return out

    def send(self, data: bytes) -> None:
        if self._sock is None:
            return
        with self._lock:
            dest = self._dest
        # Nobody listening yet (ICMP refused) is normal for a UDP client: ignore it.
        with contextlib.suppress(OSError):
            self._sock.sendto(data, dest)

    def close(self) -> None:
        if self._sock is not None:
            with contextlib.suppress(OSError):
                self._sock.close()
            self._sock = None

    @property
    def peers(self) -> int:
        return 1 if self._heard else 0


class SerialTransport(Transport):
    """A serial device (a real port or a pseudo-terminal) opened with pyserial."""

    def __init__(self, path: str, baud: int) -> None:
        self._path, self._baud = path, baud
        self._port: serial.Serial | None = None
        self._lock = threading.Lock()
        self.errors = 0
        self.dropped = 0

    def open(self) -> str:
        if not os.path.exists(self._path):
            raise ValueError(f"url: serial device {self._path!r} does not exist")
        self._port = serial.Serial(self._path, self._baud, timeout=0, write_timeout=SEND_TIMEOUT_S)
        self.address = f"{self._path},{self._baud}"
        return self.address

    def poll(self, timeout: float) -> list[tuple[object, bytes]]:
        port = self._port
        if port is None:
            return []
        try:
            readable, _, _ = select.select([port.fileno()], [], [], timeout)
            if not readable:
                return []
            data = os.read(port.fileno(), 65536)
        except (OSError, ValueError, serial.SerialException):
            # The other end of a pty closed (EIO): wait for it to come back.
            self.errors += 1
            threading.Event().wait(min(timeout, 0.05))
            return []
        return [("serial", data)] if data else []

    def send(self, data: bytes) -> None:
        port = self._port
        if port is None:
            return
        with self._lock:
            try:
                # Non-blocking like a UART: when nobody drains the other end, bytes drop.
                os.write(port.fileno(), data)
            except BlockingIOError:
                self.dropped += len(data)
            except (OSError, ValueError, serial.SerialException):
                self.errors += 1

    def close(self) -> None:
        if self._port is not None:
            with contextlib.suppress(OSError, serial.SerialException):
                self._port.close()
            self._port = None

    @property
    def peers(self) -> int:
        return 1 if self._port is not None else 0


def make_transport(url: str) -> Transport:
    """The transport for a connection string (see module docstring)."""
    ep = parse_url(url)
    if ep.kind == "tcp":
        return TcpServerTransport(ep.host, ep.port)
    if ep.kind == "udp":
        return UdpClientTransport(ep.host, ep.port)
    return SerialTransport(ep.path, ep.baud)
