"""The vision worker: runs the pipeline on its own thread, always on the newest frame.

When the pipeline is slower than the camera the frames in between are skipped and
counted as dropped (sequence gaps). Each result is published once on the frame bus
(:mod:`backend.framebus`); the consumers (missions, encoder, 3D view) take it from
their own slots at their own pace, so nothing they do can hold up the next frame.
"""

from __future__ import annotations

import logging
import statistics
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.camera import Frame, FrameSource
from backend.framebus import FrameBus
from pipeline import Camera, FrameResult, Reference

TRACK_MAX_AGE_S = 0.5  # an older detection says little about where the pad is now

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class Processed:
    """One frame and what the pipeline found in it.

    ``latency_ms``: capture to result. ``camera``: the intrinsics used for this frame
    (scaled to its size). ``reference``: the reference it was matched against.
    """

    frame: Frame
    result: FrameResult
    reference: Reference
    camera: Camera
    latency_ms: float
    t_done: float


@dataclass(frozen=True)
class WorkerStats:
    fps: float
    latency_ms: float | None
    processed: int
    dropped: int
    detected_rate: float
    errors: int
    last_error: str

    def to_dict(self) -> dict:
        return {
            "fps": round(self.fps, 2),
            "latency_ms": None if self.latency_ms is None else round(self.latency_ms, 1),
            "processed": self.processed,
            "dropped": self.dropped,
            "detected_rate": round(self.detected_rate, 3),
            "errors": self.errors,
            "last_error": self.last_error,
        }


class VisionWorker:
    """Pulls the newest frame from ``source`` and runs ``process`` on it, in a thread.

    Parameters
    ----------
    source : the running camera source.
    bus : where each result is published.
    reference : returns the active reference (``None``: frames wait unprocessed).
    camera : intrinsics at some size; scaled to each frame's size.
    process : ``process(image_bgr, reference, camera, *, prior, **hints) -> FrameResult``
        (``pipeline.process_frame``); ``prior`` is the last detection, when recent.
    hints : ``hints(frame)``: the keyword hints for this frame (``yaw_hint``, the
        camera's yaw in the pad frame; ``gravity_hint``, down in the camera frame),
        from what the vehicle reports of the frame's moment; empty when it reports
        nothing then.
    """

    def __init__(
        self,
        source: FrameSource,
        bus: FrameBus[Processed],
        *,
        reference: Callable[[], Reference | None],
        camera: Camera,
        process: Callable[..., FrameResult],
        hints: Callable[[Frame], Mapping[str, Any]] | None = None,
        window: int = 30,
        join_timeout: float = 5.0,
    ) -> None:
        self._source = source
        self._reference = reference
        self._camera = camera
        self._cameras: dict[tuple[int, int], Camera] = {(camera.width, camera.height): camera}
        self._seen = camera  # at the size of the latest frame processed
        self._process = process
        self._hints = hints
        self._join_timeout = join_timeout
        self._bus = bus
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._latest: Processed | None = None
        self._processed = 0
        self._dropped = 0
        self._errors = 0
        self._last_error = ""
        self._done_times: deque[float] = deque(maxlen=window)
        self._latencies: deque[float] = deque(maxlen=window)
        self._detected: deque[bool] = deque(maxlen=window)

    def start(self) -> None:
        if self._thread is not None:
            return
        self._thread = threading.Thread(target=self._run, name="vision-worker", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(self._join_timeout)
            if thread.is_alive():
                log.warning("vision worker did not stop within %.1f s", self._join_timeout)

    @property
    def latest(self) -> Processed | None:
        with self._lock:
            return self._latest

    @property
    def stats(self) -> WorkerStats:
        with self._lock:
            fps = 0.0
            times = list(self._done_times)
            # A worker that stopped producing shows 0 fps, not its last rate.
            if len(times) >= 2 and time.monotonic() - times[-1] < 2.0 and times[-1] > times[0]:
                fps = (len(times) - 1) / (times[-1] - times[0])
            latency = statistics.median(self._latencies) if self._latencies else None
            rate = sum(self._detected) / len(self._detected) if self._detected else 0.0
            return WorkerStats(
                fps=fps,
                latency_ms=latency,
                processed=self._processed,
                dropped=self._dropped,
                detected_rate=rate,
                errors=self._errors,
                last_error=self._last_error,
            )

    def camera_seen(self) -> Camera:
        """The camera at the size of the frames it sends (the model's own size before
        the first): how far the pad can be found depends on the frames' pixels, and a
        camera described by its field of view alone is modelled 640 px wide."""
        return self._seen

    def _camera_for(self, image: np.ndarray) -> Camera:
        h, w = image.shape[:2]
        cam = self._cameras.get((w, h))
        if cam is None:
            cam = self._camera.scaled(w, h)
            self._cameras[(w, h)] = cam
        self._seen = cam
        return cam

    def _run(self) -> None:
        last_seq = -1
        while not self._stop.is_set():
            try:
                frame = self._source.wait_frame(last_seq, timeout=0.25)
            except Exception as exc:  # a broken source must not kill the worker
                self._note_error(f"source: {exc}")
                self._stop.wait(0.25)
                continue
            if frame is None:
                continue
            newest = self._source.latest()
            if newest is not None and newest.seq > frame.seq:
                frame = newest
            if last_seq >= 0 and frame.seq > last_seq + 1:
                with self._lock:
                    self._dropped += frame.seq - last_seq - 1
            elif frame.seq < last_seq:
                # The source restarted its numbering (re-opened): start counting afresh.
                pass
            last_seq = frame.seq
            reference = self._reference()
            if reference is None:
                continue
            self._handle(frame, reference)

    def _handle(self, frame: Frame, reference: Reference) -> None:
        try:
            camera = self._camera_for(frame.image)
            hints = self._hints(frame) if self._hints is not None else {}
            result = self._process(
                frame.image, reference, camera, prior=self._prior(frame, reference), **hints
            )
        except Exception as exc:
            self._note_error(f"pipeline: {type(exc).__name__}: {exc}")
            log.exception("pipeline failed on frame %d", frame.seq)
            return
        t_done = time.monotonic()
        processed = Processed(
            frame=frame,
            result=result,
            reference=reference,
            camera=camera,
            latency_ms=(t_done - frame.t_capture) * 1000.0,
            t_done=t_done,
        )
        with self._lock:
            self._latest = processed
            self._processed += 1
            self._done_times.append(t_done)
            self._latencies.append(processed.latency_ms)
            self._detected.append(bool(result.detected))
        self._bus.publish(processed)

    def _prior(self, frame: Frame, reference: Reference) -> FrameResult | None:
        """The last detection of this reference, when recent enough to look near it first."""
        last = self._latest
        if last is None or last.reference is not reference or not last.result.detected:
            return None
        if frame.t_capture - last.frame.t_capture > TRACK_MAX_AGE_S:
            return None
        return last.result

    def _note_error(self, message: str) -> None:
        with self._lock:
            self._errors += 1
            self._last_error = message
