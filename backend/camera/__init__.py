"""Camera sources: one interface for the CMUcam4, any OpenCV source and the simulated camera.

Every source runs its own capture thread, keeps only the newest frame (never a queue),
reports ``"stalled"`` when no frame came for a while and re-opens itself with backoff.
Consumers pull: ``latest()`` or ``wait_frame(after_seq, timeout)``.

>>> src = open_source("opencv:0")        # doctest: +SKIP
>>> src.start(); frame = src.wait_frame(-1, timeout=5.0); src.close()  # doctest: +SKIP

Specs accepted by :func:`open_source`: ``"cmucam4:/dev/ttyUSB0"``, ``"opencv:0"``
(device index), ``"opencv:path/to/file.mp4"``, ``"opencv:rtsp://..."``. The simulated
camera is part of the test rig (``sim.camera``): the station opens it itself when the
user asks for ``camera="sim"``. Live 30 Hz guidance from a CMUcam4 needs its analog video out
through a USB capture device (``opencv:N``): serial ``SF`` frames take seconds each.
"""

from __future__ import annotations

import math
import threading
import time
from abc import ABC, abstractmethod
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

__all__ = [
    "CaptureError",
    "EndOfStream",
    "Frame",
    "FrameSource",
    "SourceStatus",
    "ThreadedSource",
    "open_source",
]

State = Literal["starting", "streaming", "stalled", "error", "closed"]


@dataclass(frozen=True, eq=False)
class Frame:
    """One picture from a source.

    ``image`` is BGR ``uint8`` H x W x 3; ``t_capture`` is the ``time.monotonic()`` of
    capture (best estimate); ``seq`` counts frames of this source from 0; ``info`` holds
    source-specific facts (resolution, timings, CMUcam4 packets, ...).
    """

    image: np.ndarray
    t_capture: float
    seq: int
    source: str
    info: dict = field(default_factory=dict)


@dataclass(frozen=True)
class SourceStatus:
    """A snapshot of a source's health."""

    state: State
    fps: float
    frames: int
    errors: int
    last_error: str
    stalled_since: float | None


class CaptureError(RuntimeError):
    """A capture attempt failed; the source records it and tries again."""


class EndOfStream(CaptureError):
    """The source has no more frames and will not get any (a file played without loop)."""


class FrameSource(ABC):
    """A running source pushes frames; consumers pull the latest."""

    name: str

    @abstractmethod
    def start(self) -> None:
        """Start the capture thread (idempotent)."""

    @abstractmethod
    def close(self) -> None:
        """Stop capturing; joins threads with timeouts; idempotent."""

    @abstractmethod
    def latest(self) -> Frame | None:
        """The newest frame, or ``None`` before the first."""

    @abstractmethod
    def wait_frame(self, after_seq: int, timeout: float) -> Frame | None:
        """Wait up to ``timeout`` s for a frame with ``seq > after_seq``; newest or ``None``."""

    @property
    @abstractmethod
    def status(self) -> SourceStatus:
        """Current health."""

    def __enter__(self) -> FrameSource:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ThreadedSource(FrameSource):
    """Shared machinery: a capture thread with re-open backoff and stall detection.

    Subclasses implement :meth:`_open`, :meth:`_grab` and :meth:`_release`, and set
    :attr:`expected_period` (seconds between frames). ``_grab`` returns
    ``(image, t_capture, info)``, returns ``None`` when there is nothing new yet (the
    loop just calls again), raises :class:`CaptureError` (or any exception) to make the
    loop release, back off and re-open, or raises :class:`EndOfStream` to stop for good.

    Stall: no frame for ``stall_after`` seconds (default max(3 x expected period, 1 s)).
    """

    expected_period: float = 1 / 30

    def __init__(
        self,
        name: str,
        *,
        stall_after: float | None = None,
        backoff: tuple[float, float] = (0.2, 5.0),
        join_timeout: float = 5.0,
    ) -> None:
        if not name:
            raise ValueError("name must be a non-empty string")
        if stall_after is not None and not stall_after > 0:
            raise ValueError(f"stall_after must be positive, got {stall_after}")
        lo, hi = backoff
        if not 0 < lo <= hi:
            raise ValueError(f"backoff must be (min, max) with 0 < min <= max, got {backoff}")
        self.name = name
        self._stall_after_opt = stall_after
        self._backoff = (float(lo), float(hi))
        self._join_timeout = float(join_timeout)
        self._cond = threading.Condition()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._latest: Frame | None = None
        self._seq = -1
        self._frames = 0
        self._errors = 0
        self._last_error = ""
        self._opened = False
        self._ended = False
        self._closed = False
        self._started_at: float | None = None
        self._last_frame_at: float | None = None
        self._times: deque[float] = deque(maxlen=30)
        self._paused = False

    # --- to implement ------------------------------------------------------------------
    @abstractmethod
    def _open(self) -> None: ...

    @abstractmethod
    def _grab(self) -> tuple[np.ndarray, float, dict] | None: ...

    @abstractmethod
    def _release(self) -> None: ...

    def _interrupt(self) -> None:
        """Called from ``close()`` to unblock a pending ``_grab`` (optional)."""

    # --- public ------------------------------------------------------------------------
    @property
    def stall_after(self) -> float:
        if self._stall_after_opt is not None:
            return self._stall_after_opt
        return max(3.0 * self.expected_period, 1.0)

    def start(self) -> None:
        with self._cond:
            if self._closed:
                raise RuntimeError(f"source {self.name} is closed")
            if self._thread is not None:
                return
            self._started_at = time.monotonic()
            self._thread = threading.Thread(
                target=self._run, name=f"camera-{self.name}", daemon=True
            )
            self._thread.start()

    def close(self) -> None:
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._stop.set()
            self._cond.notify_all()
            thread = self._thread
        self._interrupt()
        if thread is not None:
            thread.join(self._join_timeout)
        if thread is None or not thread.is_alive():
            # The thread released already on its way out; this covers never-started.
            self._safe_release()

    def latest(self) -> Frame | None:
        with self._cond:
            return self._latest

    def wait_frame(self, after_seq: int, timeout: float) -> Frame | None:
        if not math.isfinite(timeout) or timeout < 0:
            raise ValueError(f"timeout must be a finite number >= 0, got {timeout}")
        deadline = time.monotonic() + timeout
        with self._cond:
            while self._seq <= after_seq and not self._closed:
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self._cond.wait(left)
            return self._latest if self._seq > after_seq else None

    @property
    def status(self) -> SourceStatus:
        now = time.monotonic()
        with self._cond:
            fps = 0.0
            if len(self._times) >= 2 and self._times[-1] > self._times[0]:
                fps = (len(self._times) - 1) / (self._times[-1] - self._times[0])
            since = self._last_frame_at if self._last_frame_at is not None else self._started_at
            stalled_since = None
            if self._closed:
                state: State = "closed"
            elif self._thread is None:
                state = "starting"
            elif self._ended:
                state, stalled_since = "stalled", since
            elif self._paused:
                state = "streaming"
            elif since is not None and now - since > self.stall_after:
                state = "stalled" if self._frames or self._opened else "error"
                stalled_since = since + self.stall_after
            elif self._frames == 0:
                state = "error" if self._errors and not self._opened else "starting"
            else:
                state = "streaming"
            if state == "stalled":
                fps = 0.0  # the last frames' rate says nothing about a stalled source
            return SourceStatus(
                state, fps, self._frames, self._errors, self._last_error, stalled_since
            )

    # --- for subclasses ----------------------------------------------------------------
    def _record_error(self, message: str) -> None:
        with self._cond:
            self._errors += 1
            self._last_error = message

    def _set_paused(self, paused: bool) -> None:
        """Pause stall reporting (e.g. while the port serves a tracking stream)."""
        with self._cond:
            self._paused = paused
            if not paused:
                self._last_frame_at = time.monotonic()

    def _publish(self, image: np.ndarray, t_capture: float, info: dict) -> Frame:
        with self._cond:
            self._seq += 1
            frame = Frame(image, float(t_capture), self._seq, self.name, dict(info))
            self._latest = frame
            self._frames += 1
            now = time.monotonic()
            self._last_frame_at = now
            self._times.append(now)
            self._cond.notify_all()
            return frame

    def _sleep(self, seconds: float) -> bool:
        """Sleep unless closing; True when the source should stop."""
        return self._stop.wait(max(0.0, seconds))

    # --- the loop ----------------------------------------------------------------------
    def _safe_release(self) -> None:
        try:
            self._release()
        except Exception as exc:  # a release failure must not mask the close
            self._record_error(f"release failed: {exc}")

    def _run(self) -> None:
        delay = self._backoff[0]
        while not self._stop.is_set():
            try:
                self._open()
            except Exception as exc:
                self._record_error(_describe(exc))
                self._safe_release()
                if self._sleep(delay):
                    break
                delay = min(delay * 2, self._backoff[1])
                continue
            with self._cond:
                self._opened = True
            try:
                while not self._stop.is_set():
                    got = self._grab()
                    if got is None:
                        continue
                    image, t_capture, info = got
                    self._publish(image, t_capture, info)
                    delay = self._backoff[0]
            except EndOfStream as exc:
                self._record_error(_describe(exc))
                with self._cond:
                    self._ended = True
                self._safe_release()
                self._stop.wait()
                break
            except Exception as exc:
                if self._stop.is_set():
                    break
                self._record_error(_describe(exc))
            with self._cond:
                self._opened = False
            self._safe_release()
            if self._sleep(delay):
                break
            delay = min(delay * 2, self._backoff[1])
        self._safe_release()


def _describe(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return text or type(exc).__name__


def open_source(spec: str, **kw: Any) -> FrameSource:
    """Make a (not yet started) source from a spec string.

    ``"cmucam4:/dev/ttyUSB0"``, ``"opencv:0"``, ``"opencv:video.mp4"``,
    ``"opencv:rtsp://host/stream"``. Extra keywords go to the source's constructor.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError(
            "spec must be a camera spec such as 'sim', 'cmucam4:/dev/ttyUSB0' or 'opencv:0'"
        )
    kind, _, target = spec.strip().partition(":")
    kind = kind.lower()
    if kind == "sim":
        raise ValueError(
            "spec 'sim' is the simulated camera of the test rig: make it with "
            "sim.camera.SimCamera (the station does when camera='sim')"
        )
    if kind == "cmucam4":
        from backend.camera.cmucam4 import CMUcam4Source

        if not target:
            raise ValueError(f"spec {spec!r} needs a serial port, e.g. 'cmucam4:/dev/ttyUSB0'")
        return CMUcam4Source(target, **kw)
    if kind == "opencv":
        from backend.camera.opencv_source import OpenCVSource

        if not target:
            raise ValueError(f"spec {spec!r} needs a device index, file or URL, e.g. 'opencv:0'")
        return OpenCVSource(int(target) if target.isdigit() else target, **kw)
    raise ValueError(
        f"unknown camera spec {spec!r}: use 'cmucam4:<port>' or 'opencv:<index|file|url>'"
    )
