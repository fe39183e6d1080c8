"""The link's core: its state, the telemetry snapshot, sending, and the event thread.

:class:`LinkCore` holds what every part of :class:`~backend.link.VehicleLink` shares
(declared here, set up by ``VehicleLink.__init__``): the state machine
(connecting -> up -> lost -> up, closed), the immutable telemetry snapshot and its
condition, the transport, and the event queue whose thread delivers
:class:`LinkEvent` to subscribers, so a slow or raising subscriber never holds up the
link. The commands (:mod:`.commanding`), the reader (:mod:`.receiving`) and the
housekeeper (:mod:`.housekeeping`) build on it.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import streams
from backend.link.commands import AckTracker
from backend.link.connection import ConnectionSpec, SendError, TlogWriter, Transport
from backend.link.state import LinkEvent, LinkState
from backend.link.telemetry import StatusTextAssembler, Telemetry

log = logging.getLogger("backend.link.vehicle_link")

_TICK_S = 0.1  # housekeeping period: heartbeat loss is noticed within 0.1 s
_REASON_GRACE_S = 0.4  # refusal texts may trail the COMMAND_ACK
_RESENT_ACK_WAIT_S = 0.5  # how long to wait for the ACK of a retransmitted command
# After an accepted reboot the link is down at once; a heartbeat sent before the restart
# (ArduPilot answers, then restarts) must not bring it back: no autopilot boots this fast.
_REBOOT_HOLD_S = 1.0
_BACKOFF_S = (0.25, 2.0)  # reopen delay: first, largest
_EVENT_QUEUE = 1000
_JOIN_S = 2.0


class LinkCore:
    """State, snapshot, transport and events shared by the link's parts."""

    url: str
    _spec: ConnectionSpec
    _tlog_dir: Path | None
    _signing_key: bytes | None
    _source_system: int
    _source_component: int
    _hb_timeout: float
    _cmd_timeout: float
    _connect_timeout: float
    _stream_rates: dict[str, float]
    _transport: Transport | None
    _tlog: TlogWriter | None
    _started: bool
    _closed: bool
    _stop: threading.Event
    _wake: threading.Event
    _threads: list[threading.Thread]
    _t0: float
    _state: LinkState
    _state_lock: threading.Lock
    _cond: threading.Condition
    _gen: int
    _telemetry: Telemetry
    _latest: dict[str, Any]
    _target: tuple[int, int] | None
    _last_hb: float | None
    _hb_sent_at: float  # monotonic time of our last HEARTBEAT sent
    _rebooting_until: float
    _rx_count: int
    _handler_errors: int
    _implausible: int
    _last_error: str | None
    _streams: streams.StreamRequester
    _tracker: AckTracker
    _command_locks: dict[int, threading.Lock]
    _command_locks_guard: threading.Lock
    _param_cond: threading.Condition
    _params: dict[str, tuple[float, int, float]]
    _param_count: int
    _param_indices: set[int]
    _written_in_boot: dict[str, int]
    _statustexts: StatusTextAssembler
    _landing_targets: int
    _subscribers: tuple[Callable[[LinkEvent], None], ...]
    _subscribers_lock: threading.Lock
    _events: queue.Queue[LinkEvent | None]
    events_dropped: int

    def _send(self, msg: Any) -> None:
        transport = self._transport
        if transport is None:
            raise SendError("the link has not been started")
        transport.send(msg)

    def _send_heartbeat(self) -> None:
        """Our HEARTBEAT (a GCS's), where a transport is open to send it on."""
        transport = self._transport
        if transport is None or not transport.is_open:
            return
        msg = mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_GCS,
            mavlink2.MAV_AUTOPILOT_INVALID,
            0,
            0,
            mavlink2.MAV_STATE_ACTIVE,
            3,
        )
        self._hb_sent_at = time.monotonic()
        with contextlib.suppress(SendError):  # the reader notices a dead transport
            transport.send(msg)

    def _time_boot_ms(self) -> int:
        return int((time.monotonic() - self._t0) * 1000) & 0xFFFFFFFF

    # ------------------------------------------------------------------ state machine
    def _set_state(self, new: LinkState, reason: str) -> None:
        with self._state_lock:
            old = self._state
            if old == new or old == LinkState.CLOSED:
                return
            self._state = new
        if new == LinkState.UP:
            self._streams.reset()
            self._wake.set()  # request telemetry now, not at the next tick
        else:
            self._target = None
            self._tracker.abort_all()
        self._apply({"state": new})
        level = logging.WARNING if new == LinkState.LOST else logging.INFO
        log.log(level, "vehicle link %s -> %s: %s", old.value, new.value, reason)
        self._emit(f"link_{new.value}", {"reason": reason, "previous": old.value, "url": self.url})

    def _apply(self, changes: dict[str, Any]) -> None:
        if not changes:
            return
        with self._cond:
            self._telemetry = replace(self._telemetry, **changes)
            self._gen += 1
            self._cond.notify_all()

    def _note_error(self, text: str) -> None:
        self._last_error = text
        self._apply({"last_error": text})

    # ------------------------------------------------------------------ events
    def _emit(self, kind: str, data: dict[str, Any]) -> None:
        try:
            self._events.put_nowait(LinkEvent(kind, data))
        except queue.Full:
            self.events_dropped += 1

    def _event_loop(self) -> None:
        while True:
            try:
                event = self._events.get(timeout=0.5)
            except queue.Empty:
                if self._closed and self._stop.is_set() and self._state == LinkState.CLOSED:
                    return
                continue
            if event is None:
                return
            for callback in self._subscribers:
                try:
                    callback(event)
                except Exception:
                    log.exception("link event subscriber %r failed", callback)
