"""After a crash: open flights and mission runs are closed as interrupted, with what was
written (frames, results, the tlog cut from the session logs, the run's states)."""

from __future__ import annotations

import json
import os
import stat
import struct
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.datadir import prepare_data_dir
from backend.recovery import INTERRUPTED_MESSAGE, recover
from backend.storage import Storage


def tlog_record(t: float, mav) -> bytes:
    msg = mavlink2.MAVLink_heartbeat_message(2, 3, 0, 0, 3, 3)
    return struct.pack(">Q", int(t * 1e6)) + msg.pack(mav)


def test_an_open_flight_keeps_its_frames_and_gets_its_tlog(tmp_path):
    storage = Storage(tmp_path / "visland.db")
    started = time.time() - 60
    fid = storage.start_flight("", "armed", started)
    folder = tmp_path / "flights" / f"{fid:04d}"
    (folder / "frames").mkdir(parents=True)
    storage.set_flight_dir(fid, str(folder))
    for seq in (1, 2, 3):
        (folder / "frames" / f"{seq:06d}.jpg").write_bytes(b"\xff\xd8 jpeg \xff\xd9")
    (folder / "frames" / "000004.jpg.part").write_bytes(b"\xff\xd8 cut")
    lines = [json.dumps({"seq": n, "frame": f"frames/{n:06d}.jpg"}) for n in (1, 2, 3)]
    (folder / "results.jsonl").write_text("\n".join(lines) + "\n" + '{"seq": 4, "fra')
    tlogs = tmp_path / "tlogs"
    tlogs.mkdir()
    mav = mavlink2.MAVLink(None, 1, 1)
    (tlogs / "session.tlog").write_bytes(
        tlog_record(started - 30, mav)
        + tlog_record(started + 5, mav)
        + tlog_record(started + 9, mav)
    )
    events = []

    closed = recover(storage, tlog_dir=tlogs, emit=lambda *e: events.append(e))

    assert closed == {"flights": [fid], "mission_runs": []}
    row = storage.get_flight(fid)
    assert row["end_reason"] == "interrupted" and row["frames"] == 3
    assert row["dir"] == str(folder) and row["ended"] >= started
    assert not list(folder.glob("frames/*.part"))
    assert (folder / "results.jsonl").read_text().count("\n") == 3  # the cut line is gone
    tlog = (folder / "flight.tlog").read_bytes()
    assert len(tlog) == 2 * len(tlog_record(0, mav))  # the two records of the flight
    assert "interrupted" in events[0][1] and "3 recorded frames" in events[0][1]
    assert storage.open_flights() == []
    assert recover(storage, tlog_dir=tlogs, emit=lambda *e: None) == {
        "flights": [],
        "mission_runs": [],
    }
    storage.close()


def test_an_open_run_keeps_its_record_up_to_the_last_state(tmp_path):
    storage = Storage(tmp_path / "visland.db")
    run = storage.start_mission_run("land", {"strategy": "plnd", "config": {}})
    detail = {
        "kind": "land",
        "strategy": "plnd",
        "config": {"approach_alt_m": 4.0},
        "states": [
            {"t": 0.0, "state": "check", "reason": ""},
            {"t": 4.5, "state": "descend", "reason": "centred"},
        ],
        "targets": [[4.6, "landing_target", 0.1, 0.0, 3.0, 3.0, 1]],
        "targets_sent": 1,
        "frames": 90,
        "detections": 80,
        "notes": [],
        "touchdown": None,
        "outcome": None,
        "message": "",
        "duration_s": None,
    }
    storage.checkpoint_mission_run(run, detail)
    events = []
    recover(storage, tlog_dir=None, emit=lambda *e: events.append(e))
    row = storage.get_mission_run(run)
    assert row["outcome"] == "interrupted"
    assert row["ended"] == row["started"] + 4.5
    assert row["detail"]["states"] == detail["states"] and row["detail"]["frames"] == 90
    assert row["detail"]["message"].startswith(INTERRUPTED_MESSAGE)
    assert "'descend'" in row["detail"]["message"]
    assert events[0][2]["outcome"] == "interrupted"
    storage.close()


def test_the_data_dir_keeps_to_its_owner(tmp_path):
    data = tmp_path / "data"
    data.mkdir(mode=0o755)
    (data / "visland.db").write_bytes(b"")
    os.chmod(data / "visland.db", 0o644)
    (data / "flights").mkdir(mode=0o755)
    old = os.umask(0o022)
    try:
        prepare_data_dir(data)
        assert stat.S_IMODE(data.stat().st_mode) == 0o700
        assert stat.S_IMODE((data / "visland.db").stat().st_mode) == 0o600
        assert stat.S_IMODE((data / "flights").stat().st_mode) == 0o700
        # and what the station makes from now on is its own too
        (data / "new.bin").write_bytes(b"x")
        (data / "newdir").mkdir()
        assert stat.S_IMODE((data / "new.bin").stat().st_mode) == 0o600
        assert stat.S_IMODE((data / "newdir").stat().st_mode) == 0o700
    finally:
        os.umask(old)
