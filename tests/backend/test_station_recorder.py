"""The flight recorder: folders, results.jsonl, frames, the .tlog window, the database."""

from __future__ import annotations

import json
import struct
import time

import numpy as np
import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.camera import Frame
from backend.encoder import EncodedFrame, FrameEncoder
from backend.framebus import FrameBus
from backend.recorder import Recorder, copy_tlog_window
from backend.storage import Storage
from backend.vision_worker import Processed
from pipeline import Camera, FrameResult, Reference
from pipeline.render import make_pad_image

REFERENCE = Reference.from_image(make_pad_image(300), 0.55)


def heartbeat_bytes(seq: int, sysid: int = 1) -> bytes:
    mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=1)
    mav.seq = seq % 256
    msg = mav.heartbeat_encode(2, 3, 81, seq, 3)
    return msg.pack(mav)


def write_tlog(path, stamps, sysid: int = 1) -> None:
    with path.open("wb") as fh:
        for i, t in enumerate(stamps):
            fh.write(struct.pack(">Q", int(t * 1e6)) + heartbeat_bytes(i, sysid))


def test_window_copies_only_records_inside_and_replays(tmp_path):
    src = tmp_path / "session.tlog"
    stamps = [1000.0 + i for i in range(10)]
    write_tlog(src, stamps)
    out = tmp_path / "flight.tlog"
    with out.open("wb") as fh:
        assert copy_tlog_window(src, fh, 1003.0, 1006.0) == 4
    conn = mavutil.mavlink_connection(str(out))
    got = []
    while (msg := conn.recv_match(type="HEARTBEAT", blocking=False)) is not None:
        got.append((msg.custom_mode, round(msg._timestamp)))
    conn.close()
    assert got == [(3, 1003), (4, 1004), (5, 1005), (6, 1006)]


def test_window_stops_at_a_truncated_tail(tmp_path):
    src = tmp_path / "session.tlog"
    write_tlog(src, [10.0, 11.0, 12.0])
    data = src.read_bytes()
    src.write_bytes(data[:-5])  # a file still being written ends mid-record
    out = tmp_path / "out.tlog"
    with out.open("wb") as fh:
        assert copy_tlog_window(src, fh, 0.0, 100.0) == 2


def test_window_stops_at_garbage(tmp_path):
    src = tmp_path / "session.tlog"
    write_tlog(src, [10.0, 11.0])
    src.write_bytes(src.read_bytes() + b"\x00" * 8 + b"garbage!")
    with (tmp_path / "o.tlog").open("wb") as fh:
        assert copy_tlog_window(src, fh, 0.0, 100.0) == 2


def processed(seq: int) -> Processed:
    image = np.full((48, 64, 3), seq % 255, np.uint8)
    result = FrameResult(
        detected=False,
        corners_px=np.zeros((0, 2)),
        hu=(0.0,) * 7,
        orientation_deg=0.0,
        eccentricity=0.0,
        pose=None,
        timings_ms={"total": 1.0},
        reason="no H",
    )
    t = time.monotonic() - 0.02
    return Processed(
        Frame(image, t, seq, "test"), result, REFERENCE, Camera.from_fov(64, 48, 60), 20.0, t + 0.02
    )


def encoded(seq: int) -> EncodedFrame:
    """A processed frame as the encoder makes it for the viewers and the recorder."""
    return FrameEncoder(
        FrameBus("in").subscribe("x"), FrameBus("out"), jpeg_quality=lambda: 80
    ).encode(processed(seq))


@pytest.fixture
def store(tmp_path):
    s = Storage(tmp_path / "db.sqlite")
    yield s
    s.close()


def test_a_flight_records_frames_results_and_its_tlog(tmp_path, store):
    tlogs = tmp_path / "tlogs"
    tlogs.mkdir()
    events = []
    bus: FrameBus[EncodedFrame] = FrameBus("encoded")
    rec = Recorder(
        tmp_path / "flights",
        store,
        bus,
        tlog_dir=tlogs,
        on_event=lambda k, t, d: events.append((k, t)),
    )
    try:
        assert not bus.wanted()  # not recording: the encoder may skip its work
        assert rec.record(encoded(0)) is False  # not recording: ignored
        before = time.time()
        flight = rec.start("armed")
        assert bus.wanted()
        assert rec.start("again") == flight  # one flight at a time
        for seq in (5, 6, 9):
            assert rec.record(encoded(seq))
        time.sleep(0.01)
        now = time.time()
        started = store.get_flight(flight["id"])["started"]
        write_tlog(tlogs / "s.tlog", [before - 100, started + 0.001, now])
        ended = rec.stop("disarmed")
    finally:
        rec.close()
    assert ended["id"] == flight["id"] and rec.current is None
    folder = tmp_path / "flights" / next(p.name for p in (tmp_path / "flights").iterdir())
    lines = [json.loads(x) for x in (folder / "results.jsonl").read_text().splitlines()]
    assert [x["seq"] for x in lines] == [5, 6, 9]
    assert all(x["result"]["reason"] == "no H" and x["frame"] for x in lines)
    # t_unix is on the tlog's clock: within the flight's window.
    assert all(before - 1 <= x["t_unix"] <= now + 1 for x in lines)
    assert sorted(p.name for p in (folder / "frames").iterdir()) == [
        "000005.jpg",
        "000006.jpg",
        "000009.jpg",
    ]
    assert len((folder / "flight.tlog").read_bytes()) > 0
    with (tmp_path / "check.tlog").open("wb") as fh:
        assert copy_tlog_window(folder / "flight.tlog", fh, 0, 1e12) == 2  # not the old one
    row = store.get_flight(flight["id"])
    assert row["frames"] == 3 and row["end_reason"] == "disarmed" and row["ended"] >= row["started"]
    assert [k for k, _ in events] == ["flight", "flight"]


def test_frames_can_be_left_out(tmp_path, store):
    bus: FrameBus[EncodedFrame] = FrameBus("encoded")
    rec = Recorder(tmp_path / "flights", store, bus, tlog_dir=None, record_frames=lambda: False)
    try:
        rec.start("operator")
        assert rec.record(encoded(1))
        info = rec.stop("operator")
    finally:
        rec.close()
    folder = tmp_path / "flights" / info["dir"].rsplit("/", 1)[-1]
    assert list((folder / "frames").iterdir()) == []
    line = json.loads((folder / "results.jsonl").read_text())
    assert line["frame"] is None and line["seq"] == 1
    assert (folder / "flight.tlog").read_bytes() == b""


def test_stop_without_flight_is_none(tmp_path, store):
    rec = Recorder(tmp_path / "f", store, FrameBus("encoded"), tlog_dir=None)
    try:
        assert rec.stop("operator") is None
    finally:
        rec.close()


def test_the_writer_thread_records_what_the_bus_brings(tmp_path, store):
    bus: FrameBus[EncodedFrame] = FrameBus("encoded")
    rec = Recorder(tmp_path / "flights", store, bus, tlog_dir=None)
    rec.start_writer()
    try:
        rec.start("operator")
        bus.publish(encoded(3))
        deadline = time.monotonic() + 5
        while rec.written < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        info = rec.stop("operator")
    finally:
        rec.close()
    assert rec.written == 1 and rec.dropped == 0
    line = json.loads(
        (tmp_path / "flights" / info["dir"].rsplit("/", 1)[-1] / "results.jsonl").read_text()
    )
    assert line["seq"] == 3 and line["frame"] == "frames/000003.jpg"
    assert line["result"] == json.loads(encoded(3).result_json)  # the viewers' JSON, as is
