"""Storage: the schema, each table, and that nothing is lost across a reopen."""

from __future__ import annotations

import logging
import sqlite3
import threading

import pytest

from backend.services.events import EventLog
from backend.storage import SCHEMA_VERSION, Storage, StorageClosed


@pytest.fixture
def db(tmp_path):
    store = Storage(tmp_path / "v.db")
    yield store
    store.close()


def test_schema_is_versioned_and_created(db):
    assert db.schema_version == SCHEMA_VERSION
    names = {
        r[0]
        for r in sqlite3.connect(db.path).execute(
            "SELECT name FROM sqlite_master WHERE type='table'"
        )
    }
    assert {"refs", "flights", "mission_runs", "events", "settings", "schema_version"} <= names


def test_references_activate_exactly_one(db):
    a = db.add_reference("a", 0.55, "/x/a", {"hu": [1.0]})
    b = db.add_reference("b", 1.0, "/x/b", {"hu": [2.0]})
    assert db.active_reference() is None
    db.activate_reference(a)
    assert db.active_reference()["id"] == a
    db.activate_reference(b)
    assert db.active_reference()["id"] == b
    assert [r["active"] for r in db.list_references()] == [True, False]  # newest first
    assert db.get_reference(a)["data"] == {"hu": [1.0]}


def test_activating_unknown_reference_keeps_the_active_one(db):
    a = db.add_reference("a", 0.55, "/x/a", {})
    db.activate_reference(a)
    with pytest.raises(KeyError):
        db.activate_reference(999)
    assert db.active_reference()["id"] == a


def test_everything_survives_reopen(tmp_path):
    path = tmp_path / "v.db"
    store = Storage(path)
    ref = store.add_reference("pad", 0.55, "/refs/1", {"k": 1})
    store.activate_reference(ref)
    done = store.start_flight("/f/1", "armed")
    store.end_flight(done, frames=12, end_reason="disarmed")
    open_flight = store.start_flight("/f/2", "armed")
    run = store.start_mission_run("land", {"alt": 3})
    store.end_mission_run(run, "landed", {"error_m": 0.04})
    store.add_event("link_up", "link up", {"url": "tcp:x"})
    store.put_settings({"record_frames": False, "jpeg_quality": 70})
    store.close()

    again = Storage(path)
    try:
        assert again.active_reference()["id"] == ref
        flights = {f["id"]: f for f in again.list_flights()}
        assert flights[done]["frames"] == 12 and flights[done]["end_reason"] == "disarmed"
        # A flight left open stays open in the storage itself: closing it, with what it
        # wrote, is the recovery's work at the station's start (tests/backend/test_recovery.py).
        assert [f["id"] for f in again.open_flights()] == [open_flight]
        assert again.integrity() == "ok"
        runs = again.list_mission_runs()
        assert runs[0]["outcome"] == "landed" and runs[0]["detail"] == {"error_m": 0.04}
        events = again.recent_events()
        assert events[-1]["kind"] == "link_up" and events[-1]["data"] == {"url": "tcp:x"}
        assert again.get_settings() == {"record_frames": False, "jpeg_quality": 70}
    finally:
        again.close()


def test_newer_schema_is_refused_with_a_sentence(tmp_path):
    path = tmp_path / "v.db"
    Storage(path).close()
    con = sqlite3.connect(path)
    con.execute("UPDATE schema_version SET version = ?", (SCHEMA_VERSION + 1,))
    con.commit()
    con.close()
    with pytest.raises(RuntimeError, match="newer than this program"):
        Storage(path)


def test_concurrent_writers_lose_nothing(db):
    def write(n):
        for i in range(50):
            db.add_event("statustext", f"{n}-{i}")

    threads = [threading.Thread(target=write, args=(n,)) for n in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert len(db.recent_events(limit=1000)) == 200


def test_wal_and_full_sync_survive_a_power_cut(db):
    con = sqlite3.connect(db.path)
    try:
        assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    finally:
        con.close()
    # synchronous is per connection: the station's own is FULL (2)
    assert db._db.execute("PRAGMA synchronous").fetchone()[0] == 2


def test_an_event_after_the_database_closed_is_logged_not_raised(tmp_path, caplog):
    # A link's event thread may outlive its join timeout while the station stops, and
    # emit after the database (the last part to stop) has closed: kept in the log as
    # a warning with its text, not an error with a traceback, and still passed on.
    storage = Storage(tmp_path / "v.db")
    events = EventLog(storage)
    heard = []
    events.listen(heard.append)
    events.emit("link", "link up")
    storage.close()
    with pytest.raises(StorageClosed):
        storage.add_event("link", "after close")
    with caplog.at_level(logging.WARNING):
        events.emit("link", "link closed: closed by the ground station")
    assert [e["text"] for e in heard] == ["link up", "link closed: closed by the ground station"]
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR or r.exc_info]
    assert "not stored: link: link closed" in caplog.text
    assert [e["text"] for e in Storage(tmp_path / "v.db").recent_events()] == ["link up"]
