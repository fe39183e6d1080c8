"""Whether the camera sits on the mount the station was told: the pad's own pixels, frame
after frame, against the level that the vehicle's attitude gives through that mount.

The attitude hint holds every pose near its level (`pipeline.Pose.lean_deg`), so a
mount set wrong leaves no mark on a single pose: it is off, unflagged. Its pixels lean
the pad from that level by about the mount's error, though, every frame. On the design
bench's views (the attitude within 0.7 degrees), the median lean was 0.9-1.1 degrees
with the mount right, 2.8 with it 3 degrees off and 5.4-5.6 with it 6 degrees off (poses
then 8 % of the height off).
"""

from __future__ import annotations

import statistics
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

from pipeline import FrameResult

WINDOW = 40  # the detections (made with the attitude) looked back over
MIN_SEEN = 30  # ... of which at least this many before anything is said
WARN_DEG = 3.5  # the median lean the operator is told of
CLEAR_DEG = 2.0  # ... and told again when it is back under this

Emit = Callable[[str, str, dict[str, Any] | None], object]


class MountCheck:
    """Watches the poses' leans; emits a "vision" event when their median crosses
    ``WARN_DEG``, and another when it falls back under ``CLEAR_DEG``."""

    def __init__(self, emit: Emit, mount_deg: tuple[float, float, float]) -> None:
        self._emit = emit
        self._mount = ",".join(f"{a:g}" for a in mount_deg)
        self._leans: deque[float] = deque(maxlen=WINDOW)
        self._warned = False
        self._lock = threading.Lock()

    def observe(self, result: FrameResult) -> None:
        """Take one frame's result (any thread)."""
        pose = result.pose
        if not result.detected or pose is None or pose.lean_deg is None:
            return
        with self._lock:
            self._leans.append(float(pose.lean_deg))
            if len(self._leans) < MIN_SEEN:
                return
            lean = statistics.median(self._leans)
            seen = len(self._leans)
            if not self._warned and lean > WARN_DEG:
                self._warned = True
                text = (
                    f"The pad's pixels lean it {lean:.1f} degrees from the level the "
                    f"vehicle's attitude gives (the median of the last {seen} detections): "
                    f"the camera is likely not on the mount set (--camera-mount "
                    f"{self._mount}), or the pad does not lie level. Poses are held near "
                    "that level, and may be off by several percent of the height: set the "
                    "camera's mount."
                )
            elif self._warned and lean < CLEAR_DEG:
                self._warned = False
                text = (
                    f"The pad's pixels lie level with the vehicle's attitude again "
                    f"(a median lean of {lean:.1f} degrees over the last {seen} detections)."
                )
            else:
                return
        self._emit("vision", text, {"lean_deg": round(lean, 2), "detections": seen})
