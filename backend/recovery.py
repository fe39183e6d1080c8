"""After a crash: close what the last run of the station left open, with what it wrote.

A station killed mid-flight (SIGKILL, a power cut, an out-of-memory kill) leaves rows
that never ended: flights still "recording", mission runs still "running". On the next
start, before anything runs, each is closed as ``interrupted``:

- a flight keeps its folder: the results written up to the crash (a half-written last
  line is cut), its frames, and a ``flight.tlog`` cut from the link's session logs up to
  the last thing the flight wrote; it ends when its last file was written;
- a mission run keeps the record stored at its last state change (states, targets,
  counts), ends at that state, and says that what came after is unknown.

Each is reported as an event, so the operator sees it in the log.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from backend.recorder import write_flight_tlog
from backend.storage import INTERRUPTED, Storage

log = logging.getLogger(__name__)

INTERRUPTED_MESSAGE = (
    "The station stopped (crash, kill or power cut) while this ran; "
    "what happened after the last recorded state is unknown."
)

Emit = Callable[[str, str, dict[str, Any]], object]


def recover(storage: Storage, *, tlog_dir: Path | None, emit: Emit) -> dict[str, list[int]]:
    """Close every flight and mission run left open; returns their ids."""
    flights = [_close_flight(storage, row, tlog_dir, emit) for row in storage.open_flights()]
    runs = [_close_run(storage, row, emit) for row in storage.open_mission_runs()]
    return {"flights": flights, "mission_runs": runs}


def _close_flight(storage: Storage, row: dict[str, Any], tlog_dir: Path | None, emit: Emit) -> int:
    fid, started = int(row["id"]), float(row["started"])
    folder = Path(row["dir"]) if row["dir"] else None
    frames, ended = 0, started
    if folder is not None and folder.is_dir():
        # when the flight last wrote, read before the clean-up below touches its files
        ended = max([started, *(_mtime(p) for p in folder.rglob("*") if p.is_file())])
        for part in folder.glob("frames/*.part"):
            part.unlink(missing_ok=True)  # a frame the crash cut short
        frames = _complete_lines(folder / "results.jsonl")
        try:
            write_flight_tlog(folder, tlog_dir, started, ended)
        except OSError:
            log.exception("could not write the tlog of interrupted flight %d", fid)
    storage.close_interrupted_flight(fid, ended=ended, frames=frames)
    emit(
        "flight",
        f"flight {fid} was interrupted (the station stopped while recording): "
        f"closed with its {frames} recorded frames and its tlog",
        {"id": fid, "end_reason": INTERRUPTED},
    )
    return fid


def _close_run(storage: Storage, row: dict[str, Any], emit: Emit) -> int:
    run_id, started = int(row["id"]), float(row["started"])
    detail = dict(row["detail"] or {})
    states = detail.get("states") or []
    last_t = states[-1].get("t") if states and isinstance(states[-1], dict) else None
    ended = started + float(last_t) if isinstance(last_t, int | float) else started
    last_state = states[-1].get("state") if last_t is not None else None
    detail.update(
        outcome=INTERRUPTED,
        message=INTERRUPTED_MESSAGE
        + (f" The last recorded state was '{last_state}'." if last_state else ""),
        duration_s=round(ended - started, 3),
    )
    storage.close_interrupted_mission_run(run_id, ended=ended, detail=detail)
    emit(
        "mission_done",
        f"{row['kind']} mission run {run_id} was interrupted (the station stopped while it ran)",
        {"mission": row["kind"], "outcome": INTERRUPTED, "run_id": run_id},
    )
    return run_id


def _complete_lines(path: Path) -> int:
    """Lines in ``path`` that a crash did not cut; a cut last line is removed."""
    if not path.is_file():
        return 0
    data = path.read_bytes()
    whole = data[: data.rfind(b"\n") + 1]
    if len(whole) != len(data):
        with path.open("r+b") as fh:
            fh.truncate(len(whole))
    return whole.count(b"\n")


def _mtime(path: Path) -> float:
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0
