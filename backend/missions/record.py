"""What a mission run leaves behind: state changes, targets sent, touchdown, outcome."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

#: Terminal outcomes of a run. ``landed_blind``: a precision landing ("plnd") whose
#: targets ArduCopter never took (it came down where it was, on its own estimate).
#: ``landed_in_place``: came down where it was after the pad was lost with no GPS (an
#: ExternalNav landing without its vision): not a landing on the pad.
OUTCOMES = (
    "landed",
    "landed_blind",
    "landed_in_place",
    "completed",
    "aborted",
    "failed",
    "link_lost",
)
#: What ArduCopter said about precision landing during a "plnd" run: "accepted" (its
#: "PrecLand: Target Found" / "PrecLand: Init Complete"), "failsafe" ("PrecLand: Failsafe
#: Measures" and never a target: no backend, PLND_TYPE set without a reboot), "silent"
#: (nothing: the targets were not used).
PRECLAND_VERDICTS = ("accepted", "failsafe", "silent")
#: Targets kept in a stored record; beyond this only the count grows (a long hover at
#: 20 Hz must not make a row of megabytes).
MAX_TARGETS = 5000


def _num(value: float | None) -> float | None:
    if value is None:
        return None
    value = float(value)
    return round(value, 6) if math.isfinite(value) else None


@dataclass
class Touchdown:
    """Where the vehicle came down, relative to the pad.

    ``north_m``/``east_m``: touchdown point (local NED); ``yaw_deg``: heading then;
    ``error_m``: horizontal distance to the pad centre; ``heading_error_deg``: heading
    error modulo the pad's 180-degree symmetry (absolute); ``source``: "truth" (the
    simulator's) or "telemetry".
    """

    north_m: float
    east_m: float
    yaw_deg: float
    error_m: float
    heading_error_deg: float
    source: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "north_m": _num(self.north_m),
            "east_m": _num(self.east_m),
            "yaw_deg": _num(self.yaw_deg),
            "error_m": _num(self.error_m),
            "heading_error_deg": _num(self.heading_error_deg),
            "source": self.source,
        }


@dataclass
class RunRecord:
    """One mission run, as stored (``detail`` of a ``mission_runs`` row)."""

    kind: str
    strategy: str | None
    config: dict[str, Any]
    started: float
    states: list[dict[str, Any]] = field(default_factory=list)
    targets: list[list[Any]] = field(default_factory=list)
    targets_sent: int = 0
    frames: int = 0
    detections: int = 0
    notes: list[str] = field(default_factory=list)
    touchdown: Touchdown | None = None
    #: "plnd" runs: :data:`PRECLAND_VERDICTS`, and ArduCopter's "PrecLand: ..." texts.
    precland: str | None = None
    precland_texts: list[str] = field(default_factory=list)
    outcome: str | None = None
    message: str = ""
    ended: float | None = None

    def state(self, t: float, name: str, reason: str = "") -> None:
        """Note a state change at mission time ``t``."""
        self.states.append({"t": round(t - self.started, 3), "state": name, "reason": reason})

    def target(self, t: float, kind: str, *values: float) -> None:
        """Note a target sent: ``kind`` "landing_target" (x, y, z, distance, time_usec)
        or "velocity" (vn, ve, vd, yaw rate) or "position" (n, e, d, yaw)."""
        self.targets_sent += 1
        if len(self.targets) < MAX_TARGETS:
            self.targets.append([round(t - self.started, 3), kind, *(_num(v) for v in values)])

    def finish(self, t: float, outcome: str, message: str) -> None:
        if outcome not in OUTCOMES:
            raise ValueError(f"outcome must be one of {OUTCOMES}, got {outcome!r}")
        self.outcome = outcome
        self.message = message
        self.ended = t

    @property
    def duration_s(self) -> float | None:
        return None if self.ended is None else self.ended - self.started

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "strategy": self.strategy,
            "config": self.config,
            "states": self.states,
            "targets": self.targets,
            "targets_sent": self.targets_sent,
            "frames": self.frames,
            "detections": self.detections,
            "notes": self.notes,
            "touchdown": None if self.touchdown is None else self.touchdown.to_dict(),
            "precland": self.precland,
            "precland_texts": self.precland_texts,
            "outcome": self.outcome,
            "message": self.message,
            "duration_s": _num(self.duration_s),
        }
