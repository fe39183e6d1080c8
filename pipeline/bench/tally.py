"""Running figures of one detector: detection, false positives, pose error, time."""

from __future__ import annotations

import numpy as np

from pipeline.pose import TURN, rotation_angle_deg
from pipeline.render import View
from pipeline.result import Pose

# A pose this far off (% of the altitude) took something else for the pad, or the wrong
# one of the planar pose's two solutions: a wrong pose, not an imprecise one.
WRONG_POSE_PCT = 10.0


class Tally:
    """Detection and false-positive rates, pose errors against the truth, times."""

    def __init__(self) -> None:
        self.n = 0
        self.detected = 0
        self.fp_frames = 0
        self.fp = 0
        self.twins = 0
        self.untold = 0
        self.wrong = 0
        self.silent = 0
        self.pos_pct: list[float] = []
        self.rot_deg: list[float] = []
        self.ms: list[float] = []
        self.stages: dict[str, list[float]] = {}

    def time(self, seconds: float, stages: dict[str, float]) -> None:
        self.ms.append(seconds * 1e3)
        for k, v in stages.items():
            self.stages.setdefault(k, []).append(v)

    def score(self, detected: bool, pose: Pose | None, view: View, symmetric: bool) -> None:
        """One frame with the pad in view; a symmetric pad's turned twin counts as right,
        and so does that of a pose that says its heading was not told (``pose.symmetric``:
        the caller's heading decides, and the bench gives none).

        For a pad that is not symmetric, a pose nearer the turned twin than the truth is
        counted in ``twin_rate`` (and scored against the truth, i.e. as wrong); a pose
        of it that did not tell its heading, in ``heading_untold_rate``. A pose over
        ``WRONG_POSE_PCT`` off counts in ``wrong_pose_rate`` (of the frames), and in
        ``silent_wrong_pose_rate`` too where it was not flagged ``pose.ambiguous``.
        """
        self.n += 1
        if not detected or pose is None:
            return
        self.detected += 1
        pos, rot = pose_errors(pose, view.position_m, view.R_pad_cam)
        tpos, trot = pose_errors(pose, TURN @ view.position_m, TURN @ view.R_pad_cam)
        if not symmetric and pose.symmetric:
            self.untold += 1
        if symmetric or pose.symmetric:
            pos, rot = min(pos, tpos), min(rot, trot)
        elif trot < rot:
            self.twins += 1
        self.pos_pct.append(pos)
        self.rot_deg.append(rot)
        if pos > WRONG_POSE_PCT:
            self.wrong += 1
            self.silent += int(not pose.ambiguous)

    def false_positive(self, detected: bool) -> None:
        self.fp_frames += 1
        self.fp += int(detected)

    def summary(self) -> dict:
        return {
            "detection_rate": self.detected / max(self.n, 1),
            "false_positive_rate": self.fp / max(self.fp_frames, 1),
            "wrong_pose_rate": self.wrong / max(self.n, 1),
            "silent_wrong_pose_rate": self.silent / max(self.n, 1),
            "position_error_pct": stats(self.pos_pct),
            "rotation_error_deg": stats(self.rot_deg),
            "ms_per_frame": stats(self.ms),
            "stages_ms": {k: float(np.median(v)) for k, v in self.stages.items()},
        }


def pose_errors(pose: Pose, position_m: np.ndarray, R_pad_cam: np.ndarray) -> tuple[float, float]:
    """Position error in % of the true altitude, rotation error in degrees."""
    pos = 100 * float(np.linalg.norm(pose.position_m - position_m)) / float(position_m[2])
    return pos, rotation_angle_deg(pose.R_pad_cam, R_pad_cam)


def stats(values: list[float]) -> dict:
    if not values:
        return {"median": None, "p95": None}
    a = np.asarray(values)
    return {"median": float(np.median(a)), "p95": float(np.percentile(a, 95))}


def ratio(a: float | None, b: float | None) -> float | None:
    return None if not a or not b else float(a / b)
