"""The flight recorder: one folder per flight with the .tlog, JPEG frames and results.

A flight starts when the vehicle arms and ends when it disarms (the station watches
the telemetry), or on demand. The folder::

    flights/0007_2026-11-22T11-40-00Z/
        flight.tlog       the MAVLink stream of the flight, both directions
        results.jsonl     one FrameResult per processed frame: seq, t_capture, t_unix
        frames/000123.jpg the processed frames (when recording frames is on)

``t_unix`` in results.jsonl is the capture time on the UNIX clock, the clock of the
.tlog timestamps, so frames, results and MAVLink messages line up on replay. The
recorder is one consumer of the encoded-frame bus: its writer thread takes the newest
frame from its slot (the JPEG and the result's JSON are the ones the viewers get);
frames that come faster than the disk takes them are counted as ``dropped``, never
waited for.
"""

from __future__ import annotations

import logging
import os
import shutil
import struct
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from backend.encoder import EncodedFrame, overlay_for, splice
from backend.framebus import FrameBus
from backend.storage import Storage

log = logging.getLogger(__name__)

_JOIN_S = 5.0


def utc_stamp(t: float) -> str:
    return time.strftime("%Y-%m-%dT%H-%M-%SZ", time.gmtime(t))


class _Flight:
    """The flight being recorded: its row, folder and open results file."""

    def __init__(self, flight_id: int, folder: Path, started: float) -> None:
        self.id = flight_id
        self.dir = folder
        self.started = started
        self.results: IO[str] = (folder / "results.jsonl").open("a", buffering=1)
        self.frames = 0

    def info(self) -> dict[str, Any]:
        return {"id": self.id, "dir": str(self.dir)}


class Recorder:
    """Records flights under ``root``; ``tlog_dir`` is where the link writes its tlogs.

    ``frames``: the encoded-frame bus it records from (its slot wants frames only while
    a flight is recorded). ``record_frames``: whether JPEGs are kept (results always).
    """

    def __init__(
        self,
        root: str | Path,
        storage: Storage,
        frames: FrameBus[EncodedFrame],
        *,
        tlog_dir: str | Path | None,
        record_frames: Callable[[], bool] = lambda: True,
        on_event: Callable[[str, str, dict[str, Any]], object] | None = None,
    ) -> None:
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self._storage = storage
        self._tlog_dir = None if tlog_dir is None else Path(tlog_dir)
        self._record_frames = record_frames
        self._on_event = on_event
        # Held while a frame is written: stop() waits for the one under way, never more.
        self._lock = threading.Lock()
        self._current: _Flight | None = None
        self._slot = frames.subscribe("recorder", wanted=lambda: self._current is not None)
        self._thread: threading.Thread | None = None
        self.written = 0

    @property
    def dropped(self) -> int:
        """Frames that arrived while the writer was busy (newer ones replaced them)."""
        return self._slot.replaced

    @property
    def current(self) -> dict[str, Any] | None:
        """``{"id", "dir"}`` of the flight being recorded, or ``None``."""
        cur = self._current
        return None if cur is None else cur.info()

    def start_writer(self) -> None:
        """Start the writer thread (the composition root does, with the other parts)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._writer, name="recorder", daemon=True)
            self._thread.start()

    def start(self, reason: str) -> dict[str, Any]:
        """Start recording a flight (returns the current one if already recording)."""
        with self._lock:
            if self._current is not None:
                return self._current.info()
            started = time.time()
            flight_id = self._storage.start_flight("", reason, started)
            folder = self.root / f"{flight_id:04d}_{utc_stamp(started)}"
            (folder / "frames").mkdir(parents=True, exist_ok=True)
            self._storage.set_flight_dir(flight_id, str(folder))
            self._slot.clear()  # frames from before the flight are not part of it
            self._current = _Flight(flight_id, folder, started)
        self._event("flight", f"flight {flight_id} started ({reason})", {"id": flight_id})
        return {"id": flight_id, "dir": str(folder)}

    def stop(self, reason: str) -> dict[str, Any] | None:
        """End the current flight; writes its tlog. ``None`` when not recording."""
        with self._lock:  # the frame being written (if any) is finished first
            cur, self._current = self._current, None
        if cur is None:
            return None
        cur.results.close()
        self._write_tlog(cur, time.time())
        self._storage.end_flight(cur.id, frames=cur.frames, end_reason=reason)
        self._event("flight", f"flight {cur.id} ended ({reason})", {"id": cur.id})
        return cur.info()

    def write_tlog_now(self, flight_id: int) -> Path | None:
        """(Re)write the .tlog of a flight still being recorded, up to now."""
        cur = self._current
        if cur is None or cur.id != flight_id:
            return None
        return self._write_tlog(cur, time.time())

    def close(self) -> None:
        self.stop("station stopped")
        self._slot.close()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(_JOIN_S)

    # --- internals -----------------------------------------------------------------------
    def _event(self, kind: str, text: str, data: dict[str, Any]) -> None:
        if self._on_event is not None:
            try:
                self._on_event(kind, text, data)
            except Exception:
                log.exception("recorder event callback failed")

    def _writer(self) -> None:
        while True:
            encoded = self._slot.take()
            if encoded is None:
                return  # closed
            try:
                self.record(encoded)
            except Exception:
                log.exception("recorder failed to write a frame")

    def record(self, encoded: EncodedFrame) -> bool:
        """Write one encoded frame to the current flight (the writer thread's work)."""
        with self._lock:
            cur = self._current
            if cur is None or cur.results.closed:
                return False
            frame = encoded.processed.frame
            t_unix = time.time() - (time.monotonic() - frame.t_capture)
            name = None
            if encoded.jpeg is not None and self._record_frames():
                name = f"frames/{frame.seq:06d}.jpg"
                # Whole or absent, never half a JPEG, whenever the process dies.
                part = cur.dir / (name + ".part")
                part.write_bytes(encoded.jpeg)
                os.replace(part, cur.dir / name)
            head = {
                "seq": frame.seq,
                "t_capture": frame.t_capture,
                "t_unix": t_unix,
                "latency_ms": encoded.processed.latency_ms,
                "frame": name,
                # What the dashboard drew over it, for the replay.
                "overlay": overlay_for(encoded.processed),
            }
            cur.results.write(splice(head, "result", encoded.result_json) + "\n")
            cur.frames += 1
            self.written += 1
            return True

    def _write_tlog(self, cur: _Flight, t_end: float) -> Path:
        return write_flight_tlog(cur.dir, self._tlog_dir, cur.started, t_end)


def write_flight_tlog(folder: Path, tlog_dir: Path | None, started: float, ended: float) -> Path:
    """Write ``folder/flight.tlog``: the link's session logs cut to [started, ended]."""
    out = folder / "flight.tlog"
    tmp = out.with_suffix(".tlog.part")
    with tmp.open("wb") as fh:
        if tlog_dir is not None and tlog_dir.is_dir():
            for path in sorted(tlog_dir.glob("*.tlog")):
                # Only session logs that were written during the flight can hold it.
                if path.stat().st_mtime < started - 1.0:
                    continue
                copy_tlog_window(path, fh, started, ended)
    shutil.move(tmp, out)
    return out


def copy_tlog_window(path: Path, out: IO[bytes], t_start: float, t_end: float) -> int:
    """Copy the records of tlog ``path`` stamped in [t_start, t_end] to ``out``.

    A tlog is a run of records: an 8-byte big-endian UNIX time in microseconds followed
    by one MAVLink packet (v1: 0xFE, v2: 0xFD, length from the header). Returns the
    number of records copied; stops at the first record that does not parse (a file
    still being written ends mid-record).
    """
    data = path.read_bytes()
    lo, hi = int(t_start * 1e6), int(t_end * 1e6)
    pos, copied = 0, 0
    while pos + 8 + 3 <= len(data):
        (stamp,) = struct.unpack_from(">Q", data, pos)
        magic = data[pos + 8]
        plen = data[pos + 9]
        if magic == 0xFE:
            size = plen + 8
        elif magic == 0xFD:
            size = plen + 12 + (13 if data[pos + 10] & 0x01 else 0)
        else:
            break
        end = pos + 8 + size
        if end > len(data):
            break
        if lo <= stamp <= hi:
            out.write(data[pos:end])
            copied += 1
        pos = end
    return copied
