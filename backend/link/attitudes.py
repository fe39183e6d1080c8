"""The vehicle's recent attitudes, to look up the one it had when a frame was taken.

A frame is processed a while after it was taken (a camera's latency, a busy ground
station) while the vehicle tilts on. What the vision is told of the camera's tilt,
and what a fix of the pad is turned by, must be the attitude of the frame's moment:
the latest one is off by the turn since (a tenth of a second at 50 deg/s puts a pad
4 m below 0.35 m off, and tilts the pad's level by 5 degrees).
"""

from __future__ import annotations

import bisect
import math
import threading

Angles = tuple[float, float, float]  # roll, pitch, yaw (rad), as MAVLink ATTITUDE


class AttitudeHistory:
    """Roll, pitch and yaw by time (seconds on any clock that runs forward) over the
    last ``seconds``. Safe to add to from one thread while others look up."""

    def __init__(self, seconds: float = 2.0) -> None:
        if not (math.isfinite(seconds) and seconds > 0):
            raise ValueError(f"seconds must be a positive number, got {seconds!r}")
        self._span = float(seconds)
        self._times: list[float] = []
        self._angles: list[Angles] = []
        self._lock = threading.Lock()

    def add(self, t: float, angles: Angles) -> None:
        """Note the attitude at ``t``. One not newer than the last is the same message
        seen again and is ignored, unless its time went back by more than the span: the
        clock started again (a vehicle's reboot), and so does the history."""
        if not math.isfinite(t) or len(angles) != 3 or not all(map(math.isfinite, angles)):
            return
        with self._lock:
            times, kept = self._times, self._angles
            if times and t <= times[-1]:
                if t >= times[-1] - self._span:
                    return
                times.clear()
                kept.clear()
            times.append(t)
            kept.append((float(angles[0]), float(angles[1]), float(angles[2])))
            drop = bisect.bisect_left(times, t - self._span)
            if drop:
                del times[:drop], kept[:drop]

    def at(self, t: float, max_gap: float | None = None) -> Angles | None:
        """The attitude at ``t``: interpolated between the two around it, else the
        nearest one; None before any, or (with ``max_gap``) when ``t`` lies farther
        than that outside what is known (the vehicle's attitude then is not known)."""
        if not math.isfinite(t):
            return None
        with self._lock:  # (the two around it, not copies of all: this runs every frame)
            times, kept = self._times, self._angles
            if not times:
                return None
            if max_gap is not None and not times[0] - max_gap <= t <= times[-1] + max_gap:
                return None
            i = bisect.bisect_left(times, t)
            if i == 0 or i == len(times):
                return kept[min(i, len(times) - 1)]
            t0, t1 = times[i - 1], times[i]
            a0, a1 = kept[i - 1], kept[i]
        w = (t - t0) / (t1 - t0)
        # Yaw wraps at +-pi: interpolated the short way round.
        dyaw = math.remainder(a1[2] - a0[2], 2 * math.pi)
        return (
            a0[0] + w * (a1[0] - a0[0]),
            a0[1] + w * (a1[1] - a0[1]),
            math.remainder(a0[2] + w * dyaw, 2 * math.pi),
        )
