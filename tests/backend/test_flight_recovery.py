"""A flight left open by a crash is closed at the next start with what it had written:
its results (up to the line the crash cut), its frames, and its .tlog cut from the
session log; it then replays like any other flight."""

from __future__ import annotations

import json
import os
import time

from backend.framebus import FrameBus
from backend.recorder import Recorder
from backend.recovery import recover
from backend.services.flights import FlightService
from backend.storage import INTERRUPTED, Storage
from tests.backend.test_station_recorder import write_tlog


def test_an_interrupted_flight_is_closed_with_its_frames_and_tlog(tmp_path):
    db = tmp_path / "visland.db"
    tlogs = tmp_path / "tlogs"
    tlogs.mkdir()
    t0 = time.time() - 60
    # The run that crashed: a flight started, 3 results written, the 4th cut mid-line.
    store = Storage(db)
    flight_id = store.start_flight("", "armed", t0)
    folder = tmp_path / "flights" / f"{flight_id:04d}_crashed"
    (folder / "frames").mkdir(parents=True)
    store.set_flight_dir(flight_id, str(folder))
    with (folder / "results.jsonl").open("w") as fh:
        for i in range(3):
            fh.write(
                json.dumps({"seq": i, "t_unix": t0 + 1 + i, "frame": None, "result": {}}) + "\n"
            )
        fh.write('{"seq": 3, "t_unix": ')
    for path in folder.rglob("*"):  # written at the time of the crash, 3 s in
        os.utime(path, (t0 + 3, t0 + 3))
    # the session log ran on past the crash (another run's records, say)
    write_tlog(tlogs / "session.tlog", [t0 - 5, t0 + 0.5, t0 + 1.5, t0 + 2.5, t0 + 30])
    store.close()  # no end_flight: the process died

    # The next start.
    store = Storage(db)
    recorder = Recorder(tmp_path / "flights", store, FrameBus("encoded"), tlog_dir=tlogs)
    flights = FlightService(store, recorder)
    events: list = []
    assert recover(store, tlog_dir=tlogs, emit=lambda *e: events.append(e))["flights"] == [
        flight_id
    ]
    assert len(events) == 1
    row = store.get_flight(flight_id)
    assert row["end_reason"] == INTERRUPTED
    assert row["frames"] == 3
    assert row["ended"] >= t0 + 3
    # the tlog holds the session's records from the flight's start to its last write
    tlog = flights.tlog(flight_id).read_bytes()
    assert len(tlog) > 0
    replay = flights.replay(flight_id)
    assert [f["seq"] for f in replay["frames"]] == [0, 1, 2]
    assert [round(s["t"] - t0, 1) for s in replay["telemetry"]] == [0.5, 1.5, 2.5]
    # a second start does not touch it again
    assert recover(store, tlog_dir=tlogs, emit=lambda *e: events.append(e))["flights"] == []
    recorder.close()
    store.close()
