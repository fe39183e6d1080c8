"""The status and telemetry snapshots, built off the event loop and shared by everyone.

A thread builds the telemetry snapshot ten times a second and the status snapshot
once a second, or at once when something moved (a mission step, a link event:
:meth:`StatusService.refresh`). Each is built once, JSON-encoded once, and handed to
the listeners (the WebSocket hub) as text; ``GET /api/status`` and
``GET /api/telemetry`` return the latest snapshot without touching a lock another
thread holds or the database.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.camera import FrameSource
from backend.missions.manager import MissionManager
from backend.services.flights import FlightService
from backend.services.references import ReferenceService
from backend.services.rejections import Rejections
from backend.services.vehicle import VehicleService
from backend.vision_worker import VisionWorker

log = logging.getLogger(__name__)

TELEMETRY_PERIOD_S = 0.1
STATUS_PERIOD_S = 1.0
_JOIN_S = 5.0


@dataclass(frozen=True)
class Snapshot:
    """One snapshot as data and as its WebSocket message text (``type`` included)."""

    kind: str
    data: dict[str, Any]
    text: str


SnapshotListener = Callable[[Snapshot], None]


def to_json(message: dict[str, Any]) -> str:
    """JSON text of a message (numpy scalars and arrays become plain numbers and lists)."""
    return json.dumps(message, separators=(",", ":"), default=_json_default)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


class StatusService:
    """Builds the snapshots from the station's parts; see the module docstring."""

    def __init__(
        self,
        *,
        vehicle: VehicleService,
        source: FrameSource,
        worker: VisionWorker,
        missions: MissionManager,
        references: ReferenceService,
        flights: FlightService,
        viser_url: str | None,
        rejections: Rejections,
    ) -> None:
        self._vehicle = vehicle
        self._source = source
        self._worker = worker
        self._missions = missions
        self._references = references
        self._flights = flights
        self._viser_url = viser_url
        self._rejections = rejections
        self._listeners: tuple[SnapshotListener, ...] = ()
        self._cond = threading.Condition()
        self._dirty = False
        self._stop = False
        self._thread: threading.Thread | None = None
        self._build_lock = threading.Lock()
        self._status = self._snapshot("status", self.build_status())
        self._telemetry = self._snapshot("telemetry", self.build_telemetry())

    # --- readers ---------------------------------------------------------------------------
    @property
    def status(self) -> Snapshot:
        return self._status

    @property
    def telemetry(self) -> Snapshot:
        return self._telemetry

    def listen(self, listener: SnapshotListener) -> Callable[[], None]:
        """Call ``listener(snapshot)`` for each new snapshot; returns the remover."""
        self._listeners = (*self._listeners, listener)

        def remove() -> None:
            self._listeners = tuple(x for x in self._listeners if x is not listener)

        return remove

    # --- writers ---------------------------------------------------------------------------
    def refresh(self) -> None:
        """Build a new status snapshot soon (on the status thread); never waits."""
        with self._cond:
            self._dirty = True
            self._cond.notify_all()

    def refresh_now(self) -> Snapshot:
        """Build a new status snapshot on the calling thread (not the event loop's)."""
        with self._build_lock:
            snap = self._snapshot("status", self.build_status())
            self._status = snap
        self._tell(snap)
        return snap

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="status", daemon=True)
            self._thread.start()

    def close(self) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(_JOIN_S)

    # --- building --------------------------------------------------------------------------
    def build_status(self) -> dict[str, Any]:
        vehicle = self._vehicle
        tel = vehicle.telemetry
        st = self._source.status
        return {
            "link": {
                "state": str(tel.state),
                "url": vehicle.url,
                "heartbeat_age_s": tel.heartbeat_age_s,
                "msgs_per_s": tel.msgs_per_s,
                "crc_errors": tel.crc_errors,
                "implausible": tel.implausible,
            },
            "camera": {
                "name": self._source.name,
                "state": st.state,
                "fps": round(st.fps, 2),
                "frames": st.frames,
                "errors": st.errors,
                "last_error": st.last_error,
            },
            "pipeline": self._worker.stats.to_dict(),
            "mission": self._missions.current(),
            "reference": self._references.active_summary(),
            "flight": self._flights.current,
            "viser_url": self._viser_url,
            "rejected": self._rejections.to_dict(),
        }

    def build_telemetry(self) -> dict[str, Any]:
        return self._vehicle.telemetry.to_dict()

    @staticmethod
    def _snapshot(kind: str, data: dict[str, Any]) -> Snapshot:
        return Snapshot(kind, data, to_json({"type": kind, **data}))

    def _tell(self, snap: Snapshot) -> None:
        for listener in self._listeners:
            try:
                listener(snap)
            except Exception:
                log.exception("a %s listener failed", snap.kind)

    def _run(self) -> None:
        next_status = next_telemetry = time.monotonic()
        while True:
            with self._cond:
                wait = max(0.0, min(next_status, next_telemetry) - time.monotonic())
                self._cond.wait_for(lambda: self._stop or self._dirty, wait)
                if self._stop:
                    return
                dirty, self._dirty = self._dirty, False
            now = time.monotonic()
            try:
                if now >= next_telemetry:
                    next_telemetry = now + TELEMETRY_PERIOD_S
                    snap = self._snapshot("telemetry", self.build_telemetry())
                    self._telemetry = snap
                    self._tell(snap)
                if dirty or now >= next_status:
                    next_status = now + STATUS_PERIOD_S
                    self.refresh_now()
            except Exception:
                log.exception("building the status failed")
