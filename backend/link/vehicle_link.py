"""The vehicle link: one object over a pymavlink connection string.

Split by responsibility: this module is the object (set-up, life cycle, public
state); :mod:`.core` the state machine, snapshot and events; :mod:`.commanding` the
commands; :mod:`.receiving` the reader thread; :mod:`.housekeeping` the housekeeper.

Three threads, none of which can block forever:

- the reader receives, keeps a latest-message cache per type and dispatches each
  message to its handlers (a dict from type to handler, each in its own try/except);
  it also reopens a dropped transport with a back-off;
- the housekeeper sends our HEARTBEAT at 1 Hz, runs the state machine
  (connecting -> up -> lost -> up), (re)requests the telemetry streams and updates
  the link-quality figures;
- the event thread delivers :class:`LinkEvent` to subscribers, so a slow or raising
  subscriber never holds up the link.

Commands block the calling thread until the COMMAND_ACK or a timeout and return a
:class:`CommandResult`; they never raise for a refusal by the vehicle.
"""

from __future__ import annotations

import contextlib
import logging
import math
import queue
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import commands as cmd
from backend.link import streams
from backend.link.attitudes import Angles, AttitudeHistory
from backend.link.commanding import LinkCommands
from backend.link.commands import AckTracker
from backend.link.connection import TlogWriter, Transport, parse_url
from backend.link.core import _EVENT_QUEUE, _JOIN_S
from backend.link.housekeeping import LinkHousekeeping
from backend.link.receiving import LinkReceiver
from backend.link.state import LinkEvent, LinkState
from backend.link.streams import DEFAULT_STREAM_RATES_HZ
from backend.link.telemetry import (
    StatusTextAssembler,
    Telemetry,
)

log = logging.getLogger(__name__)

ATTITUDE_HISTORY_S = 2.0  # the attitudes kept, for frames taken this long ago at most
# A frame's moment this far from every attitude received has none: ATTITUDE comes at
# 10-50 Hz, and a vehicle silent for longer may be anywhere by then.
ATTITUDE_GAP_S = 0.5


class VehicleLink(LinkCommands, LinkReceiver, LinkHousekeeping):
    """A MAVLink link to one ArduCopter.

    Parameters
    ----------
    url : str
        pymavlink connection string: ``tcp:HOST:PORT``, ``udpin:HOST:PORT`` (or
        ``udp:``), ``udpout:HOST:PORT``, ``/dev/ttyUSB0,57600``.
    tlog_dir : str or Path or None
        Directory for the session's .tlog (every packet, both directions); None: no log.
    signing_key : bytes or None
        32-byte MAVLink 2 signing key.
    source_system : int
        Our system id; ArduCopter honours RC overrides only from SYSID_MYGCS (255).
    heartbeat_timeout_s : float
        Silence after which the link is LOST.
    command_timeout_s : float
        How long a command waits for its COMMAND_ACK (one retransmission halfway).
    baud : int
        Serial baud rate when ``url`` names none (the seed's XBee ran at 57600).
    source_component : int
        Our component id (MAV_COMP_ID_MISSIONPLANNER, as ground stations use).
    stream_rates_hz : mapping or None
        Telemetry to request, message name -> Hz; default :data:`DEFAULT_STREAM_RATES_HZ`.
    connect_timeout_s : float
        Bound on one TCP connect attempt.

    Examples
    --------
    >>> link = VehicleLink("tcp:127.0.0.1:5760", tlog_dir="data/tlogs")  # doctest: +SKIP
    >>> link.start()  # doctest: +SKIP
    >>> link.wait_until(lambda t: t.state == "up", timeout=10)  # doctest: +SKIP
    """

    def __init__(
        self,
        url: str,
        *,
        tlog_dir: str | Path | None = None,
        signing_key: bytes | None = None,
        source_system: int = 255,
        heartbeat_timeout_s: float = 3.0,
        command_timeout_s: float = 3.0,
        baud: int = 57600,
        source_component: int = mavlink2.MAV_COMP_ID_MISSIONPLANNER,
        stream_rates_hz: Mapping[str, float] | None = None,
        connect_timeout_s: float = 2.0,
    ) -> None:
        spec = parse_url(url, baud=baud)
        if signing_key is not None and (
            not isinstance(signing_key, bytes | bytearray) or len(signing_key) != 32
        ):
            raise ValueError("signing_key must be 32 bytes (or None for no signing)")
        for name, value in (
            ("source_system", source_system),
            ("source_component", source_component),
        ):
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 255:
                raise ValueError(f"{name} must be an int in 1..255, got {value!r}")
        timeouts: tuple[tuple[str, float], ...] = (
            ("heartbeat_timeout_s", heartbeat_timeout_s),
            ("command_timeout_s", command_timeout_s),
            ("connect_timeout_s", connect_timeout_s),
        )
        for name, fvalue in timeouts:
            if cmd.finite(fvalue, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {fvalue!r}")
        rates = streams.check_rates(
            DEFAULT_STREAM_RATES_HZ if stream_rates_hz is None else stream_rates_hz
        )

        self.url = spec.url
        self._spec = spec
        self._tlog_dir = None if tlog_dir is None else Path(tlog_dir)
        self._signing_key = None if signing_key is None else bytes(signing_key)
        self._source_system = source_system
        self._source_component = source_component
        self._hb_timeout = float(heartbeat_timeout_s)
        self._cmd_timeout = float(command_timeout_s)
        self._connect_timeout = float(connect_timeout_s)
        self._stream_rates = rates

        self._transport: Transport | None = None
        self._tlog: TlogWriter | None = None
        self._started = False
        self._closed = False
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._hb_sent_at = -math.inf
        self._threads: list[threading.Thread] = []
        self._t0 = time.monotonic()

        # state and the telemetry snapshot
        self._state = LinkState.CONNECTING
        self._state_lock = threading.Lock()
        self._cond = threading.Condition()
        self._gen = 0
        self._telemetry = Telemetry()
        self._latest: dict[str, Any] = {}
        self._target: tuple[int, int] | None = None
        self._last_hb: float | None = None
        self._rebooting_until = 0.0  # monotonic time: heartbeats before it are the old boot's
        self._rx_count = 0
        self._handler_errors = 0
        self._implausible = 0
        self._last_error: str | None = None

        self._streams = streams.StreamRequester()

        # commands and parameters
        self._tracker = AckTracker()
        self._command_locks: dict[int, threading.Lock] = {}
        self._command_locks_guard = threading.Lock()
        self._param_cond = threading.Condition()
        self._params: dict[str, tuple[float, int, float]] = {}  # name -> value, type, rx time
        self._param_count = 0  # how many parameters the vehicle says it has
        self._param_indices: set[int] = set()  # indices heard since the vehicle's boot
        self._written_in_boot: dict[str, int] = {}  # name -> Telemetry.boots when written
        self._statustexts = StatusTextAssembler()
        self._landing_targets = 0

        # events
        self._subscribers: tuple[Callable[[LinkEvent], None], ...] = ()
        self._subscribers_lock = threading.Lock()
        self._events: queue.Queue[LinkEvent | None] = queue.Queue(maxsize=_EVENT_QUEUE)
        self.events_dropped = 0

        self._link_handlers: dict[str, Callable[[Any], None]] = {
            "COMMAND_ACK": self._on_command_ack,
            "STATUSTEXT": self._on_statustext,
            "PARAM_VALUE": self._on_param_value,
            "ATTITUDE": self._note_attitude,
        }
        # (by this process's clock, as frames are stamped: see `attitude_at`)
        self._attitudes = AttitudeHistory(ATTITUDE_HISTORY_S)

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Open the session's tlog and start the threads; returns at once."""
        if self._closed:
            raise RuntimeError("a closed VehicleLink cannot be started again; make a new one")
        if self._started:
            return
        self._started = True
        self._t0 = time.monotonic()
        if self._tlog_dir is not None:
            self._tlog = TlogWriter(self._tlog_dir)
        self._transport = Transport(
            self._spec,
            source_system=self._source_system,
            source_component=self._source_component,
            signing_key=self._signing_key,
            tlog=self._tlog,
            connect_timeout_s=self._connect_timeout,
        )
        self._emit("link_connecting", {"url": self.url})
        for name, target in (
            ("events", self._event_loop),
            ("reader", self._reader_loop),
            ("housekeeping", self._housekeeping_loop),
        ):
            thread = threading.Thread(target=target, name=f"vehicle-link-{name}", daemon=True)
            thread.start()
            self._threads.append(thread)

    def close(self) -> None:
        """Stop the threads (each joined with a timeout), close the transport and tlog.

        Idempotent.
        """
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self._wake.set()
        self._tracker.abort_all()
        for thread in self._threads:
            if thread.name != "vehicle-link-events":
                thread.join(_JOIN_S)
        if self._transport is not None:
            self._transport.close()
        self._set_state(LinkState.CLOSED, "closed by the ground station")
        if self._tlog is not None:
            self._tlog.close()
        with contextlib.suppress(queue.Full):
            self._events.put(None, timeout=0.5)  # after link_closed: the event thread ends
        for thread in self._threads:
            if thread.name == "vehicle-link-events":
                thread.join(_JOIN_S)

    def __enter__(self) -> VehicleLink:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ public state
    @property
    def state(self) -> LinkState:
        """The link state now."""
        return self._state

    def flush_tlog(self) -> None:
        """Push the session's .tlog to disk now (the link flushes it every second too)."""
        if self._tlog is not None:
            self._tlog.flush()

    @property
    def tlog_path(self) -> Path | None:
        """The session's .tlog, or None without ``tlog_dir`` (or before ``start``)."""
        return None if self._tlog is None else self._tlog.path

    @property
    def telemetry(self) -> Telemetry:
        """A full, consistent snapshot; ``heartbeat_age_s`` is computed at the call."""
        snap = self._telemetry
        last = self._last_hb
        age = None if last is None else time.monotonic() - last
        return replace(snap, state=self._state, heartbeat_age_s=age)

    @property
    def vehicle(self) -> tuple[int, int] | None:
        """(sysid, compid) of the vehicle the link follows, None until its heartbeat."""
        return self._target

    def latest(self, msg_type: str) -> Any:
        """The latest message of ``msg_type`` (e.g. ``"ATTITUDE"``) from the vehicle, or None."""
        if not isinstance(msg_type, str):
            raise ValueError(f"msg_type must be a message name string, got {msg_type!r}")
        return self._latest.get(msg_type.upper())

    def attitude_at(self, t_monotonic: float) -> Angles | None:
        """The vehicle's roll, pitch and yaw (rad) at ``t_monotonic`` (a frame's capture
        time, ``time.monotonic()``): interpolated between the ATTITUDEs received around
        it; None when none was received within ``ATTITUDE_GAP_S`` of it (or over the
        last ``ATTITUDE_HISTORY_S``)."""
        return self._attitudes.at(t_monotonic, max_gap=ATTITUDE_GAP_S)

    def _note_attitude(self, msg: Any) -> None:
        # (stamped as the snapshot's: when the reader took it off the wire)
        rx = self._telemetry.attitude_rx_monotonic
        self._attitudes.add(time.monotonic() if rx is None else rx, (msg.roll, msg.pitch, msg.yaw))

    def subscribe(self, callback: Callable[[LinkEvent], None]) -> Callable[[], None]:
        """Call ``callback(event)`` (on the event thread) for every :class:`LinkEvent`.

        Returns a function that unsubscribes. A raising callback is logged and skipped.
        """
        if not callable(callback):
            raise ValueError("callback must be callable")
        with self._subscribers_lock:
            self._subscribers = (*self._subscribers, callback)

        def unsubscribe() -> None:
            with self._subscribers_lock:
                self._subscribers = tuple(c for c in self._subscribers if c is not callback)

        return unsubscribe

    def wait_until(self, predicate: Callable[[Telemetry], bool], timeout: float) -> bool:
        """Wait until ``predicate(telemetry)`` holds; False after ``timeout`` seconds."""
        timeout = cmd.finite(timeout, "timeout")
        if timeout < 0:
            raise ValueError(f"timeout must be >= 0, got {timeout!r}")
        deadline = time.monotonic() + timeout
        while True:
            gen = self._gen
            if predicate(self.telemetry):
                return True
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            with self._cond:
                if self._gen == gen:
                    # short slices: heartbeat_age_s and state change without a message
                    self._cond.wait(min(remaining, 0.1))
