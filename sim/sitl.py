"""Genuine ArduCopter SITL for tests and benchmarks: start it, watch it, stop it.

:class:`Sitl` starts ``../shared/sitl/arducopter`` (ArduCopter 4.5.6 built for
software in the loop) in a fresh scratch directory (a fresh ``eeprom.bin``: a new
vehicle), ``--model +`` with the release's ``copter.parm``, on an instance number of
its own (``-I N`` moves every port by 10 N, so several may run at once), and stops
it with its whole process group, also when the test that started it fails.

:class:`SitlObserver` is an independent witness on a second MAVLink port: it
keeps the latest message per type, every STATUSTEXT, and the simulator's true state
(SIM_STATE, never the EKF's estimate); :func:`wait_ready` waits on the vehicle's
own readiness (heartbeat, "EKF3 IMU0 is using GPS", first LOCAL_POSITION_NED).

What SITL does (measured, see notes/sitl-findings.md): SERIAL0 (TCP 5760 + 10 N)
listens at once and the simulation starts only when a client connects there;
SERIAL1 and SERIAL2 (5762/5763 + 10 N) open after that. A reboot re-executes the
process (same pid), drops every TCP connection and waits for SERIAL0 again.
SITL listens on every interface; that is the firmware's choice, not ours.

Command line: ``python -m sim.sitl --speedup 10`` starts one and prints its ports as
JSON; ``python -m sim.sitl --probe`` also connects, waits until it is ready and
prints the readiness timeline.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import ctypes
import fcntl
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

#: Environment variable naming a directory with ``arducopter`` and ``copter.parm``.
ENV_DIR = "VISLAND_SITL_DIR"
#: Environment variable overriding the default speed-up (tests and benchmarks).
ENV_SPEEDUP = "VISLAND_SITL_SPEEDUP"
#: Default speed-up: fast, and still faithful on a loaded 2-core machine (findings).
DEFAULT_SPEEDUP = 10.0

_BASE_TCP = 5760  # SERIAL0; SERIAL1 = +2, SERIAL2 = +3
_BASE_UDP = (5501, 5502, 5503, 9005)  # RC in, simulator in/out, IRLock
_INSTANCES = range(20, 120)  # clear of the -I 0.. a person starts by hand
_LOCK_DIR = Path(tempfile.gettempdir()) / "visland-sitl"
_PR_SET_PDEATHSIG = 1
_EARTH_RADIUS_M = 6378137.0

_LIVE: set[Sitl] = set()
_LIVE_LOCK = threading.Lock()


class SitlError(RuntimeError):
    """SITL could not be started, or did not do what was waited for in time."""


def checkout_root() -> Path:
    """The project checkout this module lives in."""
    return Path(__file__).resolve().parents[1]


def find_sitl_dir() -> Path | None:
    """Where ``arducopter`` and ``copter.parm`` are, or None.

    ``$VISLAND_SITL_DIR`` when set, else ``../shared/sitl`` beside the checkout.
    """
    env = os.environ.get(ENV_DIR)
    candidates = [Path(env)] if env else [checkout_root().parent / "shared" / "sitl"]
    for directory in candidates:
        binary = directory / "arducopter"
        parm = directory / "copter.parm"
        if binary.is_file() and os.access(binary, os.X_OK) and parm.is_file():
            return directory.resolve()
    return None


def default_speedup() -> float:
    """``$VISLAND_SITL_SPEEDUP`` or :data:`DEFAULT_SPEEDUP`."""
    text = os.environ.get(ENV_SPEEDUP)
    if not text:
        return DEFAULT_SPEEDUP
    try:
        value = float(text)
    except ValueError as exc:
        raise ValueError(f"{ENV_SPEEDUP} must be a number, got {text!r}") from exc
    if not 0 < value <= 100:
        raise ValueError(f"{ENV_SPEEDUP} must be in (0, 100], got {text!r}")
    return value


def _set_pdeathsig() -> None:  # pragma: no cover - runs in the child before exec
    # SITL dies with the process that started it, even if that one is SIGKILLed.
    with contextlib.suppress(Exception):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def _port_free(kind: int, port: int) -> bool:
    with socket.socket(socket.AF_INET, kind) as sock:
        if kind == socket.SOCK_STREAM:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def _instance_ports_free(n: int) -> bool:
    tcp = [_BASE_TCP + 10 * n + k for k in (0, 2, 3)]
    udp = [base + 10 * n for base in _BASE_UDP]
    return all(_port_free(socket.SOCK_STREAM, p) for p in tcp) and all(
        _port_free(socket.SOCK_DGRAM, p) for p in udp
    )


class _InstanceLock:
    """An instance number held for this process (an flock: released if we die)."""

    def __init__(self, exclude: set[int]) -> None:
        _LOCK_DIR.mkdir(parents=True, exist_ok=True)
        for n in _INSTANCES:
            if n in exclude:
                continue
            fh = open(_LOCK_DIR / f"instance-{n}.lock", "a+")  # noqa: SIM115 (held while running)
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                fh.close()
                continue
            if _instance_ports_free(n):
                self.number = n
                self._fh: IO[str] | None = fh
                return
            fcntl.flock(fh, fcntl.LOCK_UN)
            fh.close()
        raise SitlError(f"no free SITL instance in {_INSTANCES.start}..{_INSTANCES.stop - 1}")

    def release(self) -> None:
        if self._fh is not None:
            with contextlib.suppress(OSError):
                fcntl.flock(self._fh, fcntl.LOCK_UN)
            self._fh.close()
            self._fh = None


class Sitl:
    """One genuine ArduCopter SITL process.

    Parameters
    ----------
    speedup : float or None
        ``--speedup``: simulated seconds per wall second; None: :func:`default_speedup`.
    sitl_dir : Path or None
        Directory with ``arducopter`` and ``copter.parm``; None: :func:`find_sitl_dir`.
    home : str or None
        ``--home lat,lon,alt,yaw``; None: SITL's default (CMAC, Canberra).
    defaults : sequence of Path
        Extra parameter files loaded after ``copter.parm`` (``--defaults a,b``).
    start_timeout_s : float
        Bound on the wait for SERIAL0 to listen.

    Examples
    --------
    >>> with Sitl(speedup=10) as sitl:  # doctest: +SKIP
    ...     link = VehicleLink(sitl.url)
    """

    def __init__(
        self,
        *,
        speedup: float | None = None,
        sitl_dir: Path | None = None,
        home: str | None = None,
        defaults: tuple[Path, ...] = (),
        start_timeout_s: float = 20.0,
    ) -> None:
        speed = default_speedup() if speedup is None else float(speedup)
        if not math.isfinite(speed) or not 0 < speed <= 100:
            raise ValueError(f"speedup must be in (0, 100], got {speedup!r}")
        if not math.isfinite(start_timeout_s) or start_timeout_s <= 0:
            raise ValueError(f"start_timeout_s must be > 0, got {start_timeout_s!r}")
        directory = sitl_dir if sitl_dir is not None else find_sitl_dir()
        if directory is None:
            where = checkout_root().parent / "shared" / "sitl"
            raise SitlError(f"no ArduCopter SITL: set {ENV_DIR} or put it in {where}")
        self.sitl_dir = Path(directory)
        self.binary = self.sitl_dir / "arducopter"
        if not self.binary.is_file():
            raise SitlError(f"sitl_dir: no arducopter in {self.sitl_dir}")
        self.speedup = speed
        self.home = home
        self.defaults = (self.sitl_dir / "copter.parm", *(Path(p) for p in defaults))
        self.start_timeout_s = float(start_timeout_s)
        self.instance: int | None = None
        self.workdir: Path | None = None
        self._proc: subprocess.Popen[bytes] | None = None
        self._lock: _InstanceLock | None = None
        self._log: IO[bytes] | None = None
        self.started_at: float | None = None

    # ---------------------------------------------------------------- ports
    def _port(self, offset: int) -> int:
        if self.instance is None:
            raise SitlError("SITL is not running")
        return _BASE_TCP + 10 * self.instance + offset

    @property
    def url(self) -> str:
        """SERIAL0, where a ground station connects (the simulation waits for it)."""
        return f"tcp:127.0.0.1:{self._port(0)}"

    @property
    def serial1_url(self) -> str:
        """SERIAL1 (listens once SERIAL0 has a client)."""
        return f"tcp:127.0.0.1:{self._port(2)}"

    @property
    def serial2_url(self) -> str:
        """SERIAL2 (listens once SERIAL0 has a client): the observer's port."""
        return f"tcp:127.0.0.1:{self._port(3)}"

    @property
    def pid(self) -> int | None:
        """The SITL process id (unchanged by a reboot: SITL re-executes itself)."""
        return None if self._proc is None else self._proc.pid

    @property
    def running(self) -> bool:
        """The process is alive."""
        return self._proc is not None and self._proc.poll() is None

    def log_text(self) -> str:
        """What SITL printed so far (its console)."""
        if self.workdir is None:
            return ""
        path = self.workdir / "sitl.log"
        try:
            return path.read_text(errors="replace")
        except OSError:
            return ""

    # ---------------------------------------------------------------- lifecycle
    def start(self) -> Sitl:
        """Start SITL on a free instance; returns once SERIAL0 listens."""
        if self._proc is not None:
            raise SitlError("this Sitl was started already; make a new one")
        tried: set[int] = set()
        for _ in range(5):
            self._lock = _InstanceLock(tried)
            self.instance = self._lock.number
            tried.add(self.instance)
            self.workdir = Path(tempfile.mkdtemp(prefix=f"visland-sitl-{self.instance}-"))
            cmd = [
                str(self.binary),
                "--model",
                "+",
                "--speedup",
                f"{self.speedup:g}",
                "--defaults",
                ",".join(str(p) for p in self.defaults),
                f"-I{self.instance}",
            ]
            if self.home is not None:
                cmd += ["--home", self.home]
            self._log = open(self.workdir / "sitl.log", "wb")  # noqa: SIM115 (the child's console)
            self._proc = subprocess.Popen(
                cmd,
                cwd=self.workdir,
                stdin=subprocess.DEVNULL,
                stdout=self._log,
                stderr=subprocess.STDOUT,
                start_new_session=True,  # its own process group: stopped as a whole
                preexec_fn=_set_pdeathsig,
            )
            self.started_at = time.monotonic()
            with _LIVE_LOCK:
                _LIVE.add(self)
            if self._wait_listening():
                return self
            log = self.log_text()
            self.stop()
            self._proc = None
            if "bind" not in log.lower() and "address already in use" not in log.lower():
                raise SitlError(f"SITL did not start listening:\n{log[-2000:]}")
        raise SitlError("SITL could not bind its ports on 5 instances in a row")

    def _wait_listening(self) -> bool:
        deadline = time.monotonic() + self.start_timeout_s
        needle = f"SERIAL0 on TCP port {self._port(0)}"
        while time.monotonic() < deadline:
            if needle in self.log_text():
                return True
            if not self.running:
                return False
            time.sleep(0.02)
        return False

    def stop(self, timeout: float = 5.0) -> int | None:
        """Stop the process group (SIGTERM, then SIGKILL), delete the scratch
        directory and release the instance. Idempotent; returns the exit status."""
        proc = self._proc
        code: int | None = None
        if proc is not None:
            for sig in (signal.SIGTERM, signal.SIGKILL):
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(proc.pid, sig)
                try:
                    code = proc.wait(timeout)
                    break
                except subprocess.TimeoutExpired:
                    continue
        if self._log is not None:
            self._log.close()
            self._log = None
        if self.workdir is not None:
            shutil.rmtree(self.workdir, ignore_errors=True)
        if self._lock is not None:
            self._lock.release()
            self._lock = None
        with _LIVE_LOCK:
            _LIVE.discard(self)
        return code

    def __enter__(self) -> Sitl:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


@atexit.register
def _stop_all() -> None:
    with _LIVE_LOCK:
        live = list(_LIVE)
    for sitl in live:
        sitl.stop(timeout=2.0)


# ------------------------------------------------------------------------ observer


@dataclass(frozen=True)
class Text:
    """One STATUSTEXT: monotonic receive time, the vehicle's boot time (s), severity, text."""

    rx: float
    boot_s: float | None
    severity: int
    text: str


@dataclass(frozen=True)
class TrueState:
    """The simulator's own state (SIM_STATE), in the NED frame of an origin.

    ``position_ned`` metres from the origin passed to :meth:`SitlObserver.truth`
    (default: the EKF origin, the frame of LOCAL_POSITION_NED); ``velocity_ned`` m/s;
    attitude in radians; ``rx`` monotonic receive time.
    """

    position_ned: tuple[float, float, float]
    velocity_ned: tuple[float, float, float]
    roll: float
    pitch: float
    yaw: float
    lat_deg: float
    lon_deg: float
    alt_m: float
    rx: float


def ned_from_global(
    lat: float, lon: float, alt: float, origin: tuple[float, float, float]
) -> tuple[float, float, float]:
    """(north, east, down) metres of a WGS84 point from ``origin`` (lat, lon, alt AMSL).

    The flat-earth approximation ArduPilot's Location::get_distance_NED uses.

    >>> [round(v, 3) for v in ned_from_global(-35.0, 149.0, 580.0, (-35.0, 149.0, 584.0))]
    [0.0, 0.0, 4.0]
    """
    o_lat, o_lon, o_alt = origin
    north = math.radians(lat - o_lat) * _EARTH_RADIUS_M
    east = math.radians(lon - o_lon) * _EARTH_RADIUS_M * math.cos(math.radians(o_lat))
    return north, east, o_alt - alt


#: What the observer asks for on its port (message: Hz of simulated time).
OBSERVER_RATES_HZ: Mapping[str, float] = {
    "SIM_STATE": 25.0,
    "SYSTEM_TIME": 5.0,
    "LOCAL_POSITION_NED": 10.0,
    "GPS_GLOBAL_ORIGIN": 1.0,
    "EKF_STATUS_REPORT": 2.0,
    "HOME_POSITION": 1.0,
    "GPS_RAW_INT": 2.0,
}


class SitlObserver:
    """A second, independent MAVLink client: what the vehicle says, and the truth.

    It connects to ``url`` (retrying until it listens: SERIAL1/2 open only after
    SERIAL0 has a client), reconnects after a reboot, asks for
    :data:`OBSERVER_RATES_HZ`. It sends nothing but those requests and what a caller
    passes to :meth:`send` or :meth:`command` (e.g. a vision stand-in's
    VISION_POSITION_ESTIMATE), as system ``source_system``.
    """

    def __init__(
        self,
        url: str,
        *,
        source_system: int = 254,
        source_component: int = mavlink2.MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY,
        rates_hz: Mapping[str, float] | None = None,
    ) -> None:
        host, _, port = url.removeprefix("tcp:").rpartition(":")
        if not url.startswith("tcp:") or not host or not port.isdigit():
            raise ValueError(f"url must be tcp:HOST:PORT, got {url!r}")
        self.url = url
        self._addr = (host, int(port))
        self._source = (source_system, source_component)
        self._rates = dict(OBSERVER_RATES_HZ if rates_hz is None else rates_hz)
        self._latest: dict[str, tuple[float, Any]] = {}
        self._texts: list[Text] = []
        self._first: dict[str, tuple[float, float | None]] = {}
        self._cond = threading.Condition()
        self._boot_ms: int | None = None
        self._sock: socket.socket | None = None
        self._send_lock = threading.Lock()
        self._mav = mavlink2.MAVLink(None, *self._source)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.connections = 0
        self.epoch_texts = 0  # index of the first STATUSTEXT of the current connection
        # ArduPilot sends STATUSTEXTs only on ports it has heard from: when we first spoke
        self.active_since: float | None = None
        self.bad_data = 0
        self.started_at = time.monotonic()

    # ---------------------------------------------------------------- lifecycle
    def start(self) -> SitlObserver:
        """Start the reader thread; returns at once."""
        self.started_at = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="sitl-observer", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the thread and close the socket. Idempotent."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(3.0)
        self._close_socket()

    def __enter__(self) -> SitlObserver:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---------------------------------------------------------------- reading
    def latest(self, mtype: str) -> Any:
        """The latest message of ``mtype``, or None."""
        with self._cond:
            got = self._latest.get(mtype)
        return None if got is None else got[1]

    def latest_rx(self, mtype: str) -> float | None:
        """Monotonic receive time of the latest ``mtype``, or None."""
        with self._cond:
            got = self._latest.get(mtype)
        return None if got is None else got[0]

    def first_seen(self, mtype: str) -> tuple[float, float | None] | None:
        """(monotonic receive time, vehicle boot s) of the first ``mtype`` since start."""
        with self._cond:
            return self._first.get(mtype)

    @property
    def boot_s(self) -> float | None:
        """The vehicle's clock (s since boot), from its latest time-stamped message."""
        ms = self._boot_ms
        return None if ms is None else ms / 1000.0

    def texts(self, since: int = 0) -> list[Text]:
        """STATUSTEXTs received, from index ``since``."""
        with self._cond:
            return self._texts[since:]

    @property
    def text_count(self) -> int:
        """How many STATUSTEXTs so far (an index for :meth:`texts` and waits)."""
        with self._cond:
            return len(self._texts)

    def wait(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Wait until ``predicate()`` (called under the lock, on each message) holds."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not predicate():
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(min(left, 0.2))
        return True

    def wait_text(self, pattern: str, timeout: float, *, since: int = 0) -> Text | None:
        """The first STATUSTEXT from index ``since`` matching the regex ``pattern``."""
        regex = re.compile(pattern)
        found: list[Text] = []

        def match() -> bool:
            for entry in self._texts[since:]:
                if regex.search(entry.text):
                    found.append(entry)
                    return True
            return False

        return found[0] if self.wait(match, timeout) else None

    def wait_message(
        self,
        mtype: str,
        timeout: float,
        where: Callable[[Any], bool] = lambda m: True,
        *,
        since: float | None = None,
    ) -> Any:
        """The latest ``mtype`` received after ``since`` (default: this call) for which
        ``where`` holds, waiting up to ``timeout`` seconds; None if none came."""
        t0 = time.monotonic() if since is None else since
        got: list[Any] = []

        def fresh() -> bool:
            entry = self._latest.get(mtype)
            if entry is not None and entry[0] >= t0 and where(entry[1]):
                got.append(entry[1])
                return True
            return False

        return got[0] if self.wait(fresh, timeout) else None

    def ekf_origin(self) -> tuple[float, float, float] | None:
        """The EKF origin (lat, lon, alt AMSL) from GPS_GLOBAL_ORIGIN, or None."""
        msg = self.latest("GPS_GLOBAL_ORIGIN")
        if msg is None:
            return None
        return msg.latitude * 1e-7, msg.longitude * 1e-7, msg.altitude * 1e-3

    def truth(self, origin: tuple[float, float, float] | None = None) -> TrueState | None:
        """The simulator's true state in the NED frame of ``origin`` (default: EKF origin)."""
        with self._cond:
            got = self._latest.get("SIM_STATE")
        if got is None:
            return None
        rx, msg = got
        origin = origin or self.ekf_origin()
        if origin is None:
            return None
        lat, lon = msg.lat_int * 1e-7, msg.lon_int * 1e-7
        return TrueState(
            ned_from_global(lat, lon, float(msg.alt), origin),
            (float(msg.vn), float(msg.ve), float(msg.vd)),
            float(msg.roll),
            float(msg.pitch),
            float(msg.yaw),
            lat,
            lon,
            float(msg.alt),
            rx,
        )

    # ---------------------------------------------------------------- sending
    def send(self, msg: Any) -> bool:
        """Send one message to the vehicle; False when not connected."""
        with self._send_lock:
            sock = self._sock
            if sock is None:
                return False
            try:
                sock.sendall(msg.pack(self._mav))
            except OSError:
                return False
            self._mav.seq = (self._mav.seq + 1) % 256
        return True

    def command(self, command_id: int, params: tuple[float, ...], timeout: float) -> int | None:
        """Send COMMAND_LONG and wait for its COMMAND_ACK; the MAV_RESULT, or None.

        For the test rig's own commands (e.g. MAV_CMD_SET_EKF_SOURCE_SET from a
        vision stand-in); the ground station under test uses its own link.
        """
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        t0 = time.monotonic()
        msg = mavlink2.MAVLink_command_long_message(1, 1, command_id, 0, *p)
        if not self.send(msg):
            return None
        ack = self.wait_message(
            "COMMAND_ACK",
            timeout,
            lambda m: m.command == command_id and m.target_system in (0, self._source[0]),
            since=t0,
        )
        return None if ack is None else int(ack.result)

    def request_streams(self, names: list[str] | None = None) -> None:
        """(Re)ask for :data:`OBSERVER_RATES_HZ` (or just ``names``) on this port."""
        for name in self._rates if names is None else names:
            self.send(
                mavlink2.MAVLink_command_long_message(
                    1,
                    1,
                    mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL,
                    0,
                    getattr(mavlink2, f"MAVLINK_MSG_ID_{name}"),
                    round(1e6 / self._rates[name]),
                    0,
                    0,
                    0,
                    0,
                    0,
                )
            )

    def _missing_streams(self, connected_at: float, now: float) -> list[str]:
        # A request sent while the vehicle boots may be lost; one a reboot forgot too.
        missing = []
        with self._cond:
            for name in self._rates:
                entry = self._latest.get(name)
                if entry is None or entry[0] < connected_at or now - entry[0] > 3.0:
                    missing.append(name)
        return missing

    # ---------------------------------------------------------------- thread
    def _close_socket(self) -> None:
        with self._send_lock:
            sock, self._sock = self._sock, None
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                sock = socket.create_connection(self._addr, timeout=1.0)
            except OSError:
                self._stop.wait(0.1)
                continue
            sock.settimeout(0.2)
            with self._cond:
                # SITL drops its TCP clients only when it reboots: what came before
                # belongs to the previous boot.
                self._new_epoch()
                self.active_since = None
            with self._send_lock:
                self._sock = sock
            self.connections += 1
            parser = mavlink2.MAVLink(None, *self._source)
            parser.robust_parsing = True
            connected_at = asked = time.monotonic()
            asked -= 10.0  # ask as soon as the vehicle speaks
            while not self._stop.is_set():
                try:
                    data = sock.recv(65536)
                except TimeoutError:
                    data = None
                except OSError:
                    break
                if data == b"":
                    break
                now = time.monotonic()
                if data:
                    try:
                        msgs = parser.parse_buffer(data) or []
                    except Exception:
                        self.bad_data += 1
                        parser = mavlink2.MAVLink(None, *self._source)
                        parser.robust_parsing = True
                        msgs = []
                    self._take(msgs, now)
                heard = self.latest_rx("HEARTBEAT")
                if heard is not None and heard >= connected_at and now - asked > 2.0:
                    asked = now
                    missing = self._missing_streams(connected_at, now)
                    if missing:
                        self.request_streams(missing)
                        if self.active_since is None:
                            self.active_since = now
            self._close_socket()

    def _new_epoch(self) -> None:
        # under self._cond
        self._latest.clear()
        self._first.clear()
        self._boot_ms = None
        self.epoch_texts = len(self._texts)

    def _take(self, msgs: list[Any], now: float) -> None:
        with self._cond:
            for msg in msgs:
                mtype = msg.get_type()
                if mtype == "BAD_DATA":
                    self.bad_data += 1
                    continue
                if msg.get_srcSystem() != 1:
                    continue
                boot = getattr(msg, "time_boot_ms", None)
                if boot is not None:
                    if self._boot_ms is not None and boot < self._boot_ms - 1000:
                        self._new_epoch()  # the clock went back: a reboot on this link
                    self._boot_ms = int(boot)
                self._latest[mtype] = (now, msg)
                if mtype not in self._first:
                    self._first[mtype] = (now, self.boot_s)
                if mtype == "STATUSTEXT":
                    self._texts.append(Text(now, self.boot_s, int(msg.severity), str(msg.text)))
            self._cond.notify_all()


# ------------------------------------------------------------------------ readiness


@dataclass(frozen=True)
class Readiness:
    """When the vehicle became ready: wall seconds after ``since``, and its boot time."""

    heartbeat_s: float
    origin_set_s: float
    using_gps_s: float
    local_position_s: float
    boot_at_using_gps_s: float | None
    texts: tuple[str, ...] = field(default=())

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable form."""
        return {
            "heartbeat_s": round(self.heartbeat_s, 3),
            "origin_set_s": round(self.origin_set_s, 3),
            "using_gps_s": round(self.using_gps_s, 3),
            "local_position_s": round(self.local_position_s, 3),
            "boot_at_using_gps_s": self.boot_at_using_gps_s,
        }


def wait_ready(observer: SitlObserver, *, timeout: float, since: float | None = None) -> Readiness:
    """Wait until the vehicle can fly on GPS: a heartbeat, "EKF3 IMU0 origin set",
    "EKF3 IMU0 is using GPS" and a LOCAL_POSITION_NED after it, all since the
    observer's latest (re)connection (a reboot starts over).

    ``since``: the monotonic time to measure from (default: the observer's start).
    Raises :class:`SitlError` naming what did not come within ``timeout`` seconds.
    """
    t0 = observer.started_at if since is None else since
    deadline = time.monotonic() + timeout

    def left() -> float:
        return max(0.0, deadline - time.monotonic())

    if not observer.wait(lambda: "HEARTBEAT" in observer._latest, left()):
        raise SitlError(f"no HEARTBEAT within {timeout:g} s")
    hb = observer.first_seen("HEARTBEAT")
    origin = observer.wait_text(r"EKF3 IMU0 origin set", left(), since=observer.epoch_texts)
    if origin is None:
        raise SitlError(f"no 'EKF3 IMU0 origin set' within {timeout:g} s")
    gps = observer.wait_text(r"EKF3 IMU0 is using GPS", left(), since=observer.epoch_texts)
    if gps is None:
        raise SitlError(f"no 'EKF3 IMU0 is using GPS' within {timeout:g} s")
    if not observer.wait(lambda: "LOCAL_POSITION_NED" in observer._latest, left()):
        raise SitlError(f"no LOCAL_POSITION_NED within {timeout:g} s")
    lpn = observer.first_seen("LOCAL_POSITION_NED")
    assert hb is not None and lpn is not None
    return Readiness(
        hb[0] - t0,
        origin.rx - t0,
        gps.rx - t0,
        lpn[0] - t0,
        gps.boot_s,
        tuple(t.text for t in observer.texts()),
    )


@contextlib.contextmanager
def running_sitl(**kwargs: Any) -> Iterator[Sitl]:
    """``with running_sitl(speedup=10) as sitl:`` (stopped whatever happens)."""
    sitl = Sitl(**kwargs)
    try:
        yield sitl.start()
    finally:
        sitl.stop()


# ------------------------------------------------------------------------ command line


def main(argv: list[str] | None = None) -> int:
    """``python -m sim.sitl``: start SITL, print its ports (and readiness) as JSON."""
    parser = argparse.ArgumentParser(prog="python -m sim.sitl", description=__doc__.split("\n")[0])
    parser.add_argument("--speedup", type=float, default=None, help="default: %(default)s")
    parser.add_argument("--home", default=None, help="lat,lon,alt,yaw (default: CMAC)")
    parser.add_argument(
        "--probe",
        action="store_true",
        help="connect on SERIAL0, wait until ready, print the timeline and stop",
    )
    parser.add_argument("--timeout", type=float, default=300.0, help="readiness bound (s)")
    args = parser.parse_args(argv)
    if find_sitl_dir() is None:
        print(json.dumps({"error": f"no SITL found (set {ENV_DIR})"}))
        return 2
    with running_sitl(speedup=args.speedup, home=args.home) as sitl:
        info: dict[str, Any] = {
            "url": sitl.url,
            "serial1_url": sitl.serial1_url,
            "serial2_url": sitl.serial2_url,
            "instance": sitl.instance,
            "pid": sitl.pid,
            "speedup": sitl.speedup,
        }
        if not args.probe:
            print(json.dumps(info), flush=True)
            stop = threading.Event()
            for sig in (signal.SIGINT, signal.SIGTERM):
                signal.signal(sig, lambda *_: stop.set())
            while not stop.is_set() and sitl.running:
                stop.wait(0.5)
            return 0
        t0 = time.monotonic()
        with SitlObserver(sitl.url) as observer:
            try:
                ready = wait_ready(observer, timeout=args.timeout, since=t0)
            except SitlError as exc:
                info["error"] = str(exc)
                print(json.dumps(info))
                return 1
        info["readiness"] = ready.to_dict()
        print(json.dumps(info))
    return 0


if __name__ == "__main__":
    sys.exit(main())
