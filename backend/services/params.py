"""The vehicle's parameters: read them all, write one (checked, confirmed by the vehicle's
echo, logged), reboot the autopilot, and set up precision landing in one step.

Every write is an event (``param``), whether the vehicle took it or not; so is a reboot.
Calls block the calling thread until the vehicle answers or a timeout (the routes run
them on worker threads).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from backend.link import CommandResult, LinkEvent, LinkState, VehicleLink
from backend.missions.extnav import (
    ARMING_CHECK_ALL_BUT_VISION,
    ARMING_CHECK_VISION,
    EXTNAV_PARAMS,
    viso_delay_ms,
)
from backend.services.events import EventLog
from backend.services.param_meta import META, check_value

#: A parameter download gives up when no new parameter came for this long (a telemetry
#: radio sends ~800 params in ~20 s at 57600 baud; the vehicle was asked again meanwhile) ...
LIST_TIMEOUT_S = 20.0
#: ... and in any case after this long: a slow link that keeps delivering is not cut off.
LIST_MAX_S = 120.0
#: No new parameter for this long: the list stalled. Asked again while none of it came
#: (a lost request, a vehicle still booting), at most LIST_ASKS times; once some came,
#: the missing ones are asked for by index, READ_BATCH at a time (as MAVProxy and
#: QGroundControl fill the gaps; a radio link is not flooded).
LIST_STALL_S = 2.0
LIST_ASKS = 4
READ_BATCH = 20
#: PLND_LAG's documented range (s).
LAG_RANGE_S = (0.02, 0.25)
#: Result -> LANDING_TARGET on the link, added to the measured capture -> result (ms):
#: the mission thread is woken by the result and sends at once (bench.station_load
#: measures it under 10 ms at p95).
SEND_MS = 10.0
BATTERY_PARAMS = ("BATT_LOW_VOLT", "BATT_CRT_VOLT", "BATT_LOW_MAH", "BATT_CRT_MAH", "BATT_CAPACITY")
#: After the set-up's reboot: how long the vehicle may take to come back (wall s), and then
#: to have its position estimate again (ArduCopter: ~41 s after any boot).
REBOOT_BACK_S = 60.0
READY_AFTER_REBOOT_S = 180.0

#: Read whenever the link comes up: the alerts' thresholds and the landing panel's PLND state.
WATCHED = (
    *BATTERY_PARAMS,
    "PLND_ENABLED",
    "PLND_TYPE",
    "PLND_LAG",
    "VISO_TYPE",
    "EK3_SRC2_POSXY",
)


class UnknownParam(LookupError):
    """The vehicle has no parameter of that name."""


class BadValue(ValueError):
    """The value is outside the parameter's range or type (one sentence)."""


class VehicleArmed(RuntimeError):
    """Refused because the vehicle is armed (a reboot; a set-up that ends in one)."""


@dataclass(frozen=True)
class Write:
    """One parameter write: what was asked, what the vehicle said."""

    name: str
    old: float | None
    value: float
    result: CommandResult

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "old": self.old,
            "value": self.value,
            "ok": self.result.ok,
            "detail": self.result.detail,
        }


def lag_from_latency(latency_ms: float | None) -> float:
    """PLND_LAG (s) for a measured capture -> result latency, within its documented range.

    >>> lag_from_latency(72.0)
    0.082
    >>> lag_from_latency(None)
    0.1
    >>> lag_from_latency(900.0)
    0.25
    """
    if latency_ms is None or not math.isfinite(latency_ms) or latency_ms < 0:
        return 0.1  # nothing measured yet: a camera at ~10 fps with its processing
    lag = (latency_ms + SEND_MS) / 1000.0
    return round(min(LAG_RANGE_S[1], max(LAG_RANGE_S[0], lag)), 3)


class ParamService:
    """Parameters of the vehicle on ``link``; ``latency_ms()`` the vision's measured
    capture -> result latency (for PLND_LAG)."""

    def __init__(
        self,
        link: VehicleLink,
        events: EventLog,
        *,
        latency_ms: Callable[[], float | None],
        camera_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        self._link = link
        self._events = events
        self._latency_ms = latency_ms
        self._camera_offset = camera_offset_m
        self._lock = threading.Lock()  # one write or download at a time
        self.fetched_at: float | None = None

    # --- reading ---------------------------------------------------------------------------
    def on_link_event(self, event: LinkEvent) -> None:
        """When the link comes up (a start, a reboot), read :data:`WATCHED` in the
        background: the battery alerts and the landing panel need them at once."""
        if event.kind == "link_up":
            threading.Thread(target=self._read_watched, name="params-watched", daemon=True).start()

    def _read_watched(self) -> None:
        for name in WATCHED:
            if self._link.state != LinkState.UP:
                return
            self._link.get_param(name, timeout=2.0)

    def listing(self, names: set[str] | None = None) -> dict[str, Any]:
        """Every parameter heard so far (or those of ``names``) with its documentation,
        and whether that is all of them."""
        table, count = self._link.param_table()
        params = []
        for name in sorted(table):
            if names is not None and name not in names:
                continue
            value, ptype = table[name]
            params.append(_describe(name, value, ptype))
        return {
            "count": count,
            "received": len(table),
            "complete": count > 0 and len(table) >= count,
            "fetched_at": self.fetched_at,
            "params": params,
        }

    def refresh(self, timeout_s: float = LIST_TIMEOUT_S) -> dict[str, Any]:
        """Download every parameter (PARAM_REQUEST_LIST, then the gaps by index); returns
        :meth:`listing`.

        Waits until the vehicle sent as many as it says it has, or nothing new came for
        ``timeout_s`` (:data:`LIST_MAX_S` at most); the listing says how many came.
        """
        if self._link.state != LinkState.UP:
            raise ConnectionError("the link to the vehicle is down; no parameters were read")
        with self._lock:
            _Download(self._link, timeout_s).run()
            self.fetched_at = time.time()
        return self.listing()

    def value(self, name: str) -> float | None:
        table, _ = self._link.param_table()
        got = table.get(name)
        return None if got is None else got[0]

    def battery_thresholds(self) -> dict[str, float | None]:
        """BATT_* values the alerts use (None where the vehicle has no such parameter)."""
        table, _ = self._link.param_table()
        return {name: (table[name][0] if name in table else None) for name in BATTERY_PARAMS}

    # --- writing ---------------------------------------------------------------------------
    def write(self, name: str, value: float, *, why: str = "") -> Write:
        """Check ``value`` and write it; raises :class:`UnknownParam`, :class:`BadValue`."""
        table, _ = self._link.param_table()
        if name not in table:
            # Perhaps not downloaded yet: ask for this one before refusing.
            if self._link.get_param(name, timeout=2.0) is None:
                raise UnknownParam(f"The vehicle has no parameter {name}.")
            table, _ = self._link.param_table()
        old, ptype = table[name]
        problem = check_value(name, value, ptype)
        if problem is not None:
            raise BadValue(problem)
        with self._lock:
            result = self._link.set_param(name, value)
        write = Write(name, old, float(value), result)
        self._log(write, why)
        return write

    def reboot(self, *, why: str = "") -> CommandResult:
        """Reboot the autopilot (refused while armed, as ArduCopter itself refuses)."""
        if self._link.telemetry.armed:
            raise VehicleArmed("The vehicle is armed: land and disarm before a reboot.")
        result = self._link.reboot()
        text = "autopilot reboot " + ("sent" if result.ok else f"refused: {result.detail}")
        self._events.emit(
            "param", text + (f" ({why})" if why else ""), {"reboot": True, "ok": result.ok}
        )
        return result

    def setup_precland(self) -> dict[str, Any]:
        """Write what ArduCopter's precision landing needs to take this station's targets,
        PLND_LAG from the measured latency, then reboot (PLND_TYPE is read at boot).

        Stops at the first write the vehicle refuses; raises :class:`VehicleArmed`
        while armed (nothing written).
        """
        if self._link.telemetry.armed:
            raise VehicleArmed(
                "The vehicle is armed: land and disarm before setting up precision landing "
                "(it ends in a reboot)."
            )
        latency = self._latency_ms()
        lag = lag_from_latency(latency)
        why = "precision landing set-up"
        wanted: list[tuple[str, float]] = [
            ("PLND_ENABLED", 1.0),
            ("PLND_TYPE", 1.0),
            ("PLND_EST_TYPE", 1.0),
            ("PLND_LAG", lag),
            ("PLND_ORIENT", 25.0),
        ]
        for axis, offset in zip("XYZ", self._camera_offset, strict=True):
            wanted.append((f"PLND_CAM_POS_{axis}", offset))
        # older firmware may lack one (e.g. PLND_ORIENT before 4.2): skipped
        writes, refused = self._write_all(wanted, why, skip_unknown=True)
        if refused:
            return _setup_answer(writes, None, refused, lag_s=lag, latency_ms=latency)
        boots = self._link.telemetry.boots
        reboot = self.reboot(why=why)
        measured = "none measured yet" if latency is None else f"measured {latency:.0f} ms"
        detail = (
            f"Precision landing set up: {len(writes)} parameters written, PLND_LAG {lag:g} s "
            f"({measured} capture to result, plus {SEND_MS:g} ms to send)"
        )
        if reboot.ok:
            detail += (
                "; the autopilot is rebooting. Missions wait for its position estimate "
                "(ArduCopter: about 40 s after a boot); the event log says when it is back."
            )
            threading.Thread(
                target=self._follow_reboot, args=(boots, why), name="params-reboot", daemon=True
            ).start()
        else:
            detail += f"; the reboot was refused ({reboot.detail}), reboot it before landing."
        return _setup_answer(writes, reboot, detail, lag_s=lag, latency_ms=latency)

    def setup_extnav(self) -> dict[str, Any]:
        """Write what a GPS-denied landing needs (ArduPilot's ExternalNav fed by this
        station's VISION_POSITION_ESTIMATE; see :mod:`backend.missions.extnav`), then
        reboot (VISO_TYPE is read at boot).

        ARMING_CHECK keeps every check but the visual odometry's (the pad is not in view
        on the ground, and with VISO_TYPE 1 ArduCopter refuses to arm without vision): a
        mask of 1 (all) becomes all-but-vision, any other mask loses only that bit.
        Stops at the first write the vehicle refuses; raises :class:`VehicleArmed` while
        armed (nothing written).
        """
        if self._link.telemetry.armed:
            raise VehicleArmed(
                "The vehicle is armed: land and disarm before setting up external "
                "navigation (it ends in a reboot)."
            )
        why = "external navigation set-up"
        latency = self._latency_ms()
        delay = viso_delay_ms(latency, SEND_MS)
        wanted = [*EXTNAV_PARAMS, ("VISO_DELAY_MS", float(delay))]
        checks = self._link.get_param("ARMING_CHECK", timeout=2.0)
        if checks is not None and int(checks) != 0:
            mask = int(checks)
            mask = ARMING_CHECK_ALL_BUT_VISION if mask & 1 else mask & ~ARMING_CHECK_VISION
            wanted.append(("ARMING_CHECK", float(mask)))
        writes, refused = self._write_all(wanted, why)
        if refused:
            return _setup_answer(writes, None, refused, delay_ms=delay, latency_ms=latency)
        reboot = self.reboot(why=why)
        measured = "none measured yet" if latency is None else f"measured {latency:.0f} ms"
        detail = (
            f"External navigation set up: {len(writes)} parameters written (VISO_TYPE 1, "
            "EKF source set 2 = vision position and velocity, baro height, compass yaw; "
            f"VISO_DELAY_MS {delay}: {measured} capture to result, plus {SEND_MS:g} ms to send)"
        )
        detail += (
            "; the autopilot is rebooting."
            if reboot.ok
            else f"; the reboot was refused ({reboot.detail}), reboot it before landing."
        )
        return _setup_answer(writes, reboot, detail, delay_ms=delay, latency_ms=latency)

    def _follow_reboot(self, boots: int, why: str) -> None:
        """Say when the vehicle is back from the set-up's reboot (with the values it
        booted with) and when it has its position estimate again: only then can it fly."""
        link = self._link
        back = link.wait_until(lambda t: t.boots > boots and t.state == LinkState.UP, REBOOT_BACK_S)
        if not back:
            self._events.emit(
                "param",
                f"the autopilot was not seen back from its reboot within {REBOOT_BACK_S:g} s "
                f"({why})",
                {"reboot": True, "back": False},
            )
            return
        values = {name: link.get_param(name, timeout=2.0) for name in ("PLND_ENABLED", "PLND_TYPE")}
        said = ", ".join(f"{n} {'unread' if v is None else f'{v:g}'}" for n, v in values.items())
        self._events.emit(
            "param",
            f"the autopilot is back from its reboot with {said}; waiting for its position "
            f"estimate ({why})",
            {"reboot": True, "back": True, **values},
        )
        if link.wait_until(lambda t: t.position_ready, READY_AFTER_REBOOT_S):
            text = f"the autopilot has its position estimate again: ready to fly ({why})"
            ready = True
        else:
            text = (
                f"the autopilot has no position estimate {READY_AFTER_REBOOT_S:g} s after its "
                f"reboot ({why})"
            )
            ready = False
        self._events.emit("param", text, {"reboot": True, "ready": ready})

    def _write_all(
        self, wanted: list[tuple[str, float]], why: str, *, skip_unknown: bool = False
    ) -> tuple[list[Write], str]:
        """Write each (name, value) in turn; stops at the first the vehicle refuses.
        Returns the writes made and, on a refusal, the sentence that says so ("" else)."""
        writes: list[Write] = []
        for name, value in wanted:
            try:
                write = self.write(name, value, why=why)
            except UnknownParam:
                if skip_unknown:
                    continue
                raise
            writes.append(write)
            if not write.result.ok:
                return writes, (
                    f"The vehicle refused {name}: {write.result.detail}; "
                    "nothing more was written and no reboot was sent."
                )
        return writes, ""

    def _log(self, write: Write, why: str) -> None:
        old = "unknown" if write.old is None else f"{write.old:g}"
        if write.result.ok:
            text = f"parameter {write.name} set from {old} to {write.value:g}"
        else:
            text = f"parameter {write.name} not set to {write.value:g}: {write.result.detail}"
        if why:
            text += f" ({why})"
        self._events.emit("param", text, {**write.to_dict(), "why": why})


class _Download:
    """One parameter download on ``link`` (see :meth:`ParamService.refresh`)."""

    def __init__(self, link: VehicleLink, timeout_s: float) -> None:
        self._link = link
        self._timeout_s = timeout_s
        self._started = time.monotonic()
        self._progress: tuple[int, int] = (-1, -1)  # (names, indices) heard at the last look
        self._heard_at = self._started  # when a new parameter last came
        self._asked_at = -math.inf  # the latest ask (the list or a batch of missing ones)
        self._back = False  # the link came back: ask again at once
        self._list_asks = 0
        self._heard_at_list_ask = 0  # indices heard when the list was last asked for
        self._batch: set[int] = set()  # the missing indices last asked for

    def run(self) -> None:
        while (now := time.monotonic()) < self._deadline():
            table, _ = self._link.param_table()
            missing, count = self._link.missing_params()
            if count > 0 and (not missing or len(table) >= count):
                return  # whole
            if self._link.state != LinkState.UP:
                # Rebooting, or a radio drop-out: ask again once it is back (a rebooted
                # vehicle forgot the list it was sending: it may be asked for once more).
                self._list_asks = min(self._list_asks, LIST_ASKS - 1)
                self._back = True
                time.sleep(0.1)
                continue
            self._note_progress((len(table), count - len(missing)), now)
            self._ask(missing, count, now)
            time.sleep(0.05)

    def _deadline(self) -> float:
        # measured from the latest new parameter: a link that keeps delivering goes on
        return min(self._started + LIST_MAX_S, self._heard_at + self._timeout_s)

    def _note_progress(self, progress: tuple[int, int], now: float) -> None:
        if progress != self._progress:
            if self._progress[0] >= 0:
                self._heard_at = now
            self._progress = progress

    def _ask(self, missing: list[int], count: int, now: float) -> None:
        """Ask for the list at first, and again while none of it came; once some came,
        for the missing ones by index (when the list stalls, or the last batch came)."""
        heard = count - len(missing)
        batch_came = bool(self._batch) and self._batch.isdisjoint(missing)
        stalled = self._back or now - max(self._heard_at, self._asked_at) > LIST_STALL_S
        if self._list_asks == 0 or (
            stalled and heard <= self._heard_at_list_ask and self._list_asks < LIST_ASKS
        ):
            self._send(self._link.request_param_list())
            self._list_asks += 1
            self._asked_at, self._heard_at_list_ask = now, heard
            self._batch = set()
        elif count > 0 and (stalled or batch_came):
            self._batch = set(missing[:READ_BATCH])
            for index in missing[:READ_BATCH]:
                self._send(self._link.request_param_index(index))
            self._asked_at = now
        self._back = False

    def _send(self, sent: CommandResult) -> None:
        # the link going down meanwhile is handled by run(): it asks again once back
        if not sent.ok and self._link.state == LinkState.UP:
            raise ConnectionError(sent.detail)


def _setup_answer(
    writes: list[Write], reboot: CommandResult | None, detail: str, **figures: Any
) -> dict[str, Any]:
    """A one-step set-up's answer: ok only once its reboot was accepted (None: a write
    was refused and nothing was rebooted), its figures, what was written, the reboot."""
    return {
        "ok": reboot is not None and reboot.ok,
        **figures,
        "writes": [w.to_dict() for w in writes],
        "reboot": None if reboot is None else reboot.to_dict(),
        "detail": detail,
    }


def _describe(name: str, value: float, ptype: int) -> dict[str, Any]:
    meta = META.get(name)
    return {
        "name": name,
        "value": value,
        "type": ptype,
        "integer": ptype != 9,  # MAV_PARAM_TYPE_REAL32
        "description": meta.description if meta else "",
        "units": meta.units if meta else "",
        "low": meta.low if meta else None,
        "high": meta.high if meta else None,
        "values": {str(k): v for k, v in meta.values.items()} if meta else {},
        "reboot": meta.reboot if meta else False,
    }
