"""The flight recorder: one folder per flight with the .tlog, JPEG frames and results.

A flight starts when the vehicle arms and ends when it disarms (the station watches
the telemetry), or on demand. The folder::

    flights/0007_2026-11-22T11-40-00Z/
        flight.tlog       the MAVLink stream of the flight, both directions
        results.jsonl     one FrameResult per processed frame: seq, t_capture, t_unix
        frames/000123.jpg the processed frames (when recording frames is on)

``t_unix`` in results.jsonl is the capture time on the UNIX clock, the clock of the
.tlog timestamps, so frames, results and MAVLink messages line up on replay. Frames
are written by a writer thread from a bounded queue; if the disk cannot keep up the
overflow is counted, never waited for.
"""

from __future__ import annotations

import contextlib
import json
import logging
import queue
import shutil
import struct
import threading
import time
from collections.abc import Callable
from pathlib import Path

import cv2

from backend.storage import Storage
from backend.vision_worker import Processed

log = logging.getLogger(__name__)

_STOP = object()


def utc_stamp(t: float) -> str:
    return time.strftime("%Y-%m-%dT%H-%M-%SZ", time.gmtime(t))


class Recorder:
    """Records flights under ``root``; ``tlog_dir`` is where the link writes its tlogs."""

    def __init__(
        self,
        root: str | Path,
        storage: Storage,
        *,
        tlog_dir: str | Path | None,
        record_frames: Callable[[], bool] = lambda: True,
        jpeg_quality: Callable[[], int] = lambda: 80,
        on_event: Callable[[str, str, dict], None] | None = None,
        queue_size: int = 64,
    ) -> None:
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self._storage = storage
        self._tlog_dir = None if tlog_dir is None else Path(tlog_dir)
        self._record_frames = record_frames
        self._jpeg_quality = jpeg_quality
        self._on_event = on_event
        self._lock = threading.Lock()
        self._queue: queue.Queue = queue.Queue(maxsize=queue_size)
        self._current: dict | None = None
        self._frames = 0
        self.overflow = 0
        self._thread = threading.Thread(target=self._writer, name="recorder", daemon=True)
        self._thread.start()

    @property
    def current(self) -> dict | None:
        """``{"id", "dir"}`` of the flight being recorded, or ``None``."""
        with self._lock:
            cur = self._current
            return None if cur is None else {"id": cur["id"], "dir": str(cur["dir"])}

    def flight_dir(self, flight_id: int) -> Path | None:
        row = self._storage.get_flight(flight_id)
        return None if row is None else Path(row["dir"])

    def start(self, reason: str) -> dict:
        """Start recording a flight (returns the current one if already recording)."""
        with self._lock:
            if self._current is not None:
                return {"id": self._current["id"], "dir": str(self._current["dir"])}
            started = time.time()
            flight_id = self._storage.start_flight("", reason, started)
            fdir = self.root / f"{flight_id:04d}_{utc_stamp(started)}"
            (fdir / "frames").mkdir(parents=True, exist_ok=True)
            self._storage.set_flight_dir(flight_id, str(fdir))
            results = (fdir / "results.jsonl").open("a", buffering=1)
            self._current = {"id": flight_id, "dir": fdir, "started": started, "results": results}
            self._frames = 0
        self._event("flight", f"flight {flight_id} started ({reason})", {"id": flight_id})
        return {"id": flight_id, "dir": str(fdir)}

    def stop(self, reason: str) -> dict | None:
        """End the current flight; writes its tlog. ``None`` when not recording."""
        with self._lock:
            cur, self._current = self._current, None
            frames = self._frames
        if cur is None:
            return None
        # Let the writer finish what was queued for this flight before closing its files.
        done = threading.Event()
        with contextlib.suppress(queue.Full):
            self._queue.put(("flush", done), timeout=5.0)
        if not done.wait(5.0):
            log.warning("recorder: flush of flight %d timed out", cur["id"])
        cur["results"].close()
        self._write_tlog(cur, time.time())
        self._storage.end_flight(cur["id"], frames=frames, end_reason=reason)
        self._event("flight", f"flight {cur['id']} ended ({reason})", {"id": cur["id"]})
        return {"id": cur["id"], "dir": str(cur["dir"])}

    def submit(self, processed: Processed) -> None:
        """Queue one processed frame for the current flight (never blocks)."""
        with self._lock:
            cur = self._current
            if cur is None:
                return
            self._frames += 1
        t_unix = time.time() - (time.monotonic() - processed.frame.t_capture)
        try:
            self._queue.put_nowait(("frame", cur, processed, t_unix, self._record_frames()))
        except queue.Full:
            with self._lock:
                self.overflow += 1

    def write_tlog_now(self, flight_id: int) -> Path | None:
        """(Re)write the .tlog of a flight still being recorded, up to now."""
        with self._lock:
            cur = self._current
        if cur is None or cur["id"] != flight_id:
            return None
        return self._write_tlog(cur, time.time())

    def close(self) -> None:
        self.stop("station stopped")
        self._queue.put(_STOP)
        self._thread.join(5.0)

    # --- internals -----------------------------------------------------------------------
    def _event(self, kind: str, text: str, data: dict) -> None:
        if self._on_event is not None:
            try:
                self._on_event(kind, text, data)
            except Exception:
                log.exception("recorder event callback failed")

    def _writer(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            try:
                if item[0] == "flush":
                    item[1].set()
                    continue
                _, cur, processed, t_unix, with_frame = item
                self._write_frame(cur, processed, t_unix, with_frame)
            except Exception:
                log.exception("recorder failed to write a frame")

    def _write_frame(self, cur: dict, p: Processed, t_unix: float, with_frame: bool) -> None:
        name = None
        if with_frame:
            ok, buf = cv2.imencode(
                ".jpg", p.frame.image, [cv2.IMWRITE_JPEG_QUALITY, int(self._jpeg_quality())]
            )
            if ok:
                name = f"frames/{p.frame.seq:06d}.jpg"
                (cur["dir"] / name).write_bytes(buf.tobytes())
        line = {
            "seq": p.frame.seq,
            "t_capture": p.frame.t_capture,
            "t_unix": t_unix,
            "latency_ms": p.latency_ms,
            "frame": name,
            "result": p.result.to_dict(),
        }
        fh = cur["results"]
        if not fh.closed:
            fh.write(json.dumps(line) + "\n")

    def _write_tlog(self, cur: dict, t_end: float) -> Path:
        out = cur["dir"] / "flight.tlog"
        tmp = out.with_suffix(".tlog.part")
        with tmp.open("wb") as fh:
            if self._tlog_dir is not None and self._tlog_dir.is_dir():
                for path in sorted(self._tlog_dir.glob("*.tlog")):
                    # Only session logs that were written during the flight can hold it.
                    if path.stat().st_mtime < cur["started"] - 1.0:
                        continue
                    copy_tlog_window(path, fh, cur["started"], t_end)
        shutil.move(tmp, out)
        return out


def copy_tlog_window(path: Path, out, t_start: float, t_end: float) -> int:
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
