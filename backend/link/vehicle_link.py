"""The vehicle link: one object over a pymavlink connection string.

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
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import commands as cmd
from backend.link import streams
from backend.link.commands import AckTracker, CommandResult
from backend.link.connection import SendError, TlogWriter, Transport, TransportDropped, parse_url
from backend.link.modes import mode_number
from backend.link.state import LinkEvent, LinkState
from backend.link.streams import DEFAULT_STREAM_RATES_HZ
from backend.link.telemetry import (
    STATUSTEXT_HISTORY,
    TELEMETRY_HANDLERS,
    StatusText,
    StatusTextAssembler,
    Telemetry,
)

log = logging.getLogger(__name__)

_TICK_S = 0.1  # housekeeping period: heartbeat loss is noticed within 0.1 s
_REASON_GRACE_S = 0.4  # refusal texts may trail the COMMAND_ACK
_RESENT_ACK_WAIT_S = 0.5  # how long to wait for the ACK of a retransmitted command
_BACKOFF_S = (0.25, 2.0)  # reopen delay: first, largest
_EVENT_QUEUE = 1000
_JOIN_S = 2.0

# HEARTBEATs that do not come from a vehicle (ourselves, other GCSs, gimbals, radios)
_NOT_VEHICLE_TYPES = frozenset(
    {
        mavlink2.MAV_TYPE_GCS,
        mavlink2.MAV_TYPE_GIMBAL,
        mavlink2.MAV_TYPE_ADSB,
        mavlink2.MAV_TYPE_ONBOARD_CONTROLLER,
        mavlink2.MAV_TYPE_CAMERA,
    }
)


class VehicleLink:
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
        for name, value in (
            ("heartbeat_timeout_s", heartbeat_timeout_s),
            ("command_timeout_s", command_timeout_s),
            ("connect_timeout_s", connect_timeout_s),
        ):
            if cmd.finite(value, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {value!r}")
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
        self._rx_count = 0
        self._handler_errors = 0
        self._last_error: str | None = None

        self._streams = streams.StreamRequester()

        # commands and parameters
        self._tracker = AckTracker()
        self._command_locks: dict[int, threading.Lock] = {}
        self._command_locks_guard = threading.Lock()
        self._param_cond = threading.Condition()
        self._params: dict[str, tuple[float, int, float]] = {}  # name -> value, type, rx time
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
        }

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

    # ------------------------------------------------------------------ commands
    def arm(self) -> CommandResult:
        """Arm (MAV_CMD_COMPONENT_ARM_DISARM param1 = 1); refusals carry the reasons."""
        return self._command_long("arm", mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (1,))

    def disarm(self) -> CommandResult:
        """Disarm; ArduCopter refuses while flying (use :meth:`force_disarm` only then)."""
        return self._command_long("disarm", mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (0,))

    def force_disarm(self) -> CommandResult:
        """Disarm at once, even in flight (param2 = 21196): the motors stop. Explicit only."""
        return self._command_long(
            "force_disarm", mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (0, cmd.FORCE_MAGIC)
        )

    def set_mode(self, name: str) -> CommandResult:
        """Change flight mode by name (MAV_CMD_DO_SET_MODE with the custom mode number)."""
        try:
            number = mode_number(name)
        except ValueError as exc:
            return self._invalid("set_mode", exc)
        return self._command_long(
            f"set_mode {name.strip().upper()}",
            mavlink2.MAV_CMD_DO_SET_MODE,
            (mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number),
        )

    def takeoff(self, altitude_m: float) -> CommandResult:
        """Take off to ``altitude_m`` above home (MAV_CMD_NAV_TAKEOFF; GUIDED and armed)."""
        try:
            alt = cmd.check_altitude(altitude_m)
        except ValueError as exc:
            return self._invalid("takeoff", exc)
        return self._command_long(
            "takeoff", mavlink2.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, math.nan, 0, 0, alt)
        )

    def land(self) -> CommandResult:
        """Land where the vehicle is (MAV_CMD_NAV_LAND: ArduCopter switches to LAND)."""
        return self._command_long("land", mavlink2.MAV_CMD_NAV_LAND, (0, 0, 0, math.nan, 0, 0, 0))

    def rtl(self) -> CommandResult:
        """Return to launch (MAV_CMD_NAV_RETURN_TO_LAUNCH)."""
        return self._command_long("rtl", mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH, ())

    def reboot(self) -> CommandResult:
        """Reboot the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1 = 1).

        ArduCopter refuses while armed. Needed for settings read at boot, such as
        PLND_TYPE. The link goes LOST while the vehicle restarts and comes back by itself.
        """
        return self._command_long("reboot", mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (1,))

    def goto_local_ned(
        self, north: float, east: float, down: float, *, yaw_deg: float | None = None
    ) -> CommandResult:
        """Send a GUIDED position target in the local NED frame (metres from home).

        ArduCopter does not acknowledge these: ``ok`` means sent. It obeys only in GUIDED.
        """
        try:
            fields = cmd.position_target(north, east, down, yaw_deg=yaw_deg)
        except ValueError as exc:
            return self._invalid("goto_local_ned", exc)
        return self._send_position_target("goto_local_ned", fields)

    def set_velocity_ned(
        self,
        vn: float,
        ve: float,
        vd: float,
        *,
        yaw_rate_dps: float | None = None,
        frame: str = "local_ned",
    ) -> CommandResult:
        """Send a GUIDED velocity target (m/s); re-send at >= 1 Hz, it lapses after ~3 s.

        ``frame``: ``"local_ned"`` or ``"body_offset_ned"`` (forward/right/down).
        """
        try:
            fields = cmd.velocity_target(vn, ve, vd, yaw_rate_dps=yaw_rate_dps, frame=frame)
        except ValueError as exc:
            return self._invalid("set_velocity_ned", exc)
        return self._send_position_target("set_velocity_ned", fields)

    def send_landing_target(
        self,
        x: float,
        y: float,
        z: float,
        *,
        time_usec: int,
        distance: float | None = None,
        frame: int = mavlink2.MAV_FRAME_BODY_FRD,
        target_num: int = 0,
        size_x: float = 0.0,
        size_y: float = 0.0,
        target_type: int = mavlink2.LANDING_TARGET_TYPE_VISION_FIDUCIAL,
    ) -> CommandResult:
        """Send LANDING_TARGET (position_valid = 1, MAVLink 2 extension fields).

        ``x, y, z`` metres in ``frame`` (ArduCopter takes MAV_FRAME_BODY_FRD only),
        ``time_usec`` the capture time of the frame the pad was seen in. Not
        acknowledged: ``ok`` means sent; the telemetry counts what was sent.
        """
        try:
            fields = cmd.landing_target(
                x,
                y,
                z,
                time_usec=time_usec,
                distance=distance,
                frame=frame,
                target_num=target_num,
                size_x=size_x,
                size_y=size_y,
                target_type=target_type,
            )
        except ValueError as exc:
            return self._invalid("landing_target", exc)
        result = self._send_unacked(
            "landing_target", mavlink2.MAVLink_landing_target_message(**fields)
        )
        if result.ok:
            self._landing_targets += 1
            self._apply(
                {
                    "landing_targets_sent": self._landing_targets,
                    "last_landing_target": {
                        "x": fields["x"],
                        "y": fields["y"],
                        "z": fields["z"],
                        "distance": fields["distance"],
                        "time_usec": float(fields["time_usec"]),
                        "sent_monotonic": time.monotonic(),
                    },
                }
            )
        return result

    def rc_override(self, channels: Mapping[int, int]) -> CommandResult:
        """Override RC channels: ``{channel (1-based): pwm}``; 0 releases, 65535 ignores.

        ArduCopter drops overrides after RC_OVERRIDE_TIME (3 s): re-send at >= 1 Hz. In
        LOITER/ALT_HOLD hold the throttle (channel 3) at 1500 or the vehicle descends.
        """
        try:
            values = cmd.rc_override_channels(channels)
        except ValueError as exc:
            return self._invalid("rc_override", exc)
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_rc_channels_override_message(target[0], target[1], *values)
        return self._send_unacked("rc_override", msg)

    def get_param(self, name: str, *, timeout: float | None = None) -> float | None:
        """Read one parameter (PARAM_REQUEST_READ); None if the link is down or no answer.

        Raises ``ValueError`` for a malformed name.
        """
        name = cmd.check_param_name(name)
        wait = self._cmd_timeout if timeout is None else cmd.finite(timeout, "timeout")
        if wait <= 0:
            raise ValueError(f"timeout must be > 0, got {timeout!r}")
        if self._state != LinkState.UP:
            return None
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_param_request_read_message(
            target[0], target[1], name.encode("ascii"), -1
        )
        try:
            got = self._param_exchange(name, msg, wait)
        except SendError as exc:
            self._note_error(f"get_param {name}: {exc}")
            return None
        return None if got is None else got[0]

    def set_param(self, name: str, value: float) -> CommandResult:
        """Write one parameter (PARAM_SET), verified by the vehicle's PARAM_VALUE echo."""
        label = f"set_param {name}"
        try:
            name = cmd.check_param_name(name)
            fvalue = cmd.finite(value, "value")
        except ValueError as exc:
            return self._invalid(label, exc)
        if self._state != LinkState.UP:
            return self._link_down(label)
        known = self._params.get(name)
        ptype = known[1] if known else mavlink2.MAV_PARAM_TYPE_REAL32
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_param_set_message(
            target[0], target[1], name.encode("ascii"), fvalue, ptype
        )
        started = time.monotonic()
        try:
            got = self._param_exchange(name, msg, self._cmd_timeout)
        except SendError as exc:
            return self._finish(
                CommandResult(False, label, None, cmd.SEND_FAILED, detail=f"not sent: {exc}")
            )
        elapsed = time.monotonic() - started
        if got is None:
            detail = (
                f"no PARAM_VALUE echo within {self._cmd_timeout:g} s "
                "(unknown parameter, or the link lost it)"
            )
            return self._finish(CommandResult(False, label, None, cmd.TIMEOUT, (), detail, elapsed))
        echoed = got[0]
        expected = cmd.as_float32(fvalue)
        if math.isclose(echoed, expected, rel_tol=1e-6, abs_tol=1e-9):
            return self._finish(
                CommandResult(True, label, None, "ACCEPTED", (), f"{name} = {echoed:g}", elapsed)
            )
        detail = f"the vehicle kept {name} = {echoed:g}, not {fvalue:g}"
        return self._finish(CommandResult(False, label, None, cmd.MISMATCH, (), detail, elapsed))

    # ------------------------------------------------------------------ command plumbing
    def _invalid(self, name: str, exc: ValueError) -> CommandResult:
        # refused before anything is sent; not an event: nothing happened on the link
        return CommandResult(False, name, None, cmd.INVALID_ARGUMENT, (), str(exc))

    def _link_down(self, name: str) -> CommandResult:
        state = self._state
        if state == LinkState.LOST:
            why = "the link is lost (no heartbeat from the vehicle)"
        elif state == LinkState.CLOSED:
            why = "the link is closed"
        else:
            why = "the link is not up yet (no heartbeat from the vehicle so far)"
        return CommandResult(False, name, None, cmd.LINK_DOWN, (), f"{why}; nothing was sent")

    def _finish(self, result: CommandResult) -> CommandResult:
        self._emit("command", result.to_dict())
        return result

    def _command_lock(self, command_id: int) -> threading.Lock:
        with self._command_locks_guard:
            return self._command_locks.setdefault(command_id, threading.Lock())

    def _command_long_msg(
        self, command_id: int, params: tuple[float, ...], confirmation: int
    ) -> Any:
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        target = self._target or (1, 1)
        return mavlink2.MAVLink_command_long_message(
            target[0], target[1], command_id, confirmation, *p
        )

    def _command_long(self, name: str, command_id: int, params: tuple[float, ...]) -> CommandResult:
        """Send COMMAND_LONG and wait for its COMMAND_ACK (one retransmission halfway)."""
        if self._state != LinkState.UP:
            return self._link_down(name)
        timeout = self._cmd_timeout
        lock = self._command_lock(command_id)
        if not lock.acquire(timeout=timeout):
            detail = f"another {name} command is still waiting for its acknowledgement"
            return self._finish(CommandResult(False, name, None, cmd.TIMEOUT, (), detail))
        try:
            pending = self._tracker.begin(command_id, name)
            try:
                return self._finish(self._await_ack(name, command_id, params, pending, timeout))
            finally:
                self._tracker.end(pending)
        finally:
            lock.release()

    def _await_ack(
        self,
        name: str,
        command_id: int,
        params: tuple[float, ...],
        pending: cmd.PendingCommand,
        timeout: float,
    ) -> CommandResult:
        sent = time.monotonic()
        try:
            self._send(self._command_long_msg(command_id, params, 0))
        except SendError as exc:
            return CommandResult(False, name, None, cmd.SEND_FAILED, (), f"not sent: {exc}")
        deadline = sent + timeout
        resend_at = sent + timeout / 2
        resent = False
        while True:
            now = time.monotonic()
            if (
                pending.ack_result is not None
                and pending.ack_result != mavlink2.MAV_RESULT_IN_PROGRESS
            ):
                break
            if now >= deadline or self._state != LinkState.UP:
                break
            if now >= resend_at and pending.ack_result is None:
                resend_at = math.inf
                with contextlib.suppress(SendError):
                    self._send(self._command_long_msg(command_id, params, 1))
                    resent = True
            pending.event.wait(min(0.05, max(0.0, min(deadline, resend_at) - now)))
            pending.event.clear()
        if resent and pending.ack_result is not None:
            # The retransmission earns an ACK of its own; take it here so that it cannot
            # pass for the answer to the next command with the same id.
            linger = time.monotonic() + _RESENT_ACK_WAIT_S
            while pending.acks < 2 and time.monotonic() < linger and not self._stop.is_set():
                pending.event.wait(0.02)
                pending.event.clear()
        result = pending.ack_result
        if result is None or result == mavlink2.MAV_RESULT_IN_PROGRESS:
            elapsed = time.monotonic() - sent
            reasons = cmd.select_reasons(pending.texts)
            if self._state != LinkState.UP:
                detail = f"the link went {self._state.value} before the vehicle answered"
                return CommandResult(False, name, None, cmd.LINK_DOWN, reasons, detail, elapsed)
            detail = f"no COMMAND_ACK within {timeout:g} s"
            if result == mavlink2.MAV_RESULT_IN_PROGRESS:
                detail += " (the vehicle reported it in progress)"
            return CommandResult(False, name, result, cmd.TIMEOUT, reasons, detail, elapsed)
        elapsed = (pending.acked_at or time.monotonic()) - sent
        result_name = cmd.mav_result_name(result)
        if result == mavlink2.MAV_RESULT_ACCEPTED:
            return CommandResult(True, name, result, result_name, (), "accepted", elapsed)
        # the vehicle's explanation may trail its COMMAND_ACK by a few messages
        self._stop.wait(_REASON_GRACE_S)
        reasons = cmd.select_reasons(pending.texts)
        detail = f"refused by the vehicle ({result_name})"
        if reasons:
            detail += ": " + "; ".join(reasons)
        return CommandResult(False, name, result, result_name, reasons, detail, elapsed)

    def _send_position_target(self, name: str, fields: dict[str, Any]) -> CommandResult:
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_set_position_target_local_ned_message(
            self._time_boot_ms(), target[0], target[1], **fields
        )
        result = self._send_unacked(name, msg)
        mode = self._telemetry.mode
        if result.ok and mode != "GUIDED":
            return replace(result, detail=f"sent; ArduCopter ignores it in {mode} (not GUIDED)")
        return result

    def _send_unacked(self, name: str, msg: Any) -> CommandResult:
        if self._state != LinkState.UP:
            return self._link_down(name)
        try:
            self._send(msg)
        except SendError as exc:
            return CommandResult(False, name, None, cmd.SEND_FAILED, (), f"not sent: {exc}")
        return CommandResult(True, name, None, cmd.SENT, (), "sent (not acknowledged by design)")

    def _param_exchange(self, name: str, msg: Any, timeout: float) -> tuple[float, int] | None:
        """Send ``msg`` and wait for a PARAM_VALUE for ``name`` (resent halfway)."""
        sent = time.monotonic()
        self._send(msg)
        deadline = sent + timeout
        resend_at = sent + timeout / 2
        while True:
            with self._param_cond:
                got = self._params.get(name)
                if got is not None and got[2] >= sent:
                    return got[0], got[1]
                now = time.monotonic()
                if now >= deadline or self._state != LinkState.UP:
                    return None
                if now < resend_at:
                    self._param_cond.wait(min(0.05, deadline - now))
                    continue
            resend_at = math.inf  # sent outside the lock: the reader must not wait on us
            with contextlib.suppress(SendError):
                self._send(msg)

    def _send(self, msg: Any) -> None:
        transport = self._transport
        if transport is None:
            raise SendError("the link has not been started")
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

    # ------------------------------------------------------------------ reader thread
    def _reader_loop(self) -> None:
        transport = self._transport
        assert transport is not None
        try:
            self._read_until_stopped(transport)
        finally:
            transport.close()  # also when close() came while a connect was under way

    def _read_until_stopped(self, transport: Transport) -> None:
        backoff = _BACKOFF_S[0]
        while not self._stop.is_set():
            if not transport.is_open:
                try:
                    transport.open()
                except Exception as exc:  # refused, no device, bad address: retry later
                    self._note_error(f"cannot open {self.url}: {exc}")
                    self._stop.wait(backoff)
                    backoff = min(backoff * 2, _BACKOFF_S[1])
                    continue
                backoff = _BACKOFF_S[0]
                self._apply({"reconnects": max(0, transport.opened - 1)})
                self._wake.set()  # heartbeat at once: a UDP/TCP vehicle learns about us
                continue
            try:
                msg = transport.recv_msg()
            except TransportDropped as exc:
                transport.close()
                self._note_error(str(exc))
                if self._state == LinkState.UP:
                    self._set_state(LinkState.LOST, str(exc))
                self._stop.wait(_BACKOFF_S[0])
                continue
            except Exception as exc:  # a parser fault: count it, drop the buffer, go on
                self._handler_errors += 1
                log.exception("MAVLink parser fault; buffer dropped")
                self._note_error(f"parser fault: {exc}")
                transport.reset_parser()
                continue
            if msg is None:
                transport.wait_readable(0.05)
                continue
            self._dispatch(msg)

    def _dispatch(self, msg: Any) -> None:
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            return  # counted by the parser (receive_errors)
        self._rx_count += 1
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        now = time.monotonic()
        if mtype == "HEARTBEAT":
            if not self._is_vehicle_heartbeat(msg):
                return
            if self._target is None:
                self._target = src
            if src != self._target:
                return
            self._last_hb = now
            if self._state != LinkState.UP:
                self._set_state(LinkState.UP, f"heartbeat from system {src[0]}")
        target = self._target
        if target is None or src[0] != target[0]:
            return
        self._latest[mtype] = msg
        handler = TELEMETRY_HANDLERS.get(mtype)
        if handler is not None:
            self._run_isolated(mtype, self._apply_handler, handler, msg, now)
        link_handler = self._link_handlers.get(mtype)
        if link_handler is not None:
            self._run_isolated(mtype, link_handler, msg)

    def _run_isolated(self, mtype: str, fn: Callable[..., None], *args: Any) -> None:
        try:
            fn(*args)
        except Exception:
            self._handler_errors += 1
            # the first few in full, then a reminder now and then: never a log flood
            if self._handler_errors <= 5 or self._handler_errors % 1000 == 0:
                log.exception("handler for %s failed (%d so far)", mtype, self._handler_errors)

    def _apply_handler(
        self, handler: Callable[[Any, float], dict[str, Any]], msg: Any, now: float
    ) -> None:
        changes = handler(msg, now)
        old = self._telemetry
        self._apply(changes)
        if msg.get_type() == "HEARTBEAT":
            new = self._telemetry
            if new.mode_number != old.mode_number:
                self._emit(
                    "mode_changed",
                    {"mode": new.mode, "mode_number": new.mode_number, "previous": old.mode},
                )
            if new.armed != old.armed:
                self._emit("armed" if new.armed else "disarmed", {"mode": new.mode})

    @staticmethod
    def _is_vehicle_heartbeat(msg: Any) -> bool:
        return (
            msg.type not in _NOT_VEHICLE_TYPES
            and msg.autopilot != mavlink2.MAV_AUTOPILOT_INVALID
            and msg.get_srcComponent() != mavlink2.MAV_COMP_ID_GIMBAL
        )

    def _on_command_ack(self, msg: Any) -> None:
        addressed = getattr(msg, "target_system", 0)
        if addressed not in (0, self._source_system):
            return  # an answer to another ground station
        matched = self._tracker.on_ack(msg.command, msg.result, getattr(msg, "progress", 0))
        if (
            not matched
            and msg.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL
            and msg.result != mavlink2.MAV_RESULT_ACCEPTED
        ):
            self._streams.refused()
            self._wake.set()

    def _on_statustext(self, msg: Any) -> None:
        text = self._statustexts.feed(msg)
        if text is None:
            return
        entry = StatusText(time.time(), int(msg.severity), text)
        history = (*self._telemetry.statustexts, entry)[-STATUSTEXT_HISTORY:]
        self._apply({"statustexts": history})
        self._tracker.on_statustext(entry.severity, text)
        self._emit("statustext", {"severity": entry.severity, "text": text})

    def _on_param_value(self, msg: Any) -> None:
        with self._param_cond:
            self._params[str(msg.param_id)] = (
                float(msg.param_value),
                int(msg.param_type),
                time.monotonic(),
            )
            self._param_cond.notify_all()

    # ------------------------------------------------------------------ housekeeping thread
    def _housekeeping_loop(self) -> None:
        next_heartbeat = 0.0
        next_flush = 0.0
        rates: deque[tuple[float, int]] = deque(maxlen=32)
        while not self._stop.is_set():
            self._wake.wait(_TICK_S)
            self._wake.clear()
            if self._stop.is_set():
                break
            now = time.monotonic()
            try:
                if now >= next_heartbeat:
                    next_heartbeat = now + 1.0
                    self._send_heartbeat()
                self._check_heartbeat(now)
                self._manage_streams(now)
                self._update_quality(now, rates)
                if now >= next_flush and self._tlog is not None:
                    next_flush = now + 1.0
                    self._tlog.flush()
            except Exception:
                self._handler_errors += 1
                log.exception("vehicle link housekeeping failed")

    def _send_heartbeat(self) -> None:
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
        with contextlib.suppress(SendError):  # the reader notices a dead transport
            transport.send(msg)

    def _check_heartbeat(self, now: float) -> None:
        last = self._last_hb
        if self._state == LinkState.UP and last is not None and now - last > self._hb_timeout:
            self._set_state(LinkState.LOST, f"no heartbeat for {self._hb_timeout:g} s")

    def _manage_streams(self, now: float) -> None:
        target = self._target
        if self._state != LinkState.UP or target is None:
            return
        action = self._streams.due(now, self._telemetry.attitude_rx_monotonic)
        if action == "intervals":
            messages = streams.interval_messages(target, self._stream_rates)
        elif action == "data_streams":
            messages = streams.data_stream_messages(target)
        else:
            return
        for msg in messages:
            with contextlib.suppress(SendError):  # the reader notices a dead transport
                self._send(msg)

    def _update_quality(self, now: float, rates: deque[tuple[float, int]]) -> None:
        transport = self._transport
        assert transport is not None
        rates.append((now, self._rx_count))
        while len(rates) > 2 and now - rates[0][0] > 2.0:
            rates.popleft()
        t_old, n_old = rates[0]
        per_s = (self._rx_count - n_old) / (now - t_old) if now > t_old else 0.0
        self._apply(
            {
                "msgs_per_s": round(per_s, 2),
                "crc_errors": transport.receive_errors,
                "packets_lost_pct": round(transport.packets_lost_pct, 2),
                "handler_errors": self._handler_errors,
                "reconnects": max(0, transport.opened - 1),
            }
        )

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
