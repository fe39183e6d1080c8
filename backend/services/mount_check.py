"""Whether the camera sits on the mount the station was told: the pad's own pixels, frame
after frame, against the level that the vehicle's attitude gives through that mount.

The attitude hint holds every pose near its level, so a mount set wrong leaves no mark
on a single pose: it is off, unflagged. Its pixels lean the pad from that level by the
mount's error, though, every frame (`pipeline.Pose.lean_rotation`: the rotation, in the
camera's frame, which turns with the vehicle, that turns down as the attitude gives it
onto down as the pixels give it). Frame to frame that is mostly their noise (a degree
or two); the median rotation over many frames is the mount's error. On the design
bench's views of four designs (the attitude within 0.7 degrees), it came to 0.03-0.28
degrees with the mount right, 2.6-3.1 with it 3 degrees off and 5.2-6.1 with it 6
degrees off (poses then 8 % of the height off), in today's and the real-world mix.
Turned back by it, the mount set is the camera's, but for its turn about the vertical,
which this does not see: the suggestion keeps the yaw set.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np

from backend.frames import mount_angles, mount_rotation
from pipeline import FrameResult

WINDOW = 40  # the detections (made with the attitude) looked back over
MIN_SEEN = 30  # ... of which at least this many before anything is said
# The median lean the operator is told of: with the hint 3 degrees off, the design bench's
# poses came 0.6 % of the height off (2.7 % at p95); 6 degrees off, 8.5 % (10.8 %).
WARN_DEG = 3.0
CLEAR_DEG = 1.5  # ... and told again when it is back under this

Emit = Callable[[str, str, dict[str, Any] | None], object]


class MountCheck:
    """Watches the poses' leans; emits a "vision" event when their median crosses
    ``WARN_DEG`` (with the mount they put the camera on), and another when it falls
    back under ``CLEAR_DEG``."""

    def __init__(self, emit: Emit, mount_deg: tuple[float, float, float]) -> None:
        self._emit = emit
        self._mount_deg = mount_deg
        self._mount = _flag(mount_deg)
        self._leans: deque[np.ndarray] = deque(maxlen=WINDOW)
        self._warned = False
        self._lock = threading.Lock()

    def set_mount(self, mount_deg: tuple[float, float, float]) -> None:
        """Judge against a mount set anew: the leans seen so far were against the old
        one's level, and what was said of it is moot."""
        with self._lock:
            self._mount_deg = mount_deg
            self._mount = _flag(mount_deg)
            self._leans.clear()
            self._warned = False

    def observe(self, result: FrameResult) -> None:
        """Take one frame's result (any thread)."""
        pose = result.pose
        if not result.detected or pose is None or pose.lean_rotation is None:
            return
        with self._lock:
            self._leans.append(np.asarray(pose.lean_rotation, np.float64).reshape(3))
            if len(self._leans) < MIN_SEEN:
                return
            median = np.median(np.asarray(self._leans), axis=0)
            lean = float(np.degrees(np.linalg.norm(median)))
            seen = len(self._leans)
            data: dict[str, Any] = {"lean_deg": round(lean, 2), "detections": seen}
            if not self._warned and lean > WARN_DEG:
                self._warned = True
                suggested = self._suggested(median)
                data["suggested_mount_deg"] = [_tenths(a) for a in suggested]
                text = (
                    f"The pad's pixels lean it {lean:.1f} degrees from the level the "
                    f"vehicle's attitude gives (the median of the last {seen} detections): "
                    f"the camera is likely not on the mount set (--camera-mount "
                    f"{self._mount}), or the pad does not lie level. Poses are held near "
                    "that level, and may be off by several percent of the height: set the "
                    "camera's mount (the Landing panel's, between missions). By the pad's "
                    f"pixels, it is about --camera-mount {_flag(suggested)} (its yaw is not "
                    "seen: the one set is kept)."
                )
            elif self._warned and lean < CLEAR_DEG:
                self._warned = False
                text = (
                    f"The pad's pixels lie level with the vehicle's attitude again "
                    f"(a median lean of {lean:.1f} degrees over the last {seen} detections)."
                )
            else:
                return
        self._emit("vision", text, data)

    def _suggested(self, lean: np.ndarray) -> tuple[float, float, float]:
        """The mount (roll, pitch, yaw degrees) the median lean rotation ``lean`` puts
        the camera on: the mount set, turned by it the other way (the pixels' down is
        the true mount's: ``R_true.T @ down == turn(lean) @ R_set.T @ down``)."""
        undo, _ = cv2.Rodrigues(-lean)
        roll, pitch, _ = mount_angles(mount_rotation(*self._mount_deg) @ undo)
        return (roll, pitch, float(self._mount_deg[2]))


def _flag(angles: tuple[float, float, float]) -> str:
    """Angles as ``--camera-mount`` takes them, to a tenth of a degree."""
    return ",".join(f"{_tenths(a):g}" for a in angles)


def _tenths(angle: float) -> float:
    return round(float(angle), 1) + 0.0  # (no "-0")
