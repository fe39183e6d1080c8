"""SQLite storage (stdlib ``sqlite3``): references, flights, mission runs, events, settings.

One file under the data directory; the schema carries a version and is migrated
forward on open. Every write commits at once (WAL journal, ``synchronous=FULL``), so
nothing is lost on a restart, a crash or a power cut; rows a crash left open are
closed as ``interrupted`` on the next start (:mod:`backend.recovery`). Safe to call
from several threads (one connection, one lock).
"""

from __future__ import annotations

import json
import logging
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

SCHEMA_VERSION = 1
#: The outcome of a mission run, and the end reason of a flight, that were still open
#: when the station stopped without closing them (a crash, a kill, a power cut).
INTERRUPTED = "interrupted"

_SCHEMA_V1 = """
CREATE TABLE IF NOT EXISTS refs (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    name TEXT NOT NULL,
    pad_size_m REAL NOT NULL,
    created REAL NOT NULL,
    active INTEGER NOT NULL DEFAULT 0,
    dir TEXT NOT NULL,
    data TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS flights (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    started REAL NOT NULL,
    ended REAL,
    dir TEXT NOT NULL,
    frames INTEGER NOT NULL DEFAULT 0,
    reason TEXT NOT NULL DEFAULT '',
    end_reason TEXT
);
CREATE TABLE IF NOT EXISTS mission_runs (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    kind TEXT NOT NULL,
    started REAL NOT NULL,
    ended REAL,
    outcome TEXT,
    detail TEXT NOT NULL DEFAULT '{}'
);
CREATE TABLE IF NOT EXISTS events (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    t REAL NOT NULL,
    kind TEXT NOT NULL,
    text TEXT NOT NULL,
    data TEXT NOT NULL DEFAULT '{}'
);
CREATE INDEX IF NOT EXISTS events_t ON events (t);
CREATE TABLE IF NOT EXISTS settings (
    key TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
"""


class StorageClosed(RuntimeError):
    """A write after the station closed its database (it is the last part to stop)."""


class Storage:
    """The station's database at ``path`` (created with its folder when missing)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._closed = False
        self._db = sqlite3.connect(
            self.path, check_same_thread=False, isolation_level=None, timeout=5.0
        )
        self._db.row_factory = sqlite3.Row
        with self._lock:
            mode = self._db.execute("PRAGMA journal_mode=WAL").fetchone()[0]
            if str(mode).lower() != "wal":
                log.warning("%s: SQLite kept journal mode %s (no WAL here)", self.path, mode)
            # FULL: a commit returns only once the WAL is on disk, so a power cut loses
            # nothing the station reported done (a run's outcome, a flight's end).
            # NORMAL would stay consistent but could lose the last commits; our writes
            # are few (rows, state changes, events), so the fsync each costs is cheap.
            self._db.execute("PRAGMA synchronous=FULL")
            self._migrate()

    def _migrate(self) -> None:
        self._db.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
        row = self._db.execute("SELECT version FROM schema_version").fetchone()
        version = 0 if row is None else int(row[0])
        if version > SCHEMA_VERSION:
            raise RuntimeError(
                f"{self.path} has schema version {version}, newer than this program's "
                f"{SCHEMA_VERSION}: upgrade Visland or use another data directory"
            )
        if version < 1:
            self._db.executescript("BEGIN;" + _SCHEMA_V1 + "COMMIT;")
        if row is None:
            self._db.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
        else:
            self._db.execute("UPDATE schema_version SET version = ?", (SCHEMA_VERSION,))

    @property
    def schema_version(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT version FROM schema_version").fetchone()[0])

    def close(self) -> None:
        with self._lock:
            self._closed = True
            self._db.close()

    # --- references ----------------------------------------------------------------------
    def add_reference(self, name: str, pad_size_m: float, dir: str, data: dict) -> int:
        """Insert a reference (inactive) and return its id."""
        with self._lock:
            cur = self._db.execute(
                "INSERT INTO refs (name, pad_size_m, created, dir, data) VALUES (?, ?, ?, ?, ?)",
                (name, float(pad_size_m), time.time(), dir, json.dumps(data)),
            )
            return _rowid(cur)

    def set_reference_dir(self, ref_id: int, dir: str) -> None:
        with self._lock:
            self._db.execute("UPDATE refs SET dir = ? WHERE id = ?", (dir, ref_id))

    def activate_reference(self, ref_id: int) -> None:
        """Make ``ref_id`` the only active reference (one transaction)."""
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.execute("UPDATE refs SET active = 0 WHERE active = 1")
                cur = self._db.execute("UPDATE refs SET active = 1 WHERE id = ?", (ref_id,))
                if cur.rowcount != 1:
                    raise KeyError(ref_id)
                self._db.execute("COMMIT")
            except BaseException:
                self._db.execute("ROLLBACK")
                raise

    def get_reference(self, ref_id: int) -> dict | None:
        with self._lock:
            row = self._db.execute("SELECT * FROM refs WHERE id = ?", (ref_id,)).fetchone()
        return None if row is None else _ref_row(row)

    def active_reference(self) -> dict | None:
        with self._lock:
            row = self._db.execute("SELECT * FROM refs WHERE active = 1").fetchone()
        return None if row is None else _ref_row(row)

    def list_references(self) -> list[dict]:
        with self._lock:
            rows = self._db.execute("SELECT * FROM refs ORDER BY id DESC").fetchall()
        return [_ref_row(r) for r in rows]

    # --- flights -------------------------------------------------------------------------
    def start_flight(self, dir: str, reason: str, started: float | None = None) -> int:
        with self._lock:
            cur = self._db.execute(
                "INSERT INTO flights (started, dir, reason) VALUES (?, ?, ?)",
                (time.time() if started is None else started, dir, reason),
            )
            return _rowid(cur)

    def set_flight_dir(self, flight_id: int, dir: str) -> None:
        with self._lock:
            self._db.execute("UPDATE flights SET dir = ? WHERE id = ?", (dir, flight_id))

    def update_flight(self, flight_id: int, *, frames: int) -> None:
        with self._lock:
            self._db.execute("UPDATE flights SET frames = ? WHERE id = ?", (frames, flight_id))

    def end_flight(self, flight_id: int, *, frames: int, end_reason: str) -> None:
        with self._lock:
            self._db.execute(
                "UPDATE flights SET ended = ?, frames = ?, end_reason = ? WHERE id = ?",
                (time.time(), frames, end_reason, flight_id),
            )

    def open_flights(self) -> list[dict]:
        """Flights never ended (the station stopped while recording them)."""
        with self._lock:
            rows = self._db.execute("SELECT * FROM flights WHERE ended IS NULL").fetchall()
        return [dict(r) for r in rows]

    def close_interrupted_flight(self, flight_id: int, *, ended: float, frames: int) -> None:
        with self._lock:
            self._db.execute(
                "UPDATE flights SET ended = ?, frames = ?, end_reason = ? "
                "WHERE id = ? AND ended IS NULL",
                (ended, frames, INTERRUPTED, flight_id),
            )

    def delete_flight(self, flight_id: int) -> bool:
        with self._lock:
            cur = self._db.execute("DELETE FROM flights WHERE id = ?", (flight_id,))
            return cur.rowcount > 0

    def mission_runs_between(self, t0: float, t1: float) -> list[dict]:
        """Mission runs that overlap [t0, t1], oldest first, with their records."""
        with self._lock:
            rows = self._db.execute(
                "SELECT * FROM mission_runs WHERE started <= ? AND (ended IS NULL OR ended >= ?) "
                "ORDER BY id",
                (t1, t0),
            ).fetchall()
        out = []
        for r in rows:
            d = dict(r)
            d["detail"] = json.loads(d.get("detail") or "{}")
            out.append(d)
        return out

    def get_flight(self, flight_id: int) -> dict | None:
        with self._lock:
            row = self._db.execute("SELECT * FROM flights WHERE id = ?", (flight_id,)).fetchone()
        return None if row is None else dict(row)

    def list_flights(self) -> list[dict]:
        with self._lock:
            rows = self._db.execute("SELECT * FROM flights ORDER BY id DESC").fetchall()
        return [dict(r) for r in rows]

    # --- mission runs --------------------------------------------------------------------
    def start_mission_run(self, kind: str, detail: dict | None = None) -> int:
        with self._lock:
            cur = self._db.execute(
                "INSERT INTO mission_runs (kind, started, detail) VALUES (?, ?, ?)",
                (kind, time.time(), json.dumps(detail or {})),
            )
            return _rowid(cur)

    def end_mission_run(self, run_id: int, outcome: str, detail: dict | None = None) -> None:
        with self._lock:
            self._db.execute(
                "UPDATE mission_runs SET ended = ?, outcome = ?, detail = ? WHERE id = ?",
                (time.time(), outcome, json.dumps(detail or {}), run_id),
            )

    def checkpoint_mission_run(self, run_id: int, detail: dict) -> None:
        """Store a running mission's record so far (what a crash leaves is this)."""
        with self._lock:
            self._db.execute(
                "UPDATE mission_runs SET detail = ? WHERE id = ? AND ended IS NULL",
                (json.dumps(detail), run_id),
            )

    def open_mission_runs(self) -> list[dict]:
        """Mission runs never ended (the station stopped while they ran)."""
        with self._lock:
            rows = self._db.execute("SELECT * FROM mission_runs WHERE ended IS NULL").fetchall()
        return [{**dict(r), "detail": json.loads(r["detail"])} for r in rows]

    def close_interrupted_mission_run(self, run_id: int, *, ended: float, detail: dict) -> None:
        with self._lock:
            self._db.execute(
                "UPDATE mission_runs SET ended = ?, outcome = ?, detail = ? "
                "WHERE id = ? AND ended IS NULL",
                (ended, INTERRUPTED, json.dumps(detail), run_id),
            )

    def integrity(self) -> str:
        """SQLite's ``PRAGMA integrity_check`` answer ("ok" when the file is sound)."""
        with self._lock:
            rows = self._db.execute("PRAGMA integrity_check").fetchall()
        return "; ".join(str(r[0]) for r in rows)

    def list_mission_runs(self, limit: int | None = None) -> list[dict]:
        """Mission runs, newest first (at most ``limit``)."""
        with self._lock:
            rows = self._db.execute(
                "SELECT * FROM mission_runs ORDER BY id DESC LIMIT ?",
                (-1 if limit is None else int(limit),),
            ).fetchall()
        return [{**dict(r), "detail": json.loads(r["detail"])} for r in rows]

    def get_mission_run(self, run_id: int) -> dict | None:
        with self._lock:
            row = self._db.execute("SELECT * FROM mission_runs WHERE id = ?", (run_id,)).fetchone()
        return None if row is None else {**dict(row), "detail": json.loads(row["detail"])}

    # --- events --------------------------------------------------------------------------
    def add_event(self, kind: str, text: str, data: dict | None = None, t: float | None = None):
        """Store an event; :class:`StorageClosed` once the station closed the database."""
        with self._lock:
            if self._closed:
                raise StorageClosed(f"{self.path} is closed")
            self._db.execute(
                "INSERT INTO events (t, kind, text, data) VALUES (?, ?, ?, ?)",
                (time.time() if t is None else t, kind, text, json.dumps(data or {}, default=str)),
            )

    def recent_events(self, limit: int = 100) -> list[dict]:
        with self._lock:
            rows = self._db.execute(
                "SELECT * FROM events ORDER BY id DESC LIMIT ?", (int(limit),)
            ).fetchall()
        return [{**dict(r), "data": json.loads(r["data"])} for r in reversed(rows)]

    # --- settings ------------------------------------------------------------------------
    def get_settings(self) -> dict[str, Any]:
        with self._lock:
            rows = self._db.execute("SELECT key, value FROM settings").fetchall()
        return {r["key"]: json.loads(r["value"]) for r in rows}

    def put_settings(self, values: dict[str, Any]) -> None:
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                for key, value in values.items():
                    self._db.execute(
                        "INSERT INTO settings (key, value) VALUES (?, ?) "
                        "ON CONFLICT(key) DO UPDATE SET value = excluded.value",
                        (key, json.dumps(value)),
                    )
                self._db.execute("COMMIT")
            except BaseException:
                self._db.execute("ROLLBACK")
                raise


def _ref_row(row: sqlite3.Row) -> dict:
    out = dict(row)
    out["data"] = json.loads(out["data"])
    out["active"] = bool(out["active"])
    return out


def _rowid(cursor: sqlite3.Cursor) -> int:
    """The id of the row an INSERT just made."""
    if cursor.lastrowid is None:
        raise RuntimeError("the INSERT made no row")
    return int(cursor.lastrowid)
