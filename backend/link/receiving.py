"""The link's reader thread: receive, cache the latest message per type, dispatch.

A message whose values cannot be real (:mod:`.plausibility`) is dropped and counted.
Each message goes to its handlers (a dict from type to handler, each isolated in its
own try/except, so one bad message can never stall the link); a dropped transport is
reopened with a back-off.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link.connection import Transport, TransportDropped
from backend.link.core import _BACKOFF_S, LinkCore
from backend.link.plausibility import implausible
from backend.link.state import LinkState
from backend.link.telemetry import (
    CLOCK_MESSAGES,
    POSITION_STALE_MS,
    STATE_COMMANDS,
    STATUSTEXT_HISTORY,
    TELEMETRY_HANDLERS,
    StatusText,
    clock_changes,
)

log = logging.getLogger("backend.link.vehicle_link")

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


class LinkReceiver(LinkCore):
    """The reader thread of :class:`~backend.link.VehicleLink`."""

    _link_handlers: dict[str, Callable[[Any], None]]

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
                # a new connection (SITL restarts its process): what answers is the new boot
                self._rebooting_until = 0.0
                self._apply({"reconnects": max(0, transport.opened - 1)})
                # Our heartbeat at once, from this thread: a UDP/TCP vehicle learns about
                # us, and it goes out before anything the vehicle sends is read (left to
                # the housekeeper, a loaded machine had it miss a session of 0.1 s).
                self._send_heartbeat()
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
        problem = implausible(msg)
        if problem is not None:  # well-formed, but not what any vehicle can be doing
            self._implausible += 1
            self._apply(
                {"implausible": self._implausible, "last_implausible": f"{mtype}: {problem}"}
            )
            return
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
            if self._state != LinkState.UP and now >= self._rebooting_until:
                self._set_state(LinkState.UP, f"heartbeat from system {src[0]}")
        target = self._target
        if target is None or src[0] != target[0]:
            return
        if mtype in CLOCK_MESSAGES and src == target:
            self._run_isolated(mtype, self._on_vehicle_clock, int(msg.time_boot_ms))
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

    def _on_vehicle_clock(self, boot_ms: int) -> None:
        rate = self._stream_rates.get("LOCAL_POSITION_NED")
        stale_ms = POSITION_STALE_MS if not rate else max(POSITION_STALE_MS, 3000.0 / rate)
        old = self._telemetry
        # (_rebooting_until stays set from an accepted reboot until its new boot is heard)
        asked = self._rebooting_until > 0.0
        changes = clock_changes(old, boot_ms, stale_ms, reboot_asked=asked)
        if changes.get("boots", old.boots) != old.boots:
            # What the cache holds came from the previous boot.
            self._latest = {k: v for k, v in self._latest.items() if k == "HEARTBEAT"}
            with self._param_cond:
                # The new boot may number its parameters otherwise (an enabled subsystem
                # adds some): the indices heard count no more; the values stay.
                self._param_indices.clear()
            log.info("the vehicle rebooted (its clock went back to %d ms)", boot_ms)
            rebooting = self._state == LinkState.LOST and asked
            self._rebooting_until = 0.0  # (the new boot is heard: nothing more to wait for)
        else:
            rebooting = False
        if changes.get("position_stale") and not old.position_stale:
            log.warning("LOCAL_POSITION_NED stopped: the position is no longer current")
        self._apply(changes)
        if rebooting:
            # the new boot is heard (its heartbeat came first): no need to wait out the hold
            self._set_state(LinkState.UP, "the vehicle is back from its reboot")

    def _apply_handler(
        self, handler: Callable[[Any, float], dict[str, Any]], msg: Any, now: float
    ) -> None:
        changes = handler(msg, now)
        old = self._telemetry
        if msg.get_type() == "HEARTBEAT":
            changes["heartbeats"] = old.heartbeats + 1
            changes["state_confirmed"] = True
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
        if msg.command in STATE_COMMANDS and msg.result == mavlink2.MAV_RESULT_ACCEPTED:
            # whoever asked: the armed flag and mode are old until the next HEARTBEAT
            self._apply({"state_confirmed": False})
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
        old = self._telemetry
        history = (*old.statustexts, entry)[-STATUSTEXT_HISTORY:]
        self._apply({"statustexts": history, "statustexts_received": old.statustexts_received + 1})
        self._tracker.on_statustext(entry.severity, text)
        self._emit("statustext", {"severity": entry.severity, "text": text})

    def _on_param_value(self, msg: Any) -> None:
        with self._param_cond:
            self._params[str(msg.param_id)] = (
                float(msg.param_value),
                int(msg.param_type),
                time.monotonic(),
            )
            # The vehicle's count of parameters (the table is whole when we hold them all).
            count = int(getattr(msg, "param_count", 0) or 0)
            if 0 < count < 0xFFFF:
                self._param_count = count
            # Which of them this is: a download asks for the missing ones by index. A
            # PARAM_SET's echo has none (65535, as ArduPilot sends -1).
            index = int(getattr(msg, "param_index", -1))
            if 0 <= index < self._param_count:
                self._param_indices.add(index)
            self._param_cond.notify_all()
