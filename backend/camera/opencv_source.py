"""Frames from anything OpenCV opens: a capture device, a video file or a stream URL.

The CMUcam4's analog video out reaches a computer through a USB capture device: that is
the 30 Hz path for live guidance (``opencv:0``). Video files play at their own frame
rate (or ``fps=``), optionally looping: this is how recorded flights replay.
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np

from backend.camera import CaptureError, EndOfStream, ThreadedSource

_URL_PREFIXES = ("rtsp://", "rtsps://", "http://", "https://", "udp://", "tcp://", "rtmp://")


class OpenCVSource(ThreadedSource):
    """A ``cv2.VideoCapture`` in a capture thread.

    Parameters
    ----------
    target : int or str
        Device index, file path or stream URL.
    loop : bool
        Files only: start again at the end. Without it the source ends and reports
        ``"stalled"`` with ``last_error`` saying the file ended.
    fps : float, optional
        Files only: playback rate; default the file's own rate (30 if unknown);
        0 reads as fast as possible (benchmarks).
    open_timeout, read_timeout : float
        Seconds OpenCV may block opening or reading a stream (FFmpeg backend).
    """

    def __init__(
        self,
        target: int | str,
        *,
        loop: bool = False,
        fps: float | None = None,
        name: str | None = None,
        stall_after: float | None = None,
        open_timeout: float = 5.0,
        read_timeout: float = 5.0,
        backoff: tuple[float, float] = (0.5, 10.0),
    ) -> None:
        if isinstance(target, bool) or not isinstance(target, int | str):
            raise ValueError(f"target must be a device index, file path or URL, got {target!r}")
        if isinstance(target, int) and target < 0:
            raise ValueError(f"target: device index must be >= 0, got {target}")
        if isinstance(target, str) and not target.strip():
            raise ValueError("target must not be empty")
        if fps is not None and not fps >= 0:
            raise ValueError(f"fps must be >= 0, got {fps}")
        self.target = target
        self.kind = (
            "device"
            if isinstance(target, int)
            else "url"
            if target.lower().startswith(_URL_PREFIXES)
            else "file"
        )
        if loop and self.kind != "file":
            raise ValueError(f"loop applies to video files only, not to a {self.kind}")
        super().__init__(name or f"opencv:{target}", stall_after=stall_after, backoff=backoff)
        self.loop = bool(loop)
        self._fps_opt = fps
        self._open_timeout_ms = int(open_timeout * 1000)
        self._read_timeout_ms = int(read_timeout * 1000)
        self._cap: cv2.VideoCapture | None = None
        self._next_at = 0.0
        self._period = 0.0
        self.expected_period = 1 / 30
        self.loops = 0

    def _open(self) -> None:
        params = [
            cv2.CAP_PROP_OPEN_TIMEOUT_MSEC,
            self._open_timeout_ms,
            cv2.CAP_PROP_READ_TIMEOUT_MSEC,
            self._read_timeout_ms,
        ]
        if self.kind == "file" and not Path(str(self.target)).is_file():
            raise CaptureError(f"no video file at {self.target}")
        cap = cv2.VideoCapture(self.target, cv2.CAP_ANY, params)
        if not cap.isOpened():
            cap.release()
            raise CaptureError(f"OpenCV cannot open {self.kind} {self.target}")
        self._cap = cap
        native = cap.get(cv2.CAP_PROP_FPS)
        native = native if np.isfinite(native) and 0 < native < 1000 else 30.0
        rate = native if self._fps_opt is None else self._fps_opt
        if self.kind == "file":
            self._period = 1.0 / rate if rate > 0 else 0.0
        else:
            self._period = 0.0  # live sources pace themselves
        self.expected_period = 1.0 / native
        self._next_at = time.monotonic()

    def _grab(self) -> tuple[np.ndarray, float, dict] | None:
        cap = self._cap
        if cap is None:
            raise CaptureError("capture not open")
        if self._period > 0:
            # Play files at their rate: wait for this frame's slot.
            if self._sleep(self._next_at - time.monotonic()):
                return None
            self._next_at = max(self._next_at + self._period, time.monotonic() - self._period)
        ok, image = cap.read()
        t = time.monotonic()
        if not ok or image is None:
            if self.kind == "file":
                if self.loop:
                    self.loops += 1
                    if not cap.set(cv2.CAP_PROP_POS_FRAMES, 0):
                        raise CaptureError(f"cannot rewind {self.target}")
                    ok, image = cap.read()
                    t = time.monotonic()
                    if not ok:
                        raise CaptureError(f"{self.target} has no frames")
                else:
                    raise EndOfStream(f"end of video file {self.target} (loop off)")
            else:
                raise CaptureError(f"{self.kind} {self.target} gave no frame")
        image = _to_bgr(image)
        info = {
            "resolution": (image.shape[1], image.shape[0]),
            "kind": self.kind,
            "pos_frames": int(cap.get(cv2.CAP_PROP_POS_FRAMES)),
            "loops": self.loops,
        }
        return image, t, info

    def _release(self) -> None:
        cap, self._cap = self._cap, None
        if cap is not None:
            cap.release()


def _to_bgr(image: np.ndarray) -> np.ndarray:
    if image.dtype != np.uint8:
        image = cv2.convertScaleAbs(image, alpha=255.0 / max(1, int(image.max())))
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return image
