"""CMUcam4 driver over pyserial, a frame source built on it, and a snapshot CLI.

Protocol: ``specs/cmucam4.md`` (firmware v1.02). Every read has a deadline; pixel data is
read by count, never scanned for terminators; ``ERR:``/``NCK`` become exceptions; after
garbage or a timeout the driver resynchronises (``\\r``, drain, empty command) or, failing
that, runs the connect sequence again.

Full frames over serial are slow (``SF`` 160x120 takes about 5 s: one column per camera
frame), so :class:`CMUcam4Source` delivers stills. Live 30 Hz guidance needs either the
``T`` packet stream (:meth:`CMUcam4.track`, a coarse colour-blob cue) or the board's
analog video out through a USB capture device, read with the OpenCV source (``opencv:N``).

CLI::

    python -m backend.camera.cmucam4 /dev/ttyUSB0 --snapshot out.png [--res 160x120]

Why one module of ~900 lines: it is one serial protocol, and the driver, its frame
source and its CLI share the command and resynchronisation machinery; split, each
part would reach into the others' internals.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import serial

from backend.camera import CaptureError, ThreadedSource
from backend.camera.rgb565 import decode_rgb565, parse_resolution, resolution_to_hv

BAUDS = (250000, 115200, 19200)
BANNER = b"\rCMUcam4 v"
_PROMPT = object()


class CMUcam4Error(CaptureError):
    """Anything that went wrong talking to a CMUcam4; the message names the port."""


class CMUcam4NotFound(CMUcam4Error):
    """No CMUcam4 answered on the port (no banner at any baud)."""


class CMUcam4Timeout(CMUcam4Error):
    """The camera did not answer in time."""


class CMUcam4NCK(CMUcam4Error):
    """The camera refused a command (unknown command or missing argument)."""


class CMUcam4CameraError(CMUcam4Error):
    """The camera reported ``ERR: <text>`` (e.g. ``Camera Timeout Error``)."""

    def __init__(self, message: str, text: str) -> None:
        super().__init__(message)
        self.text = text


class CMUcam4ProtocolError(CMUcam4Error):
    """Bytes that do not fit the protocol (garbage, a reboot banner, a lost sync)."""


class CMUcam4Disconnected(CMUcam4Error):
    """The serial port went away (unplugged, or the pty closed)."""


@dataclass(frozen=True)
class CMUcam4Settings:
    """Camera settings sent after connecting; the defaults are the seed's.

    The seed turned on auto pan (``AP 1``), auto tilt (``AT 1``) and auto gain
    (``AG 1``), and raised the brightness to 16 (``CB 16``) "because it was too dark".
    Auto pan/tilt drive servos following the tracked colour; switch them off for a
    fixed, downward-looking mount.
    """

    auto_gain: bool = True
    auto_white_balance: bool = True
    brightness: int = 16
    contrast: int = 0
    auto_pan: bool = True
    auto_tilt: bool = True

    def __post_init__(self) -> None:
        if not -127 <= int(self.brightness) <= 127:
            raise ValueError(f"brightness must be in -127..127, got {self.brightness}")
        if not -31 <= int(self.contrast) <= 31:
            raise ValueError(f"contrast must be in -31..31, got {self.contrast}")

    def commands(self) -> list[str]:
        return [
            f"AG {int(self.auto_gain)}",
            f"AW {int(self.auto_white_balance)}",
            f"CB {int(self.brightness)}",
            f"CC {int(self.contrast)}",
            f"AP {int(self.auto_pan)}",
            f"AT {int(self.auto_tilt)}",
        ]


@dataclass(frozen=True)
class TPacket:
    """Colour tracking result in the 160x120 tracking image (all zero: nothing tracked)."""

    mx: int
    my: int
    x1: int
    y1: int
    x2: int
    y2: int
    pixels: int
    confidence: int
    t: float
    bitmap: np.ndarray | None = field(default=None, compare=False, repr=False)
    """Line mode only: the 60x80 bool image of tracked pixels."""

    @property
    def tracked(self) -> bool:
        return self.pixels > 0


@dataclass(frozen=True)
class SPacket:
    """Colour statistics of the tracking window: (R, G, B) mean, median, mode, stdev."""

    mean: tuple[int, int, int]
    median: tuple[int, int, int]
    mode: tuple[int, int, int]
    stdev: tuple[int, int, int]
    t: float
    bitmap: np.ndarray | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True, eq=False)
class Snapshot:
    """One ``SF`` frame: BGR image and when its first and last columns arrived."""

    image: np.ndarray
    t_start: float
    t_end: float
    nbytes: int

    @property
    def t_mid(self) -> float:
        return 0.5 * (self.t_start + self.t_end)


def _parse_ints(line: str, tag: str, n: int) -> list[int]:
    words = line.split()
    if len(words) != n + 1 or words[0] != tag:
        raise ValueError(line)
    return [int(w) for w in words[1:]]


class CMUcam4:
    """A CMUcam4 on a serial port.

    Parameters
    ----------
    port : str
        Serial device, e.g. ``/dev/ttyUSB0``.
    timeout : float
        Seconds for an ordinary reply (and for each ``SF`` column).
    reset_timeout : float
        Seconds to wait for the banner after ``RS`` at each baud (library: 2.25 s).
    tries : int
        Rounds over the baud rates in :meth:`connect` (library: 4).
    baud : int
        The rate to switch to after the banner (250,000 is exact on the board).
    long_timeout : float
        Seconds for SD-card commands (``DF``).
    """

    def __init__(
        self,
        port: str,
        *,
        timeout: float = 1.0,
        reset_timeout: float = 2.25,
        tries: int = 4,
        baud: int = 250000,
        long_timeout: float = 120.0,
    ) -> None:
        if not port:
            raise ValueError("port must name a serial device, e.g. /dev/ttyUSB0")
        for key, val in (
            ("timeout", timeout),
            ("reset_timeout", reset_timeout),
            ("long_timeout", long_timeout),
        ):
            if not (math.isfinite(val) and val > 0):
                raise ValueError(f"{key} must be a positive number of seconds, got {val}")
        if int(tries) < 1:
            raise ValueError(f"tries must be >= 1, got {tries}")
        if not 1 <= int(baud) <= 250000:
            raise ValueError(f"baud must be in 1..250000, got {baud}")
        self.port = port
        self.timeout = float(timeout)
        self.reset_timeout = float(reset_timeout)
        self.tries = int(tries)
        self.baud = int(baud)
        self.long_timeout = float(long_timeout)
        self.version: str | None = None
        self.garbage_bytes = 0  # bytes skipped while resynchronising
        self.line_mode = False  # LM 1: packets carry an 80x60 bitmap
        self._ser: serial.Serial | None = None
        self._buf = bytearray()
        self._cancel = threading.Event()

    # --- port --------------------------------------------------------------------------
    def open(self) -> None:
        """Open the serial port (19,200 baud 8N1); ``CMUcam4Error`` naming it on failure."""
        if self._ser is not None:
            return
        try:
            self._ser = serial.Serial(self.port, 19200, timeout=0.1, write_timeout=2.0)
        except (serial.SerialException, OSError, ValueError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            if "could not open port" in reason and ":" in reason:
                reason = reason.rsplit(":", 1)[-1].strip() or reason
            raise CMUcam4Error(f"cannot open {self.port}: {reason}") from None
        self._buf.clear()

    def close(self) -> None:
        """Close the port; also clears a :meth:`cancel` (it lasts until the next close)."""
        ser, self._ser = self._ser, None
        self.version = None
        self._cancel.clear()
        if ser is not None:
            with contextlib.suppress(Exception):
                ser.close()

    def cancel(self) -> None:
        """Make a blocked read fail now with ``CMUcam4Error`` (from another thread); reads
        keep failing until :meth:`close`."""
        self._cancel.set()
        ser = self._ser
        if ser is not None:
            with contextlib.suppress(Exception):
                ser.cancel_read()

    def __enter__(self) -> CMUcam4:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- bytes -------------------------------------------------------------------------
    def _port(self) -> serial.Serial:
        if self._ser is None:
            raise CMUcam4Error(f"{self.port} is not open")
        return self._ser

    def _write(self, data: bytes) -> None:
        try:
            self._port().write(data)
        except serial.SerialTimeoutException:
            raise CMUcam4Timeout(f"{self.port}: write timed out") from None
        except (serial.SerialException, OSError) as exc:
            raise CMUcam4Disconnected(f"{self.port} disappeared: {exc}") from None

    def _fill(self, deadline: float) -> bool:
        """Read whatever arrives before ``deadline`` into the buffer; False on timeout."""
        ser = self._port()
        if self._cancel.is_set():
            raise CMUcam4Error(f"{self.port}: cancelled")
        left = deadline - time.monotonic()
        if left <= 0:
            return False
        try:
            ser.timeout = min(left, 0.25)  # short slices so cancel() is noticed
            chunk = ser.read(max(1, min(ser.in_waiting, 65536)))
        except (serial.SerialException, OSError, TypeError) as exc:
            raise CMUcam4Disconnected(f"{self.port} disappeared: {exc}") from None
        self._buf += chunk
        return True

    def _read_exact(self, n: int, deadline: float, what: str) -> bytes:
        while len(self._buf) < n:
            if not self._fill(deadline):
                raise CMUcam4Timeout(
                    f"{self.port}: timed out waiting for {what} (got {len(self._buf)} of {n} bytes)"
                )
        out = bytes(self._buf[:n])
        del self._buf[:n]
        return out

    def _read_token(self, deadline: float, limit: int = 1024) -> str | object:
        """The next reply line (without ``\\r``), or ``_PROMPT`` for a lone ``:``."""
        while True:
            if self._buf[:1] == b":":
                del self._buf[:1]
                return _PROMPT
            idx = self._buf.find(b"\r")
            if idx >= 0:
                line = bytes(self._buf[:idx])
                del self._buf[: idx + 1]
                return line.decode("ascii", "replace")
            if len(self._buf) > limit:
                raise CMUcam4ProtocolError(
                    f"{self.port}: no line end in {len(self._buf)} bytes: {bytes(self._buf[:40])!r}"
                )
            if not self._fill(deadline):
                raise CMUcam4Timeout(
                    f"{self.port}: timed out waiting for a reply (got {bytes(self._buf[:40])!r})"
                )

    def _drain(self, quiet: float, limit: float) -> int:
        """Discard input until the line is quiet for ``quiet`` s (at most ``limit`` s)."""
        n = len(self._buf)
        self._buf.clear()
        end = time.monotonic() + limit
        last = time.monotonic()
        while time.monotonic() < end and time.monotonic() - last < quiet:
            self._fill(min(end, time.monotonic() + quiet))
            if self._buf:
                n += len(self._buf)
                self._buf.clear()
                last = time.monotonic()
        self.garbage_bytes += n
        return n

    # --- replies -----------------------------------------------------------------------
    def _expect_ack(self, cmd: str, deadline: float) -> None:
        while True:
            tok = self._read_token(deadline)
            if tok is _PROMPT or tok == "":
                continue  # a stray prompt or the empty line of a banner
            assert isinstance(tok, str)
            if tok == "ACK":
                return
            if tok == "NCK":
                self._skip_prompt(deadline)
                raise CMUcam4NCK(f"{self.port}: camera answered NCK to {cmd!r}")
            if tok.startswith("ERR:"):
                self._skip_prompt(deadline)
                text = tok[4:].strip()
                raise CMUcam4CameraError(f"{self.port}: {cmd!r} failed: {text}", text)
            if tok.startswith("MSG:"):
                continue
            raise CMUcam4ProtocolError(f"{self.port}: expected ACK to {cmd!r}, got {tok!r}")

    def _skip_prompt(self, deadline: float) -> None:
        with contextlib.suppress(CMUcam4Timeout):
            while self._read_token(deadline) is not _PROMPT:
                pass

    def _lines_until_prompt(self, cmd: str, deadline: float) -> list[str]:
        lines: list[str] = []
        while True:
            tok = self._read_token(deadline)
            if tok is _PROMPT:
                return lines
            assert isinstance(tok, str)
            if tok.startswith("ERR:"):
                self._skip_prompt(deadline)
                text = tok[4:].strip()
                raise CMUcam4CameraError(f"{self.port}: {cmd!r} failed: {text}", text)
            if not tok.startswith("MSG:"):
                lines.append(tok)

    def command(self, cmd: str, *, timeout: float | None = None) -> list[str]:
        """Send one command; return the reply lines between ``ACK`` and the prompt.

        Raises ``CMUcam4NCK``, ``CMUcam4CameraError``, ``CMUcam4Timeout`` or
        ``CMUcam4ProtocolError``.
        """
        if "\r" in cmd or "\n" in cmd:
            raise ValueError(f"cmd must be a single line, got {cmd!r}")
        deadline = time.monotonic() + (timeout or self.timeout)
        self._write(cmd.encode("ascii") + b"\r")
        self._expect_ack(cmd, deadline)
        return self._lines_until_prompt(cmd, deadline)

    # --- connecting --------------------------------------------------------------------
    def connect(self) -> str:
        """The official library's sequence: reset, banner, ``BM 250000``, ``DM 0``.

        Returns the firmware version. Raises ``CMUcam4NotFound`` naming the port and
        what was received when no banner comes at any baud rate.
        """
        self.open()
        self.line_mode = False  # a reset clears every mode
        received = bytearray()
        last_exc: CMUcam4Error | None = None
        for _ in range(self.tries):
            for baud in BAUDS:
                try:
                    version = self._reset_at(baud, received)
                except CMUcam4Disconnected:
                    raise
                except CMUcam4Error as exc:
                    last_exc = exc
                    continue
                if version is None:
                    continue
                try:
                    self._switch_baud()
                    self.command("DM 0")
                except CMUcam4Disconnected:
                    raise
                except CMUcam4Error as exc:
                    last_exc = exc
                    continue
                self.version = version
                return version
        if last_exc is not None and received.find(BANNER) >= 0:
            raise CMUcam4NotFound(f"{self.port}: CMUcam4 found but setup failed: {last_exc}")
        what = repr(bytes(received[:48])) if received else "nothing"
        raise CMUcam4NotFound(
            f"no CMUcam4 on {self.port}: no banner at {'/'.join(map(str, BAUDS))} baud "
            f"in {self.tries} tries; received {what}"
            + (f" ({len(received)} bytes)" if len(received) > 48 else "")
        )

    def _reset_at(self, baud: int, received: bytearray) -> str | None:
        ser = self._port()
        try:
            ser.baudrate = baud
            ser.reset_input_buffer()
        except (serial.SerialException, OSError) as exc:
            raise CMUcam4Disconnected(f"{self.port} disappeared: {exc}") from None
        self._buf.clear()
        self._write(b"\0\0\0\rRS\r")
        deadline = time.monotonic() + self.reset_timeout
        while True:
            idx = self._buf.find(BANNER)
            if idx >= 0:
                received += self._buf
                del self._buf[: idx + len(BANNER)]
                break
            if len(self._buf) > 4096:  # keep only the tail: the banner may straddle
                received += self._buf[:-16]
                del self._buf[:-16]
            if not self._fill(deadline):
                received += self._buf
                self._buf.clear()
                return None
        line = self._read_token(deadline, limit=64)
        if not isinstance(line, str):
            raise CMUcam4ProtocolError(f"{self.port}: malformed banner")
        while self._read_token(deadline) is not _PROMPT:
            pass
        return line.strip()

    def _switch_baud(self) -> None:
        deadline = time.monotonic() + self.timeout
        self._write(f"BM {self.baud}\r".encode())
        self._expect_ack(f"BM {self.baud}", deadline)
        try:
            self._port().flush()
            self._port().baudrate = self.baud
        except (serial.SerialException, OSError) as exc:
            raise CMUcam4Disconnected(f"{self.port} disappeared: {exc}") from None
        self._buf.clear()
        deadline = time.monotonic() + self.timeout
        self._write(b"\r")
        self._expect_ack(f"BM {self.baud} handshake", deadline)
        while self._read_token(deadline) is not _PROMPT:
            pass

    def resync(self) -> None:
        """Regain the command prompt after garbage, a timeout or an aborted stream.

        Sends ``\\r`` (ends any stream or frame), drains until quiet, then checks that an
        empty command gets ``ACK``. Raises ``CMUcam4Error`` if the camera does not answer
        (the caller should :meth:`connect` again).
        """
        self._write(b"\r")
        self._drain(quiet=min(0.1, self.timeout), limit=self.timeout * 2)
        deadline = time.monotonic() + self.timeout
        self._write(b"\r")
        try:
            self._expect_ack("resync", deadline)
            while self._read_token(deadline) is not _PROMPT:
                pass
        except CMUcam4Error as exc:
            raise CMUcam4ProtocolError(f"{self.port}: cannot resynchronise: {exc}") from None

    # --- commands ----------------------------------------------------------------------
    def get_version(self) -> str:
        lines = self.command("GV")
        if not lines or not lines[0].startswith("CMUcam4 v"):
            raise CMUcam4ProtocolError(f"{self.port}: unexpected GV reply {lines!r}")
        return lines[0].strip()

    def configure(self, settings: CMUcam4Settings | None = None) -> None:
        """Send the settings (defaults: the seed's)."""
        for cmd in (settings or CMUcam4Settings()).commands():
            self.command(cmd)

    def set_poll_mode(self, on: bool) -> None:
        self.command(f"PM {int(on)}")

    def set_line_mode(self, on: bool) -> None:
        """``LM``: each T/S packet then carries the 80x60 bitmap of tracked pixels."""
        self.command(f"LM {int(on)}")
        self.line_mode = bool(on)

    def set_tracking_colors(self, colors: tuple[int, int, int, int, int, int] | None) -> None:
        """``ST``: (rmin, rmax, gmin, gmax, bmin, bmax), or ``None`` for the defaults."""
        self.command("ST" + _color_args(colors))

    def get_tracking_colors(self) -> tuple[int, ...]:
        lines = self.command("GT")
        try:
            return tuple(int(w) for w in lines[0].split())
        except (IndexError, ValueError):
            raise CMUcam4ProtocolError(f"{self.port}: unexpected GT reply {lines!r}") from None

    def set_tracking_window(self, window: tuple[int, int, int, int] | None) -> None:
        """``SW``: (x1, y1, x2, y2) in the 160x120 tracking image, or ``None`` (full)."""
        if window is not None:
            x1, y1, x2, y2 = (int(v) for v in window)
            if not (0 <= x1 <= x2 <= 159 and 0 <= y1 <= y2 <= 119):
                raise ValueError(f"window must lie in 0..159 x 0..119, got {window}")
            self.command(f"SW {x1} {y1} {x2} {y2}")
        else:
            self.command("SW")

    def snapshot(
        self,
        width: int = 160,
        height: int = 120,
        *,
        should_abort: Callable[[], bool] | None = None,
    ) -> Snapshot:
        """``SF``: one frame, decoded exactly (column-major RGB565, low byte first).

        Each column must arrive within ``timeout`` s. ``should_abort`` is polled between
        columns; when it returns True the transfer is stopped (``\\r``) and
        ``CMUcam4Error`` raised. On a camera error or lost sync the driver resynchronises
        before raising, so the next command works.
        """
        h, v = resolution_to_hv(width, height)
        cmd = f"SF {h} {v}"
        deadline = time.monotonic() + self.timeout
        self._write(cmd.encode() + b"\r")
        self._expect_ack(cmd, deadline)
        col_bytes = 2 * height
        data = bytearray(width * col_bytes)
        t_start = t_end = time.monotonic()
        try:
            for x in range(width):
                if should_abort is not None and should_abort():
                    self.resync()
                    raise CMUcam4Error(f"{self.port}: snapshot aborted")
                deadline = time.monotonic() + self.timeout
                head = self._read_exact(5, deadline, f"column {x} of {width}")
                if head != b"DAT: ":
                    self._column_trouble(cmd, x, head, deadline)
                data[x * col_bytes : (x + 1) * col_bytes] = self._read_exact(
                    col_bytes, deadline, f"pixels of column {x}"
                )
                tail = self._read_exact(1, deadline, f"end of column {x}")
                if tail != b"\r":
                    self.resync()
                    raise CMUcam4ProtocolError(
                        f"{self.port}: column {x} does not end with CR (got {tail!r}); resynced"
                    )
                if x == 0:
                    t_start = time.monotonic()
                t_end = time.monotonic()
            tok = self._read_token(time.monotonic() + self.timeout)
            if tok is not _PROMPT:
                self.resync()
                raise CMUcam4ProtocolError(f"{self.port}: {cmd}: expected ':' after the frame")
        except CMUcam4Timeout:
            self._recover_after_timeout()
            raise
        return Snapshot(
            decode_rgb565(bytes(data), width, height), t_start, t_end, len(data) + width * 6 + 1
        )

    def _column_trouble(self, cmd: str, x: int, head: bytes, deadline: float) -> None:
        if head.startswith(b"ERR:"):
            self._buf[:0] = head
            line = self._read_token(deadline)
            self._skip_prompt(deadline)
            text = str(line)[4:].strip()
            raise CMUcam4CameraError(f"{self.port}: {cmd} failed at column {x}: {text}", text)
        self._buf[:0] = head
        seen = bytes(self._buf[:32])
        self.resync()
        raise CMUcam4ProtocolError(
            f"{self.port}: {cmd}: expected 'DAT: ' for column {x}, got {seen!r}; resynced"
        )

    def _recover_after_timeout(self) -> None:
        """After a timeout the camera may still be sending: try to regain the prompt."""
        with contextlib.suppress(CMUcam4Error):
            self.resync()

    def dump_frame(self, width: int = 640, height: int = 480) -> None:
        """``DF``: write a BMP to the camera's microSD card (read it with ``read_dump_bmp``).

        The v1.02 subset has no command to read files back over serial; take the card out
        (or read the stand-in's SD directory). Waits up to ``long_timeout`` s.
        """
        h, v = resolution_to_hv(width, height)
        self.command(f"DF {h} {v}", timeout=self.long_timeout)

    def track(
        self,
        colors: tuple[int, int, int, int, int, int] | None = None,
        *,
        window: tuple[int, int, int, int] | None = None,
        packet_timeout: float | None = None,
    ) -> PacketStream:
        """Start colour tracking (``TC``): a stream of :class:`TPacket` at about 30 Hz.

        ``colors`` = (rmin, rmax, gmin, gmax, bmin, bmax). Use as a context manager;
        each ``next()`` waits at most ``packet_timeout`` s (default: ``timeout``).
        """
        if window is not None:
            self.set_tracking_window(window)
        return PacketStream(self, "TC" + _color_args(colors), packet_timeout or self.timeout)

    def statistics(self, *, packet_timeout: float | None = None) -> PacketStream:
        """Start ``GM``: a stream of :class:`SPacket` (colour statistics)."""
        return PacketStream(self, "GM", packet_timeout or self.timeout)


def _color_args(colors: tuple[int, ...] | None) -> str:
    if colors is None:
        return ""
    vals = [int(c) for c in colors]
    if len(vals) != 6 or not all(0 <= c <= 255 for c in vals):
        raise ValueError(
            f"colors must be 6 values 0..255 (rmin rmax gmin gmax bmin bmax), got {colors}"
        )
    return " " + " ".join(map(str, vals))


class PacketStream:
    """An open ``T``/``S`` packet stream; iterate for packets, close to stop it.

    ``next()`` raises ``CMUcam4Timeout`` when no packet comes within the packet timeout,
    ``CMUcam4CameraError`` on ``ERR:``, ``CMUcam4ProtocolError`` on garbage (for instance
    a reboot banner) and ``StopIteration`` when the camera ends the stream (poll mode).
    """

    def __init__(self, cam: CMUcam4, cmd: str, packet_timeout: float) -> None:
        self._cam = cam
        self._cmd = cmd
        self._timeout = float(packet_timeout)
        self._open = False
        self.packets = 0
        deadline = time.monotonic() + cam.timeout
        cam._write(cmd.encode() + b"\r")
        cam._expect_ack(cmd, deadline)
        self._open = True

    def __iter__(self) -> Iterator[TPacket | SPacket]:
        return self

    def __next__(self) -> TPacket | SPacket:
        if not self._open:
            raise StopIteration
        cam = self._cam
        while True:
            tok = cam._read_token(time.monotonic() + self._timeout, limit=256)
            if tok is _PROMPT:
                self._open = False
                raise StopIteration
            assert isinstance(tok, str)
            if tok.startswith("MSG:"):
                continue
            if tok.startswith("ERR:"):
                self._open = False
                cam._skip_prompt(time.monotonic() + cam.timeout)
                text = tok[4:].strip()
                raise CMUcam4CameraError(f"{cam.port}: {self._cmd} stream: {text}", text)
            now = time.monotonic()
            try:
                if tok.startswith("T "):
                    vals = _parse_ints(tok, "T", 8)
                    bitmap = self._bitmap()
                    self.packets += 1
                    mx, my, x1, y1, x2, y2, pixels, confidence = vals
                    return TPacket(mx, my, x1, y1, x2, y2, pixels, confidence, t=now, bitmap=bitmap)
                if tok.startswith("S "):
                    vals = _parse_ints(tok, "S", 12)
                    bitmap = self._bitmap()
                    self.packets += 1
                    return SPacket(
                        (vals[0], vals[1], vals[2]),
                        (vals[3], vals[4], vals[5]),
                        (vals[6], vals[7], vals[8]),
                        (vals[9], vals[10], vals[11]),
                        t=now,
                        bitmap=bitmap,
                    )
            except ValueError:
                pass
            self._open = False
            raise CMUcam4ProtocolError(f"{cam.port}: {self._cmd} stream: unexpected {tok[:40]!r}")

    def _bitmap(self) -> np.ndarray | None:
        """Line mode: read ``F `` + 600 bytes + CR by count (binary: never scanned)."""
        cam = self._cam
        if not cam.line_mode:
            return None
        raw = cam._read_exact(603, time.monotonic() + self._timeout, "line-mode bitmap")
        if raw[:2] != b"F " or raw[-1:] != b"\r":
            self._open = False
            raise CMUcam4ProtocolError(f"{cam.port}: malformed line-mode bitmap {raw[:8]!r}")
        bits = np.unpackbits(np.frombuffer(raw[2:602], np.uint8), bitorder="big")
        return bits.reshape(60, 80).astype(bool)

    def close(self) -> None:
        """Stop the stream (``\\r``) and wait for the prompt; resync if it goes wrong."""
        if not self._open:
            return
        self._open = False
        cam = self._cam
        try:
            cam._write(b"\r")
            deadline = time.monotonic() + cam.timeout
            while (tok := cam._read_token(deadline, limit=256)) is not _PROMPT:
                if cam.line_mode and isinstance(tok, str) and tok[:2] in ("T ", "S "):
                    cam._read_exact(603, deadline, "line-mode bitmap")
        except CMUcam4Disconnected:
            raise
        except CMUcam4Error:
            cam.resync()

    def __enter__(self) -> PacketStream:
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.close()
        except CMUcam4Error:
            if exc[0] is None:
                raise


# --- the frame source ----------------------------------------------------------------


def sf_seconds(width: int, height: int, baud: int = 250000) -> float:
    """Expected ``SF`` duration: one column per 30 Hz camera frame, longer if the bytes
    of a column take more than a frame on the wire (640x480: about 43 s)."""
    col_time = (2 * height + 6) * 10 / baud
    return width * math.ceil(col_time / (1 / 30) - 1e-9) / 30 + col_time


class CMUcam4Source(ThreadedSource):
    """Stills from a CMUcam4: ``SF`` snapshots in a loop (a frame every few seconds).

    ``t_capture`` is the middle of the transfer (each column comes from a different
    camera frame). :meth:`track` borrows the port for a ``T`` packet stream; snapshots
    pause meanwhile. On any error the port is re-opened with backoff.
    """

    def __init__(
        self,
        port: str,
        *,
        resolution: tuple[int, int] | str = (160, 120),
        settings: CMUcam4Settings | None = None,
        name: str | None = None,
        stall_after: float | None = None,
        timeout: float = 1.0,
        reset_timeout: float = 2.25,
        tries: int = 1,
        backoff: tuple[float, float] = (0.5, 10.0),
    ) -> None:
        if isinstance(resolution, str):
            resolution = parse_resolution(resolution)
        self.width, self.height = int(resolution[0]), int(resolution[1])
        resolution_to_hv(self.width, self.height)
        super().__init__(name or f"cmucam4:{port}", stall_after=stall_after, backoff=backoff)
        self.cam = CMUcam4(port, timeout=timeout, reset_timeout=reset_timeout, tries=tries)
        self.settings = settings or CMUcam4Settings()
        self.expected_period = sf_seconds(self.width, self.height)
        self._port_lock = threading.Lock()
        self._want_port = threading.Event()
        self._connected = False

    def _open(self) -> None:
        with self._port_lock:
            self.cam.close()
            if self._stop.is_set():  # close() came first: its cancel was just cleared
                raise CMUcam4Error(f"{self.cam.port}: closing")
            self.cam.connect()
            self.cam.configure(self.settings)
            self._connected = True

    def _grab(self) -> tuple[np.ndarray, float, dict] | None:
        if self._want_port.is_set():
            self._sleep(0.05)
            return None
        with self._port_lock:
            if not self._connected:
                raise CMUcam4Error(f"{self.cam.port}: lost the connection while tracking")
            try:
                snap = self.cam.snapshot(
                    self.width, self.height, should_abort=self._want_port.is_set
                )
            except (CMUcam4CameraError, CMUcam4NCK) as exc:
                # The driver has the prompt back: count it and try the next frame
                # without reconnecting.
                self._record_error(str(exc))
                self._sleep(min(0.2, self.cam.timeout))
                return None
            except CMUcam4Error as exc:
                if self._want_port.is_set() and "aborted" in str(exc):
                    return None
                raise
        info = {
            "resolution": (self.width, self.height),
            "sf_started": snap.t_start,
            "sf_finished": snap.t_end,
            "sf_seconds": snap.t_end - snap.t_start,
            "bytes": snap.nbytes,
            "version": self.cam.version,
        }
        return snap.image, snap.t_mid, info

    def _release(self) -> None:
        self._connected = False
        self.cam.close()

    def _interrupt(self) -> None:
        self.cam.cancel()

    @contextlib.contextmanager
    def track(
        self,
        colors: tuple[int, int, int, int, int, int] | None = None,
        *,
        window: tuple[int, int, int, int] | None = None,
        packet_timeout: float = 1.0,
        wait: float = 10.0,
    ) -> Iterator[PacketStream]:
        """Borrow the port for a ``T`` packet stream (30 Hz colour blob of the pad).

        Stops the current snapshot (``\\r`` aborts ``SF``), yields the stream, and gives
        the port back to the snapshot loop on exit. ``CMUcam4Error`` if the port is not
        free within ``wait`` s or the camera is not connected.
        """
        self._want_port.set()
        self._set_paused(True)
        try:
            if not self._port_lock.acquire(timeout=wait):
                raise CMUcam4Timeout(f"{self.cam.port}: port busy for {wait} s")
            try:
                if not self._connected:
                    raise CMUcam4Error(
                        f"{self.cam.port}: camera not connected "
                        f"({self.status.last_error or 'starting'})"
                    )
                try:
                    with self.cam.track(
                        colors, window=window, packet_timeout=packet_timeout
                    ) as stream:
                        yield stream
                except CMUcam4Error:
                    self._connected = False  # make the loop reconnect
                    raise
            finally:
                self._port_lock.release()
        finally:
            self._want_port.clear()
            self._set_paused(False)


# --- CLI -----------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m backend.camera.cmucam4",
        description="Take a snapshot from a CMUcam4 on a serial port.",
    )
    parser.add_argument("port", help="serial device, e.g. /dev/ttyUSB0")
    parser.add_argument("--snapshot", type=Path, required=True, metavar="OUT.png")
    parser.add_argument(
        "--res", default="160x120", help="640/320/160/80 x 480/240/120/60 (default 160x120)"
    )
    parser.add_argument("--timeout", type=float, default=1.0, help="reply/column timeout, s")
    parser.add_argument(
        "--reset-timeout",
        type=float,
        default=2.25,
        help="wait for the banner after RS at each baud, s",
    )
    parser.add_argument("--tries", type=int, default=1, help="rounds over the baud rates")
    ns = parser.parse_args(argv)
    try:
        import cv2

        width, height = parse_resolution(ns.res)
        with CMUcam4(
            ns.port, timeout=ns.timeout, reset_timeout=ns.reset_timeout, tries=ns.tries
        ) as cam:
            cam.configure()
            snap = cam.snapshot(width, height)
            version = cam.version
        if not cv2.imwrite(str(ns.snapshot), snap.image):
            raise CMUcam4Error(f"cannot write {ns.snapshot}")
    except (CMUcam4Error, ValueError) as exc:
        print(f"error: {str(exc).splitlines()[0]}", file=sys.stderr)
        return 1
    print(
        f"{ns.snapshot}: {width}x{height} in {snap.t_end - snap.t_start:.2f} s (CMUcam4 {version})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
