"""Runs one mission at a time for the station, in real time, on its own thread.

The thread is woken by each new vision result (its slot on the frame bus) and steps
the mission with it at once, so guidance goes out as soon as the pad is seen. Each
step has its result, as in the lockstep scenarios (a step without one would count as
"pad not seen"); only when no result comes for ``period_s`` (a stalled camera) does it
step without one, for the timeouts and failsafes. An abort wakes it at once. It stores the run
(``mission_runs``: started at once, finished with the whole record), reports state
changes as station events and hands a live snapshot to ``notify`` (the status
service) at every step where something moved. The run's record so far is stored at
each state change, so a crash leaves it as far as it went (:mod:`backend.recovery`).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from backend.framebus import FrameBus
from backend.missions.config import HoverConfig, LandConfig
from backend.missions.extnav import land_mission
from backend.missions.hover import HoverMission
from backend.missions.mission import Mission, VisionSample
from backend.storage import Storage
from backend.vision_worker import Processed

log = logging.getLogger(__name__)

#: Step without a result after this long (longer than a frame of a 10 Hz camera).
PERIOD_S = 0.2
JOIN_TIMEOUT_S = 5.0
#: Live snapshots at most this often (the dashboard panel; the state changes go at once).
SNAPSHOT_PERIOD_S = 0.2


class MissionBusy(RuntimeError):
    """A mission is already running."""


class MissionManager:
    """Start, watch and abort missions.

    Parameters
    ----------
    link : VehicleLink
        The station's link.
    results : FrameBus
        The vision results; the manager takes them from its own slot while a
        mission runs.
    storage : Storage or None
        Where runs are stored.
    emit_event : callable
        ``emit_event(kind, text, data)``: the station's event log.
    notify : callable or None
        ``notify(snapshot)``: the live state (more listeners: :meth:`listen`).
    period_s : float
        Control period.
    """

    def __init__(
        self,
        link: Any,
        results: FrameBus[Processed],
        storage: Storage | None,
        emit_event: Callable[[str, str, dict[str, Any]], Any],
        notify: Callable[[dict[str, Any]], None] | None = None,
        *,
        period_s: float = PERIOD_S,
    ) -> None:
        if not period_s > 0:
            raise ValueError(f"period_s must be > 0, got {period_s!r}")
        self.link = link
        self._results = results.subscribe("missions", wanted=lambda: self.running)
        self.storage = storage
        self._emit = emit_event
        self._listeners: tuple[Callable[[dict[str, Any]], None], ...] = ()
        if notify is not None:
            self.listen(notify)
        self.period_s = float(period_s)
        self._lock = threading.Lock()
        self._mission: Mission | None = None
        self._run_id: int | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._last: Mission | None = None

    def listen(self, listener: Callable[[dict[str, Any]], None]) -> None:
        """Call ``listener(snapshot)`` with the live state whenever it moves."""
        self._listeners = (*self._listeners, listener)

    def _notify(self, snapshot: dict[str, Any]) -> None:
        for listener in self._listeners:
            try:
                listener(snapshot)
            except Exception:
                log.exception("a mission listener failed")

    # --- the operator ------------------------------------------------------------------------
    def start_land(self, config: LandConfig) -> dict:
        """Start a landing; raises :class:`MissionBusy` when one runs."""
        return self._start(lambda now, cb: land_mission(self.link, config, now=now, on_change=cb))

    def start_hover(self, config: HoverConfig) -> dict:
        """Start a hover; raises :class:`MissionBusy` when one runs."""
        return self._start(lambda now, cb: HoverMission(self.link, config, now=now, on_change=cb))

    def abort(self, reason: str = "operator abort", *, hand_over: bool = False) -> dict | None:
        """Abort the running mission (acted on at once); None when none runs.

        ``hand_over``: the mission ends without commanding the vehicle (the caller
        holds it: the station's ABORT); otherwise it switches to its abort mode.
        """
        with self._lock:
            mission = self._mission
        if mission is None or mission.done:
            return None
        mission.abort(reason, hand_over=hand_over)
        self._results.nudge()  # acted on now, not at the next result
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(JOIN_TIMEOUT_S)  # acted on, stored and reported
        return self._snapshot(mission)

    def current(self) -> dict | None:
        """The running (or last) mission's live state; None before the first."""
        with self._lock:
            mission = self._mission or self._last
        return None if mission is None else self._snapshot(mission)

    @property
    def running(self) -> bool:
        with self._lock:
            return self._mission is not None and not self._mission.done

    def history(self, limit: int = 50) -> list[dict]:
        """Stored runs, newest first, without their per-target logs."""
        if self.storage is None:
            return []
        out = []
        for row in self.storage.list_mission_runs(limit):
            detail = row.get("detail") or {}
            out.append(
                {
                    "id": row["id"],
                    "kind": row["kind"],
                    "started": row["started"],
                    "ended": row["ended"],
                    "outcome": row["outcome"],
                    "strategy": detail.get("strategy"),
                    "message": detail.get("message", ""),
                    "touchdown": detail.get("touchdown"),
                    "duration_s": detail.get("duration_s"),
                    "frames": detail.get("frames"),
                    "detections": detail.get("detections"),
                    "targets_sent": detail.get("targets_sent"),
                }
            )
        return out

    def run(self, run_id: int) -> dict | None:
        """One stored run with its whole record."""
        if self.storage is None:
            return None
        return self.storage.get_mission_run(run_id)

    def close(self) -> None:
        """Abort a running mission (the station is going) and stop the thread."""
        self.abort("the ground station is shutting down")
        self._stop.set()
        self._results.close()
        if self._thread is not None:
            self._thread.join(JOIN_TIMEOUT_S)
            self._thread = None

    # --- inside ------------------------------------------------------------------------------
    def _start(self, make: Callable[[float, Callable[[Mission], None]], Mission]) -> dict:
        old = self._thread
        if old is not None and self._mission is not None and self._mission.done:
            old.join(JOIN_TIMEOUT_S)  # the last one is storing its record (outside the lock)
        with self._lock:
            if self._mission is not None and not self._mission.done:
                raise MissionBusy(
                    f"a {self._mission.kind} mission is running ({self._mission.state}); "
                    "abort it first"
                )
            if self._thread is not None and self._thread.is_alive():
                raise MissionBusy("the last mission is still finishing")
            mission = make(time.monotonic(), self._on_change)
            self._mission = mission
            self._stop.clear()
            self._results.clear()  # only results from now on
            detail = {"strategy": mission.record.strategy, "config": mission.record.config}
            self._run_id = (
                self.storage.start_mission_run(mission.kind, detail) if self.storage else None
            )
            self._thread = threading.Thread(
                target=self._loop, args=(mission,), name=f"mission-{mission.kind}", daemon=True
            )
            self._thread.start()
        self._emit(
            "mission",
            f"{mission.kind} mission started" + self._strategy_text(mission),
            {"mission": mission.kind, "state": mission.state, "run_id": self._run_id},
        )
        return self._snapshot(mission)

    @staticmethod
    def _strategy_text(mission: Mission) -> str:
        strategy = mission.record.strategy
        return f" ({strategy})" if strategy else ""

    def _snapshot(self, mission: Mission) -> dict:
        snap = mission.snapshot()
        snap["run_id"] = self._run_id if mission is self._mission else None
        # The run's record is in storage (GET /api/missions shows its outcome).
        snap["stored"] = mission is self._last
        return snap

    def _on_change(self, mission: Mission) -> None:
        run_id = self._run_id
        if self.storage is not None and run_id is not None and mission is self._mission:
            # What a crash leaves of this run is its record at the last state change.
            try:
                self.storage.checkpoint_mission_run(run_id, mission.record.to_dict())
            except Exception:
                log.exception("could not store the mission run so far")
        last = mission.record.states[-1] if mission.record.states else {}
        text = f"{mission.kind}: {mission.state}"
        if last.get("reason"):
            text += f" ({last['reason']})"
        self._emit(
            "mission",
            text,
            {"mission": mission.kind, "state": mission.state, "run_id": self._run_id},
        )
        self._notify(self._snapshot(mission))

    def _loop(self, mission: Mission) -> None:
        last_notify = 0.0
        next_tick = time.monotonic()
        try:
            while not mission.done and not self._stop.is_set():
                # Woken by the next result, or at the next tick without one.
                processed = self._results.take(max(0.0, next_tick - time.monotonic()))
                if self._stop.is_set():
                    break
                now = time.monotonic()
                sample = None
                if processed is not None:
                    sample = VisionSample(
                        processed.result, processed.camera, processed.frame.t_capture
                    )
                mission.step(now, sample)
                next_tick = now + self.period_s
                if now - last_notify >= SNAPSHOT_PERIOD_S:
                    last_notify = now
                    self._notify(self._snapshot(mission))
            if not mission.done:
                mission.abort("the ground station is shutting down")
                mission.step(time.monotonic())
        except Exception as exc:  # a fault in one step must not leave the run unrecorded
            log.exception("mission step failed")
            mission.record.finish(time.monotonic(), "failed", f"internal error: {exc}")
            mission.state = "failed"
        finally:
            self._finish(mission)

    def _finish(self, mission: Mission) -> None:
        rec = mission.record
        if self.storage is not None and self._run_id is not None:
            try:
                self.storage.end_mission_run(self._run_id, rec.outcome or "failed", rec.to_dict())
            except Exception:
                log.exception("could not store the mission run")
        self._emit(
            "mission_done",
            f"{mission.kind} mission {rec.outcome}: {rec.message}",
            {
                "mission": mission.kind,
                "outcome": rec.outcome,
                "run_id": self._run_id,
                "touchdown": None if rec.touchdown is None else rec.touchdown.to_dict(),
            },
        )
        with self._lock:
            self._last = mission
        self._notify(self._snapshot(mission))
