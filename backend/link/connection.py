"""The transport under the vehicle link: connection strings, (re)opening, signing, tlog.

A :class:`Transport` owns one pymavlink connection at a time. The reader thread opens,
reads and closes it; any thread may send. Every connection speaks MAVLink 2 through its
own parser object (never pymavlink's process-wide dialect switch), and every packet in
both directions goes to the session's :class:`TlogWriter`.
"""

from __future__ import annotations

import contextlib
import errno
import select
import socket
import struct
import threading
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, BinaryIO, Literal

import serial
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

Kind = Literal["tcp", "udpin", "udpout", "serial"]

_URL_HELP = "tcp:HOST:PORT, udpin:HOST:PORT (or udp:), udpout:HOST:PORT, or /dev/DEVICE[,BAUD]"
_SEND_TIMEOUT_S = 1.0
# RADIO_STATUS comes from SiK/XBee radios, which cannot sign; MAVProxy accepts it too.
_UNSIGNED_OK = frozenset({mavlink2.MAVLINK_MSG_ID_RADIO_STATUS})


class SendError(OSError):
    """A message could not be sent."""


class TransportDropped(SendError):
    """The connection is gone (peer closed, device unplugged); reopen it."""


@dataclass(frozen=True)
class ConnectionSpec:
    """A parsed connection string."""

    url: str
    kind: Kind
    host: str | None = None
    port: int | None = None
    device: str | None = None
    baud: int | None = None


def parse_url(url: str, *, baud: int = 57600) -> ConnectionSpec:
    """Parse a pymavlink-style connection string.

    Parameters
    ----------
    url : str
        ``tcp:HOST:PORT`` (connect out, e.g. ArduPilot SITL's ``tcp:127.0.0.1:5760``),
        ``udpin:HOST:PORT`` or ``udp:HOST:PORT`` (listen), ``udpout:HOST:PORT`` (send
        to), or a serial device with optional baud, ``/dev/ttyUSB0,57600``.
    baud : int
        Serial baud rate when the string names none.

    Raises
    ------
    ValueError
        If the string is none of these forms.

    >>> parse_url("tcp:127.0.0.1:5760").port
    5760
    >>> parse_url("/dev/ttyUSB0,57600").baud
    57600
    """
    if not isinstance(url, str) or not url.strip():
        raise ValueError(f"url must be a connection string ({_URL_HELP}), got {url!r}")
    url = url.strip()
    prefixes = (("tcp:", "tcp"), ("udpin:", "udpin"), ("udp:", "udpin"), ("udpout:", "udpout"))
    for prefix, kind in prefixes:
        if url.startswith(prefix):
            host, sep, port_text = url[len(prefix) :].rpartition(":")
            if not sep or not host or not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
                raise ValueError(f"url {url!r} must look like {prefix}HOST:PORT with PORT 1..65535")
            return ConnectionSpec(url=url, kind=kind, host=host, port=int(port_text))  # type: ignore[arg-type]
    if ":" in url.split(",")[0] and not url.upper().startswith("COM"):
        raise ValueError(f"url {url!r} is not a supported connection string ({_URL_HELP})")
    device, sep, baud_text = url.partition(",")
    if sep:
        if not baud_text.strip().isdigit() or int(baud_text) <= 0:
            raise ValueError(f"url {url!r}: the baud rate after ',' must be a positive integer")
        baud = int(baud_text)
    if isinstance(baud, bool) or not isinstance(baud, int) or baud <= 0:
        raise ValueError(f"baud must be a positive integer, got {baud!r}")
    return ConnectionSpec(url=url, kind="serial", device=device.strip(), baud=baud)


class TlogWriter:
    """Writes a .tlog: per packet an 8-byte big-endian UNIX time in microseconds, then
    the raw MAVLink packet. MAVExplorer, Mission Planner and QGroundControl replay it,
    and so does ``pymavlink.mavutil.mavlink_connection(path)``.
    """

    def __init__(self, directory: str | Path, *, start: datetime | None = None) -> None:
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        stamp = (start or datetime.now(UTC)).strftime("%Y-%m-%dT%H-%M-%SZ")
        self._lock = threading.Lock()
        self.packets = 0
        for n in range(1000):
            path = directory / (f"{stamp}.tlog" if n == 0 else f"{stamp}-{n}.tlog")
            try:
                self._file: BinaryIO | None = open(path, "xb")  # noqa: SIM115 (lives with the writer)
            except FileExistsError:
                continue
            self.path = path
            break
        else:
            raise FileExistsError(f"no free tlog name for {stamp} in {directory}")

    def write(self, packet: bytes | bytearray, t: float | None = None) -> None:
        """Append one packet stamped with ``t`` (default: now)."""
        usec = int((time.time() if t is None else t) * 1e6) & ~3  # pymavlink's own stamp
        with self._lock:
            if self._file is None:
                return
            self._file.write(struct.pack(">Q", usec) + bytes(packet))
            self.packets += 1

    def flush(self) -> None:
        """Push buffered packets to disk so the log replays while the link runs."""
        with self._lock:
            if self._file is not None:
                self._file.flush()

    def close(self) -> None:
        """Flush and close; later writes are dropped."""
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None


class _TcpConnection(mavutil.mavfile):
    """pymavlink's TCP client, with a bounded connect and a loud end of stream.

    ``mavutil.mavtcp`` prints and sleeps inside ``recv`` to reconnect, which would stall
    the reader thread; here a closed or reset socket raises :class:`TransportDropped`
    and the link reopens it with a back-off of its own.
    """

    def __init__(
        self, host: str, port: int, *, timeout: float, source_system: int, source_component: int
    ) -> None:
        sock = socket.create_connection((host, port), timeout=timeout)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.setblocking(False)
        mavutil.set_close_on_exec(sock.fileno())
        self.port = sock
        super().__init__(
            sock.fileno(),
            f"tcp:{host}:{port}",
            source_system=source_system,
            source_component=source_component,
            input=False,
        )

    def recv(self, n: int | None = None) -> bytes:
        try:
            data = self.port.recv(4096)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise TransportDropped(f"TCP connection failed: {exc}") from exc
        if not data:
            raise TransportDropped("TCP connection closed by the vehicle")
        return data

    def write(self, buf: bytes | bytearray) -> None:
        view = memoryview(bytes(buf))
        deadline = time.monotonic() + _SEND_TIMEOUT_S
        while view:
            try:
                sent = self.port.send(view)
            except BlockingIOError:
                sent = 0
            except OSError as exc:
                if exc.errno in (errno.EPIPE, errno.ECONNRESET, errno.ENOTCONN, errno.EBADF):
                    raise TransportDropped(f"TCP connection failed: {exc}") from exc
                raise SendError(f"TCP send failed: {exc}") from exc
            view = view[sent:]
            if view:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TransportDropped("TCP send stalled for 1 s")
                select.select([], [self.port], [], left)

    def close(self) -> None:
        self.port.close()


def _serial_writer(conn: Any) -> Any:
    """A write for mavutil.mavserial that reports failures instead of printing them."""

    def write(buf: bytes | bytearray) -> None:
        try:
            conn.port.write(bytes(buf))
        except serial.SerialTimeoutException as exc:
            raise SendError(f"serial write timed out: {exc}") from exc
        except (OSError, serial.SerialException) as exc:
            raise TransportDropped(f"serial device failed: {exc}") from exc

    return write


class Transport:
    """One MAVLink connection at a time over a :class:`ConnectionSpec`.

    Parameters
    ----------
    spec : ConnectionSpec
        Where the vehicle is.
    source_system, source_component : int
        Our MAVLink identity (255 is ArduPilot's SYSID_MYGCS default).
    signing_key : bytes or None
        32-byte MAVLink 2 signing key; outgoing packets are signed and unsigned
        incoming ones rejected (counted as receive errors) except RADIO_STATUS.
    tlog : TlogWriter or None
        Where every packet, both ways, is recorded.
    connect_timeout_s : float
        Bound on a TCP connect.
    """

    def __init__(
        self,
        spec: ConnectionSpec,
        *,
        source_system: int = 255,
        source_component: int = mavlink2.MAV_COMP_ID_MISSIONPLANNER,
        signing_key: bytes | None = None,
        tlog: TlogWriter | None = None,
        connect_timeout_s: float = 2.0,
    ) -> None:
        self.spec = spec
        self.source_system = source_system
        self.source_component = source_component
        self.signing_key = signing_key
        self.tlog = tlog
        self.connect_timeout_s = connect_timeout_s
        self._lock = threading.Lock()
        self._conn: Any = None
        self._closed_errors = 0
        self._closed_loss = 0
        self._closed_count = 0
        self.opened = 0

    # ------------------------------------------------------------------ lifecycle
    @property
    def is_open(self) -> bool:
        """Whether a connection is open now."""
        return self._conn is not None

    def open(self) -> None:
        """Open the connection; raises ``OSError`` (or ``serial.SerialException``)."""
        spec = self.spec
        ids = {"source_system": self.source_system, "source_component": self.source_component}
        if spec.kind == "tcp":
            assert spec.host is not None and spec.port is not None  # parse_url sets both
            conn: Any = _TcpConnection(spec.host, spec.port, timeout=self.connect_timeout_s, **ids)
        elif spec.kind in ("udpin", "udpout"):
            conn = mavutil.mavlink_connection(f"{spec.kind}:{spec.host}:{spec.port}", **ids)
        else:
            # mavserial directly: mavlink_connection would open a regular file as a log
            conn = mavutil.mavserial(spec.device, baud=spec.baud, **ids)
            conn.port.write_timeout = _SEND_TIMEOUT_S
            conn.write = _serial_writer(conn)
        self._speak_mavlink2(conn)
        with self._lock:
            self._conn = conn
            self.opened += 1

    def _speak_mavlink2(self, conn: Any) -> None:
        # A private MAVLink 2 parser: pymavlink would otherwise switch the dialect of the
        # whole process when it first sees a MAVLink 2 byte.
        mav = mavlink2.MAVLink(
            conn, srcSystem=self.source_system, srcComponent=self.source_component
        )
        mav.robust_parsing = True
        conn.mav = mav
        conn.robust_parsing = True
        conn.WIRE_PROTOCOL_VERSION = "2.0"
        conn.first_byte = False
        if self.signing_key is not None:
            conn.setup_signing(
                self.signing_key,
                sign_outgoing=True,
                allow_unsigned_callback=lambda _mav, msg_id: msg_id in _UNSIGNED_OK,
            )
        mav.set_callback(self._log_incoming)

    def _log_incoming(self, msg: Any) -> None:
        if self.tlog is not None and msg.get_type() != "BAD_DATA":
            self.tlog.write(msg.get_msgbuf())

    def close(self) -> None:
        """Close the connection (idempotent); counters carry over to the next one."""
        with self._lock:
            conn, self._conn = self._conn, None
            if conn is None:
                return
            self._closed_errors += conn.mav.total_receive_errors
            self._closed_loss += conn.mav_loss
            self._closed_count += conn.mav_count
        with contextlib.suppress(Exception):
            conn.close()

    # ------------------------------------------------------------------ traffic
    def recv_msg(self) -> Any:
        """The next parsed message or None when none is waiting (never blocks).

        Raises :class:`TransportDropped` when the connection is gone.
        """
        conn = self._conn
        if conn is None:
            raise TransportDropped("not open")
        try:
            return conn.recv_msg()
        except TransportDropped:
            raise
        except (OSError, serial.SerialException) as exc:
            raise TransportDropped(f"{self.spec.kind} receive failed: {exc}") from exc

    def wait_readable(self, timeout: float) -> None:
        """Sleep until data may be waiting, at most ``timeout`` seconds."""
        conn = self._conn
        if conn is None:
            time.sleep(timeout)
            return
        try:
            conn.select(timeout)
        except (OSError, ValueError):
            time.sleep(timeout)

    def send(self, msg: Any) -> None:
        """Pack, sign, send and log one message; raises :class:`SendError`."""
        with self._lock:
            conn = self._conn
            if conn is None:
                raise TransportDropped("not open")
            try:
                conn.mav.send(msg)
            except SendError:
                raise
            except (OSError, serial.SerialException) as exc:
                raise SendError(f"send failed: {exc}") from exc
            if self.tlog is not None:
                self.tlog.write(msg.get_msgbuf())

    def reset_parser(self) -> None:
        """Drop half-parsed bytes (after an unexpected parser fault)."""
        conn = self._conn
        if conn is not None:
            conn.mav.buf = bytearray()
            conn.mav.buf_index = 0
            conn.mav.expected_length = mavlink2.HEADER_LEN_V1 + 2

    # ------------------------------------------------------------------ counters
    @property
    def receive_errors(self) -> int:
        """Bad bytes, bad CRCs and bad signatures seen, over every connection so far."""
        conn = self._conn
        return self._closed_errors + (conn.mav.total_receive_errors if conn is not None else 0)

    @property
    def packets_lost_pct(self) -> float:
        """Packets missing by sequence number, percent of those expected, all connections."""
        conn = self._conn
        loss = self._closed_loss + (conn.mav_loss if conn is not None else 0)
        count = self._closed_count + (conn.mav_count if conn is not None else 0)
        return 100.0 * loss / (loss + count) if loss + count else 0.0

    @property
    def signing_stats(self) -> dict[str, int]:
        """Signature counters of the current connection (all zero without signing)."""
        conn = self._conn
        if conn is None:
            return {}
        s = conn.mav.signing
        return {
            "good": s.goodsig_count,
            "bad": s.badsig_count,
            "unsigned_accepted": s.unsigned_count,
            "rejected": s.reject_count,
        }
