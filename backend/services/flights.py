"""Recorded flights: start and stop on demand or with arming, list them, find their files.

A flight starts when the vehicle arms and ends when it disarms (the link's ``armed``
and ``disarmed`` events), or when the operator says so. The listing reads the
database: the routes call it from worker threads, never on the event loop.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

from backend.link import LinkEvent
from backend.recorder import Recorder
from backend.services import replay
from backend.storage import Storage


class NoSuchFlight(LookupError):
    """No flight with that id (or without the file asked for)."""


class FlightBusy(RuntimeError):
    """The flight is still being recorded."""


class FlightService:
    """The flights in ``storage``, recorded by ``recorder``."""

    def __init__(self, storage: Storage, recorder: Recorder) -> None:
        self._storage = storage
        self._recorder = recorder

    @property
    def current(self) -> dict[str, Any] | None:
        """``{"id", "dir"}`` of the flight being recorded, or ``None``."""
        return self._recorder.current

    def on_link_event(self, event: LinkEvent) -> None:
        """Arming starts a flight, disarming ends it (link event thread)."""
        if event.kind == "armed":
            self._recorder.start("armed")
        elif event.kind == "disarmed" and self._recorder.current is not None:
            self._recorder.stop("disarmed")

    def start(self, reason: str = "operator") -> dict[str, Any]:
        return self._recorder.start(reason)

    def stop(self, reason: str = "operator") -> dict[str, Any] | None:
        return self._recorder.stop(reason)

    def rows(self) -> list[dict[str, Any]]:
        """Every flight's row, newest first."""
        return self._storage.list_flights()

    def get(self, flight_id: int) -> dict[str, Any]:
        row = self._storage.get_flight(flight_id)
        if row is None:
            raise NoSuchFlight(f"No flight {flight_id}.")
        return row

    def folder(self, flight_id: int) -> Path:
        row = self.get(flight_id)
        if not row["dir"]:
            raise NoSuchFlight(f"No flight {flight_id}.")
        return Path(row["dir"])

    def tlog(self, flight_id: int) -> Path:
        """The flight's .tlog; one still being recorded gets it written up to now."""
        folder = self.folder(flight_id)
        self._recorder.write_tlog_now(flight_id)
        path = folder / "flight.tlog"
        if not path.is_file():
            raise NoSuchFlight(f"Flight {flight_id} has no .tlog.")
        return path

    def results(self, flight_id: int) -> Path:
        path = self.folder(flight_id) / "results.jsonl"
        if not path.is_file():
            raise NoSuchFlight(f"Flight {flight_id} has no results.")
        return path

    def frames(self, flight_id: int) -> list[int]:
        """The numbers of the flight's recorded frames, in order."""
        folder = self.folder(flight_id) / "frames"
        if not folder.is_dir():
            return []
        return [int(p.stem) for p in sorted(folder.glob("*.jpg"))]

    def frame(self, flight_id: int, seq: int) -> Path:
        path = self.folder(flight_id) / "frames" / f"{seq:06d}.jpg"
        if not path.is_file():
            raise NoSuchFlight(f"Flight {flight_id} has no frame {seq}.")
        return path

    def size_bytes(self, row: dict[str, Any]) -> int:
        """Bytes the flight's folder takes on disk (0 when it is gone)."""
        folder = Path(row["dir"]) if row.get("dir") else None
        if folder is None or not folder.is_dir():
            return 0
        return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())

    def delete(self, flight_id: int) -> dict[str, Any]:
        """Delete a flight's folder and row; :class:`FlightBusy` while it is recorded."""
        row = self.get(flight_id)
        current = self._recorder.current
        if current is not None and current["id"] == flight_id:
            raise FlightBusy(f"Flight {flight_id} is being recorded; stop it before deleting.")
        size = self.size_bytes(row)
        if row.get("dir"):
            shutil.rmtree(row["dir"], ignore_errors=True)
        self._storage.delete_flight(flight_id)
        return {"id": flight_id, "freed_bytes": size}

    def replay(self, flight_id: int) -> dict[str, Any]:
        """The flight as one timeline (:mod:`backend.services.replay`)."""
        row = self.get(flight_id)
        folder = self.folder(flight_id)
        self._recorder.write_tlog_now(flight_id)
        frames = replay.read_results(folder / "results.jsonl", flight_id)
        telemetry, texts = replay.read_tlog(folder / "flight.tlog")
        t0 = row["started"]
        t1 = row["ended"] or time.time()
        times = [f["t"] for f in frames] + [s["t"] for s in telemetry]
        if times:
            t0, t1 = min(t0, min(times)), max(t1, max(times))
        runs = self._storage.mission_runs_between(t0, t1)
        return {
            "id": flight_id,
            "t0": t0,
            "t1": t1,
            "frames": frames,
            "telemetry": telemetry,
            "texts": texts,
            "missions": replay.mission_states(runs),
        }
