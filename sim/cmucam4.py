"""A CMUcam4 stand-in on a pseudo-terminal: the real byte protocol with its real timing.

``python -m sim.cmucam4 [--scale-time K] [--image PATH] [--fault ...]`` opens a pty
pair, prints the device path (the slave end) on one line and serves the camera on the
master end until interrupted. Point the driver (or any serial terminal) at that path.

What it emulates (``specs/cmucam4.md``, firmware v1.02):

- boot banner at 19,200 baud, ``RS`` reboot, ``BM`` baud switching with the ``\\r``
  handshake at the new rate, ``DM`` extra stop bits;
- *baud mismatch*: the pty has no real line rate, so the board reads the host's termios
  speed on the slave it keeps open; bytes sent at a rate the board is not using are
  dropped (framing errors) and the board's bytes reach such a host scrambled;
- pacing: every byte takes ``(10 + DM) / baud`` seconds and the camera makes a frame
  every 1/30 s, both multiplied by ``time_scale`` (1 = real time, 0 = no pacing);
  ``SF`` sends one column per camera frame, so 160x120 takes about 5.3 s at scale 1;
- ``SF``/``DF`` frames, ``T`` and ``S`` packet streams (``TC``/``TW``/``GM``), poll mode,
  ``GV``/``GT``/``GW``, the 0/1 settings, unknown commands -> ``NCK``, input normalisation;
- faults for tests (:class:`Faults`): garbage before the banner, a board that only
  talks garbage, ``ERR: Camera Timeout Error`` mid-frame, ``NCK`` for chosen commands,
  a reboot mid-stream, the port disappearing, and :meth:`CMUcam4Board.set_silent`.

The picture comes from a still image or a callable returning BGR frames (the simulated
camera), resized to the requested resolution. A callable that returns ``None`` makes the
camera time out (``ERR: Camera Timeout Error``), as a real camera with no frame does.

Why one module of ~800 lines: it is one board's firmware behaviour (its command table,
its pacing and its faults act on the same state machine); it is test rig, not shipped
station code.
"""

from __future__ import annotations

import argparse
import array
import contextlib
import fcntl
import os
import select
import shutil
import signal
import struct
import sys
import tempfile
import termios
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from backend.camera.rgb565 import encode_column, sf_resolution, write_dump_bmp

VERSION = "1.02"
BOOT_BAUD = 19200
FRAME_PERIOD = 1 / 30
_TCGETS2 = 0x802C542A  # Linux x86-64/arm64 ioctl: struct termios2 with the exact speeds


@dataclass(frozen=True)
class Faults:
    """Faults to inject. Mid-frame faults fire on the first ``times`` occasions (0 = always).

    Attributes
    ----------
    garbage_before_banner : int
        Random bytes sent before every boot banner.
    garbage_only : bool
        Never speak the protocol: answer any input with random bytes.
    timeout_at_column : int | None
        ``SF``: send ``ERR: Camera Timeout Error`` instead of this column.
    nck : tuple of str
        Commands answered ``NCK`` although valid (e.g. ``("SF",)``).
    reset_at_column : int | None
        ``SF``: the board reboots (back to 19,200 baud, banner) at this column.
    reset_after_packets : int | None
        ``T``/``S`` streams: the board reboots after this many packets.
    disappear_at_column : int | None
        ``SF``: the pty closes at this column (the port disappears).
    times : int
        How many times each mid-frame fault fires.
    """

    garbage_before_banner: int = 0
    garbage_only: bool = False
    timeout_at_column: int | None = None
    nck: tuple[str, ...] = ()
    reset_at_column: int | None = None
    reset_after_packets: int | None = None
    disappear_at_column: int | None = None
    times: int = 1

    @classmethod
    def parse(cls, items: list[str]) -> Faults:
        """Parse CLI fault words: ``garbage[=N]``, ``garbage-only``, ``timeout@COL``,
        ``nck:CMD``, ``reset@COL``, ``reset-packets@N``, ``disappear@COL``, ``times=N``."""
        kw: dict = {}
        nck: list[str] = []
        for item in items:
            word, _, arg = item.replace("@", "=").replace(":", "=").partition("=")
            try:
                if word == "garbage":
                    kw["garbage_before_banner"] = int(arg or 64)
                elif word == "garbage-only":
                    kw["garbage_only"] = True
                elif word == "timeout":
                    kw["timeout_at_column"] = int(arg)
                elif word == "nck":
                    if not arg:
                        raise ValueError
                    nck.append(arg.upper())
                elif word == "reset":
                    kw["reset_at_column"] = int(arg)
                elif word == "reset-packets":
                    kw["reset_after_packets"] = int(arg)
                elif word == "disappear":
                    kw["disappear_at_column"] = int(arg)
                elif word == "times":
                    kw["times"] = int(arg)
                else:
                    raise ValueError
            except ValueError:
                raise ValueError(f"fault: cannot understand {item!r}") from None
        return cls(nck=tuple(nck), **kw)


class _Reboot(Exception):
    pass


class _Gone(Exception):
    pass


class _Abort(Exception):
    pass


@dataclass
class _State:
    baud: int = BOOT_BAUD
    stop_bits: int = 0
    poll: bool = False
    settings: dict[str, int] = field(default_factory=dict)
    colors: tuple[int, ...] = (0, 255, 0, 255, 0, 255)
    window: tuple[int, int, int, int] = (0, 0, 159, 119)


def default_picture() -> np.ndarray:
    """A 640x480 view of the helipad from 2 m, rendered by the simulated camera."""
    return sim_frame_source(0.0, 0.0, -2.0, 0.0)()


def sim_frame_source(
    north: float, east: float, down: float, yaw_deg: float, *, snr_db: float | None = None
) -> Callable[[], np.ndarray]:
    """Frames of the simulated camera from a fixed vehicle pose (pad at the origin)."""
    from sim.camera import PadRenderer, SimCameraConfig, VehiclePose

    renderer = PadRenderer(SimCameraConfig(floor="textured", snr_db=snr_db))

    def frame() -> np.ndarray:
        pose = VehiclePose((north, east, down), 0.0, 0.0, np.radians(yaw_deg), time.monotonic())
        return renderer.render(pose)[0]

    return frame


class CMUcam4Board:
    """The stand-in board. ``start()`` opens the pty; :attr:`path` is the device to open.

    Parameters
    ----------
    time_scale : float
        Multiplies every emulated duration (byte times, camera frames, boot). 1 is real
        time; 0.02 makes a 160x120 ``SF`` take about 0.1 s; 0 disables pacing.
    image : ndarray, optional
        A still BGR picture to serve.
    frame_source : callable, optional
        Returns the current BGR picture (or ``None``: no camera frame). Wins over ``image``.
    faults : Faults, optional
    sd_dir : path, optional
        The "SD card" for ``DF`` dumps; a temporary directory (removed on close) if omitted.
    seed : int
        Seeds the garbage generator.
    """

    def __init__(
        self,
        *,
        time_scale: float = 1.0,
        image: np.ndarray | None = None,
        frame_source: Callable[[], np.ndarray | None] | None = None,
        faults: Faults | None = None,
        sd_dir: str | Path | None = None,
        seed: int = 0,
        boot_delay: float = 0.5,
    ) -> None:
        if not time_scale >= 0:
            raise ValueError(f"time_scale must be >= 0, got {time_scale}")
        if image is not None:
            image = np.asarray(image)
            if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
                raise ValueError(f"image must be BGR uint8 HxWx3, got {image.dtype} {image.shape}")
        self.time_scale = float(time_scale)
        self._image = image if image is not None else (None if frame_source else default_picture())
        self._frame_source = frame_source
        self.faults = faults or Faults()
        self._own_sd = sd_dir is None
        self.sd_dir = Path(sd_dir) if sd_dir is not None else Path(tempfile.mkdtemp(prefix="sd-"))
        self.sd_dir.mkdir(parents=True, exist_ok=True)
        self._rng = np.random.default_rng(seed)
        self._boot_delay = float(boot_delay)
        self._master = -1
        self._slave = -1
        self.path = ""
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._silent = threading.Event()
        self._st = _State()
        self._line = bytearray()
        self._clock = 0.0
        self._fired: dict[str, int] = {}
        self._pic_cache: tuple[float, np.ndarray | None] | None = None
        self.commands: list[str] = []  # every command line executed, for tests
        self.dropped_bytes = 0  # host bytes lost to a baud mismatch
        self.boots = 0

    # --- lifecycle ---------------------------------------------------------------------
    def start(self) -> str:
        """Open the pty pair, boot, and serve in a thread. Returns the device path."""
        if self._thread is not None:
            return self.path
        self._master, self._slave = os.openpty()
        self.path = os.ttyname(self._slave)
        # Raw slave: no echo, no CR/NL translation (pyserial sets this too).
        attrs = termios.tcgetattr(self._slave)
        attrs[0] = attrs[1] = attrs[3] = 0
        attrs[2] = termios.CS8 | termios.CREAD | termios.CLOCAL
        termios.tcsetattr(self._slave, termios.TCSANOW, attrs)
        os.set_blocking(self._master, False)
        self._thread = threading.Thread(target=self._serve, name="cmucam4-board", daemon=True)
        self._thread.start()
        return self.path

    def close(self) -> None:
        """Stop serving, close the pty (the device disappears) and clean up."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
        self._close_fds()
        if self._own_sd:
            shutil.rmtree(self.sd_dir, ignore_errors=True)

    def __enter__(self) -> CMUcam4Board:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def set_silent(self, silent: bool) -> None:
        """Stop (or resume) talking: input is ignored and nothing is sent, like a hung board."""
        if silent:
            self._silent.set()
        else:
            self._silent.clear()

    @property
    def baud(self) -> int:
        return self._st.baud

    def _close_fds(self) -> None:
        for fd in (self._master, self._slave):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = -1

    # --- the byte level ----------------------------------------------------------------
    def _host_baud(self) -> int | None:
        slave = self._slave
        if slave < 0:  # closed under a board still serving (close() gave up waiting)
            raise _Gone
        try:
            buf = array.array("i", [0] * 16)
            fcntl.ioctl(slave, _TCGETS2, buf)
            return struct.unpack_from("I", buf.tobytes(), 36)[0]
        except OSError:
            return None  # unknown: assume the host matches

    def _mismatch(self) -> bool:
        host = self._host_baud()
        return host is not None and host != self._st.baud

    def _byte_time(self) -> float:
        return (10 + self._st.stop_bits) / self._st.baud * self.time_scale

    def _pace(self, seconds: float) -> None:
        """Advance the emulated clock; sleep when it runs ahead of real time."""
        now = time.monotonic()
        self._clock = max(self._clock, now) + seconds
        ahead = self._clock - now
        if ahead > 0.002 and self._stop.wait(ahead):
            raise _Gone

    def _wait_frame(self) -> None:
        """Wait for the camera's next frame tick (1/30 s, scaled)."""
        period = FRAME_PERIOD * self.time_scale
        if period <= 0:
            return
        now = max(self._clock, time.monotonic())
        self._pace((np.floor(now / period) + 1) * period - now)

    def _send(self, data: bytes) -> None:
        if self._silent.is_set() or not data:
            return
        if self._mismatch():
            data = bytes(self._rng.integers(0, 256, len(data), dtype=np.uint8))
        bt = self._byte_time()
        # Pace in slices of ~10 ms so the wire timing is right at any scale.
        step = max(1, int(0.01 / bt)) if bt > 0 else len(data)
        for i in range(0, len(data), step):
            if self._stop.is_set():  # _pace notices only when ahead of real time
                raise _Gone
            chunk = data[i : i + step]
            self._write(chunk)
            self._pace(len(chunk) * bt)

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        deadline = time.monotonic() + 0.2
        while view:
            try:
                n = os.write(self._master, view)
                view = view[n:]
            except BlockingIOError:
                # A host that does not read loses bytes, as with a real UART overrun.
                if time.monotonic() > deadline:
                    return
                select.select([], [self._master], [], 0.02)
            except OSError as exc:
                raise _Gone from exc

    def _poll_input(self, timeout: float) -> bytes:
        """Bytes the host sent (at the board's rate) within ``timeout``; b"" if none."""
        try:
            ready, _, _ = select.select([self._master], [], [], max(0.0, timeout))
        except (OSError, ValueError) as exc:
            raise _Gone from exc
        if not ready:
            return b""
        try:
            data = os.read(self._master, 4096)
        except BlockingIOError:
            return b""
        except OSError:
            # EIO: no process has the slave open right now; keep waiting for one.
            self._stop.wait(min(timeout, 0.05))
            return b""
        if self._silent.is_set():
            return b""
        if self._mismatch():
            self.dropped_bytes += len(data)
            return b""
        return data

    def _host_sent_cr(self) -> bool:
        """During a stream: did the host send a carriage return (abort)?"""
        return b"\r" in self._poll_input(0.0)

    # --- serving -----------------------------------------------------------------------
    def _serve(self) -> None:
        try:
            self._boot(first=True)
            while not self._stop.is_set():
                data = self._poll_input(0.05)
                if self._stop.is_set():
                    break
                for byte in data:
                    if self.faults.garbage_only:
                        self._send(self._garbage(8))
                        continue
                    line = self._feed(byte)
                    if line is None:
                        continue
                    try:
                        self._execute(line)
                    except _Reboot:
                        self._line.clear()
                        self._boot()
                        break
        except _Gone:
            pass
        finally:
            self._close_fds()

    def _garbage(self, n: int) -> bytes:
        # No 'C' so garbage can never spell the banner by chance.
        data = self._rng.integers(0, 256, n, dtype=np.uint8)
        data[data == ord("C")] = ord("c")
        return bytes(data)

    def _boot(self, first: bool = False) -> None:
        self._st = _State()
        self.boots += 1
        if first:
            # The power-up banner goes out before any host has opened the port: lost.
            return
        self._pace(self._boot_delay * self.time_scale)
        if self.faults.garbage_only:
            self._send(self._garbage(32))
            return
        if self.faults.garbage_before_banner:
            self._send(self._garbage(self.faults.garbage_before_banner))
        self._send(f"\rCMUcam4 v{VERSION}\r:".encode())

    def _feed(self, byte: int) -> str | None:
        """Input normalisation; returns a complete command line at ``\\r``."""
        if byte == 0x0D:
            line = self._line.decode("ascii")
            self._line.clear()
            return line
        if byte in (0x08, 0x7F):
            if self._line:
                self._line.pop()
        elif byte == 0x09:
            self._append(0x20)
        elif 0x20 <= byte < 0x7F:
            self._append(ord(chr(byte).upper()))
        return None  # other non-printables are dropped

    def _append(self, byte: int) -> None:
        if len(self._line) < 255:
            self._line.append(byte)

    def _fire(self, name: str, column_or_count: int, at: int | None) -> bool:
        if at is None or column_or_count != at:
            return False
        n = self._fired.get(name, 0)
        if self.faults.times and n >= self.faults.times:
            return False
        self._fired[name] = n + 1
        return True

    # --- commands ----------------------------------------------------------------------
    def _execute(self, line: str) -> None:
        self.commands.append(line)
        words = line.split()
        if not words:
            self._send(b"ACK\r:")
            return
        cmd, args = words[0], [_number(w) for w in words[1:]]
        if cmd in self.faults.nck:
            self._send(b"NCK\r:")
            return
        handler = getattr(self, f"_cmd_{cmd}", None)
        if cmd in _FLAGS:
            handler = self._cmd_flag
        if handler is None:
            self._send(b"NCK\r:")
            return
        handler(cmd, args)

    def _ack(self, text: str = "") -> None:
        self._send(b"ACK\r" + text.encode() + b":")

    def _cmd_flag(self, cmd: str, args: list[int]) -> None:
        if not args:
            self._send(b"NCK\r:")
            return
        self._st.settings[cmd] = 1 if args[0] else 0
        if cmd == "PM":
            self._st.poll = bool(args[0])
        self._ack()

    def _cmd_GV(self, cmd: str, args: list[int]) -> None:
        self._ack(f"CMUcam4 v{VERSION}\r")

    def _cmd_RS(self, cmd: str, args: list[int]) -> None:
        self._send(b"ACK\r")
        raise _Reboot

    def _cmd_BM(self, cmd: str, args: list[int]) -> None:
        if not args or not 1 <= args[0] <= 250000:
            self._send(b"NCK\r:")
            return
        self._send(b"ACK\r")
        old, self._st.baud = self._st.baud, args[0]
        # Wait (bounded) for a carriage return at the new rate.
        deadline = time.monotonic() + max(1.0, 5.0 * self.time_scale)
        while time.monotonic() < deadline and not self._stop.is_set():
            if b"\r" in self._poll_input(0.02):
                self._send(b"ACK\r:")
                return
        self._st.baud = old
        self._send(b":")

    def _cmd_DM(self, cmd: str, args: list[int]) -> None:
        if not args:
            self._send(b"NCK\r:")
            return
        self._ack()
        self._st.stop_bits = max(0, min(args[0], 255))

    def _cmd_CB(self, cmd: str, args: list[int]) -> None:
        self._setting(cmd, args, -127, 127)

    def _cmd_CC(self, cmd: str, args: list[int]) -> None:
        self._setting(cmd, args, -31, 31)

    def _cmd_AP(self, cmd: str, args: list[int]) -> None:
        self._setting(cmd, args, -(2**31), 2**31)

    _cmd_AT = _cmd_AP

    def _cmd_L0(self, cmd: str, args: list[int]) -> None:
        self._ack()

    def _cmd_L1(self, cmd: str, args: list[int]) -> None:
        self._setting(cmd, args, -1, 2**31)

    def _setting(self, cmd: str, args: list[int], lo: int, hi: int) -> None:
        if not args:
            self._send(b"NCK\r:")
            return
        self._st.settings[cmd] = max(lo, min(args[0], hi))
        self._ack()

    def _cmd_ST(self, cmd: str, args: list[int]) -> None:
        if args and len(args) < 6:
            self._send(b"NCK\r:")
            return
        self._st.colors = tuple(args[:6]) if args else (0, 255, 0, 255, 0, 255)
        self._ack()

    def _cmd_SW(self, cmd: str, args: list[int]) -> None:
        if args and len(args) < 4:
            self._send(b"NCK\r:")
            return
        self._st.window = tuple(args[:4]) if args else (0, 0, 159, 119)  # type: ignore[assignment]
        self._ack()

    def _cmd_GT(self, cmd: str, args: list[int]) -> None:
        self._ack(" " + " ".join(map(str, self._st.colors)) + "\r")

    def _cmd_GW(self, cmd: str, args: list[int]) -> None:
        self._ack(" " + " ".join(map(str, self._st.window)) + "\r")

    def _cmd_TC(self, cmd: str, args: list[int]) -> None:
        if args and len(args) < 6:
            self._send(b"NCK\r:")
            return
        if args:
            self._st.colors = tuple(args[:6])
        self._send(b"ACK\r")
        self._stream(self._t_packet)

    def _cmd_TW(self, cmd: str, args: list[int]) -> None:
        if len(args) < 3:
            self._send(b"NCK\r:")
            return
        pic = self._picture(160, 120)
        if pic is None:
            self._send(b"ACK\rERR: Camera Timeout Error\r:")
            return
        x1, y1, x2, y2 = self._clamped_window()
        cx, cy = (x1 + x2) // 2, (y1 + y2) // 2
        win = pic[max(y1, cy - 10) : min(y2, cy + 10) + 1, max(x1, cx - 10) : min(x2, cx + 10) + 1]
        mean = win.reshape(-1, 3).mean(axis=0)[::-1]  # R, G, B
        colors: list[int] = []
        for m, r in zip(mean, args[:3], strict=True):
            colors += [int(max(0, m - r)), int(min(255, m + r))]
        self._st.colors = tuple(colors)
        self._send(b"ACK\r")
        self._stream(self._t_packet)

    def _cmd_GM(self, cmd: str, args: list[int]) -> None:
        self._send(b"ACK\r")
        self._stream(self._s_packet)

    def _stream(self, make: Callable[[np.ndarray], str]) -> None:
        """Stream one packet per camera frame until the host sends CR (or once in PM 1)."""
        count = 0
        while not self._stop.is_set():
            self._wait_frame()
            if self._host_sent_cr():
                break
            pic = self._picture(160, 120)
            if pic is None:
                self._send(b"ERR: Camera Timeout Error\r:")
                return
            packet = make(pic).encode() + b"\r"
            if self._st.settings.get("LM"):
                packet += b"F " + self._line_bitmap(pic) + b"\r"
            self._send(packet)
            count += 1
            if self._st.poll:
                break
            if self._fire("reset-packets", count, self.faults.reset_after_packets):
                raise _Reboot
        self._send(b":")

    def _clamped_window(self) -> tuple[int, int, int, int]:
        x1, y1, x2, y2 = self._st.window
        x1, x2 = sorted((max(0, min(x1, 159)), max(0, min(x2, 159))))
        y1, y2 = sorted((max(0, min(y1, 119)), max(0, min(y2, 119))))
        return x1, y1, x2, y2

    def _tracked(self, pic: np.ndarray) -> np.ndarray:
        """Pixels of the 160x120 picture inside the colour bounds and the window."""
        x1, y1, x2, y2 = self._clamped_window()
        rmin, rmax, gmin, gmax, bmin, bmax = self._st.colors
        p = pic.astype(np.int32)
        b, g, r = p[..., 0], p[..., 1], p[..., 2]
        mask = (r >= rmin) & (r <= rmax) & (g >= gmin) & (g <= gmax) & (b >= bmin) & (b <= bmax)
        inside = np.zeros_like(mask)
        inside[y1 : y2 + 1, x1 : x2 + 1] = True
        return mask & inside

    def _line_bitmap(self, pic: np.ndarray) -> bytes:
        """Line mode: the tracked pixels at 80x60, rows top down, MSB = leftmost pixel."""
        mask = self._tracked(pic).reshape(60, 2, 80, 2).any(axis=(1, 3))
        return np.packbits(mask, axis=1, bitorder="big").tobytes()

    def _t_packet(self, pic: np.ndarray) -> str:
        """Colour tracking: centroid, box, pixels and confidence (both 0..255 as %)."""
        x1, y1, x2, y2 = self._clamped_window()
        mask = self._tracked(pic)[y1 : y2 + 1, x1 : x2 + 1]
        n = int(mask.sum())
        if n == 0:
            return "T 0 0 0 0 0 0 0 0"
        ys, xs = np.nonzero(mask)
        bx1, bx2, by1, by2 = xs.min() + x1, xs.max() + x1, ys.min() + y1, ys.max() + y1
        mx, my = round(xs.mean()) + x1, round(ys.mean()) + y1
        pixels = round(255 * n / mask.size)
        confidence = round(255 * n / ((bx2 - bx1 + 1) * (by2 - by1 + 1)))
        return f"T {mx} {my} {bx1} {by1} {bx2} {by2} {pixels} {confidence}"

    def _s_packet(self, pic: np.ndarray) -> str:
        x1, y1, x2, y2 = self._clamped_window()
        win = pic[y1 : y2 + 1, x1 : x2 + 1].reshape(-1, 3)[:, ::-1]  # R, G, B
        mean = np.round(win.mean(axis=0)).astype(int)
        median = np.round(np.median(win, axis=0)).astype(int)
        mode = [int(np.bincount(win[:, i], minlength=256).argmax()) for i in range(3)]
        stdev = np.round(win.std(axis=0)).astype(int)
        vals = [*mean, *median, *mode, *stdev]
        return "S " + " ".join(str(int(v)) for v in vals)

    def _picture(self, width: int, height: int) -> np.ndarray | None:
        """The camera's current frame at ``width`` x ``height`` (None: no frame)."""
        if self._frame_source is not None:
            now = time.monotonic()
            # The callable may be slow (rendering): ask at most 30 times a real second.
            if self._pic_cache is None or now - self._pic_cache[0] >= FRAME_PERIOD:
                try:
                    pic = self._frame_source()
                except Exception:
                    pic = None
                self._pic_cache = (now, pic)
            pic = self._pic_cache[1]
        else:
            pic = self._image
        if pic is None:
            return None
        if pic.shape[:2] != (height, width):
            pic = cv2.resize(pic, (width, height), interpolation=cv2.INTER_AREA)
        return pic

    def _hv(self, args: list[int]) -> tuple[int, int] | None:
        if len(args) < 2 or not (0 <= args[0] <= 3 and 0 <= args[1] <= 3):
            return None
        return sf_resolution(args[0], args[1])

    def _cmd_SF(self, cmd: str, args: list[int]) -> None:
        size = self._hv(args)
        if size is None:
            self._send(b"NCK\r:")
            return
        width, height = size
        self._send(b"ACK\r")
        for x in range(width):
            # Each column comes from a new camera frame (a moving scene shears).
            self._wait_frame()
            if self._host_sent_cr():
                break
            if self._fire("disappear", x, self.faults.disappear_at_column):
                self._close_fds()
                raise _Gone
            if self._fire("reset", x, self.faults.reset_at_column):
                raise _Reboot
            pic = self._picture(width, height)
            if pic is None or self._fire("timeout", x, self.faults.timeout_at_column):
                self._send(b"ERR: Camera Timeout Error\r:")
                return
            self._send(b"DAT: " + encode_column(pic, x) + b"\r")
        self._send(b":")

    def _cmd_DF(self, cmd: str, args: list[int]) -> None:
        size = self._hv(args)
        if size is None:
            self._send(b"NCK\r:")
            return
        width, height = size
        self._send(b"ACK\r")
        pic = self._picture(width, height)
        if pic is None:
            self._send(b"ERR: Camera Timeout Error\r:")
            return
        numbers = [int(p.name[:5]) for p in self.sd_dir.glob("*BM.BMP") if p.name[:5].isdigit()]
        number = (max(numbers) + 1) % 65536 if numbers else 0
        # Writing to the card takes about a camera frame per column.
        for _ in range(width):
            self._wait_frame()
        try:
            write_dump_bmp(self.sd_dir / f"{number:05d}BM.BMP", pic)
        except OSError:
            self._send(b"ERR: Disk IO Error\r:")
            return
        self._send(b":")


_FLAGS = {"AG", "AW", "HM", "VF", "BW", "NG", "TM", "CT", "PM", "LM", "SM"}


def _number(word: str) -> int:
    """Signed decimal or 0x hex; anything else reads as 0 (as the firmware does)."""
    try:
        return int(word, 16) if word.lower().startswith(("0x", "-0x")) else int(word, 10)
    except ValueError:
        return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m sim.cmucam4",
        description="Serve a CMUcam4 stand-in on a pseudo-terminal; prints the device path.",
    )
    parser.add_argument(
        "--scale-time",
        type=float,
        default=1.0,
        metavar="K",
        help="multiply every emulated duration (1 = real time)",
    )
    parser.add_argument("--image", type=Path, help="still picture to serve")
    parser.add_argument(
        "--sim-pose",
        default="0,0,-2,0",
        metavar="N,E,D,YAW",
        help="without --image: serve the simulated camera from this vehicle pose "
        "(metres NED, yaw degrees; pad at the origin)",
    )
    parser.add_argument("--snr-db", type=float, help="sensor noise of the simulated camera")
    parser.add_argument("--sd-dir", type=Path, help="directory standing in for the SD card")
    parser.add_argument(
        "--fault",
        action="append",
        default=[],
        help="garbage[=N], garbage-only, timeout@COL, nck:CMD, reset@COL, "
        "reset-packets@N, disappear@COL, times=N (repeatable)",
    )
    ns = parser.parse_args(argv)
    try:
        faults = Faults.parse(ns.fault)
        image, frames = None, None
        if ns.image is not None:
            image = cv2.imread(str(ns.image), cv2.IMREAD_COLOR)
            if image is None:
                raise ValueError(f"image: cannot read a picture from {ns.image}")
        else:
            try:
                n, e, d, yaw = (float(v) for v in ns.sim_pose.split(","))
            except ValueError:
                raise ValueError(f"sim-pose must be N,E,D,YAW, got {ns.sim_pose!r}") from None
            frames = sim_frame_source(n, e, d, yaw, snr_db=ns.snr_db)
        board = CMUcam4Board(
            time_scale=ns.scale_time,
            image=image,
            frame_source=frames,
            faults=faults,
            sd_dir=ns.sd_dir,
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with board:
        print(board.path, flush=True)
        try:
            while not stop.wait(0.5):
                if board._thread is not None and not board._thread.is_alive():
                    break  # the port disappeared (fault) or the board stopped
        except KeyboardInterrupt:
            pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
