"""The mission state machine's frame: one ``step`` per control tick, no threads of its own.

A mission is driven by whoever owns the clock: the station's mission thread in real
time (:mod:`backend.missions.manager`), or the scenario runner in lockstep with the
simulated vehicle (:mod:`bench.scenarios`). Each ``step(now, sample)`` reads the
link's telemetry, takes the newest vision result, and sends what the state calls for.
The link is anything with :class:`~backend.link.VehicleLink`'s methods.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from backend.link import LinkState, Telemetry
from backend.link.attitudes import AttitudeHistory
from backend.missions.config import LandConfig
from backend.missions.geometry import PadFix, heading_error_deg, pad_fix, rot_ned_body, wrap90
from backend.missions.record import RunRecord, Touchdown
from pipeline import Camera, FrameResult

#: Below this RC throttle (us) LOITER would descend: no pilot, or the stick is down.
LOITER_MIN_THROTTLE_PWM = 1400
#: States after which a mission does nothing more.
TERMINAL = (
    "landed",
    "landed_blind",
    "landed_in_place",
    "completed",
    "aborted",
    "failed",
    "link_lost",
)
#: How long (mission clock) a HEARTBEAT may take to confirm an accepted command's effect
#: (ArduCopter sends one a second).
CONFIRM_S = 3.0
#: The run's note when a detection's pose was ambiguous, and so not used.
AMBIGUOUS_NOTE = (
    "a detection whose pose was ambiguous (made without the vehicle's attitude, which had "
    "not come near the frame's moment) was not used"
)


@dataclass(frozen=True, eq=False)
class VisionSample:
    """One processed frame handed to a mission.

    ``t_capture``: capture time on the mission's clock; ``time_usec``: the same moment
    on the vehicle's clock when the camera knows it (a simulated camera in lockstep),
    else None and the mission maps it through the latest ATTITUDE (``time_boot_ms``
    and its arrival time), which needs the mission clock to be ``time.monotonic``.
    """

    result: FrameResult
    camera: Camera
    t_capture: float
    time_usec: int | None = None


@dataclass(frozen=True)
class TouchdownTruth:
    """Where a simulated vehicle touched down: local NED (m) and heading (deg)."""

    north_m: float
    east_m: float
    yaw_deg: float


def vehicle_time_usec(tel: Telemetry, t_capture: float) -> int | None:
    """``t_capture`` (``time.monotonic``) on the vehicle's clock, from the last ATTITUDE."""
    if tel.attitude_time_boot_ms is None or tel.attitude_rx_monotonic is None:
        return None
    usec = tel.attitude_time_boot_ms * 1000 + (t_capture - tel.attitude_rx_monotonic) * 1e6
    return max(1, round(usec))


class Mission:
    """Common machinery: states, vision fixes, failsafe bookkeeping, the run record.

    Parameters
    ----------
    link : VehicleLink-like
        ``telemetry``, ``set_mode``, ``arm``, ``takeoff``, ``goto_local_ned``,
        ``set_velocity_ned``, ``send_landing_target``, ``get_param``.
    config : LandConfig
        Pad location and guidance settings.
    now : float
        The mission clock's time at start.
    touchdown_truth : callable or None
        Returns where a simulated vehicle really touched down (None: use telemetry).
    on_change : callable or None
        ``on_change(mission)`` after every state change (from the driving thread).
    """

    kind = "mission"

    def __init__(
        self,
        link: Any,
        config: LandConfig,
        *,
        now: float,
        touchdown_truth: Callable[[], TouchdownTruth | None] | None = None,
        on_change: Callable[[Mission], None] | None = None,
    ) -> None:
        if not isinstance(now, int | float) or not math.isfinite(now):
            raise ValueError(f"now must be a finite number of seconds, got {now!r}")
        if not isinstance(config, LandConfig):
            raise ValueError(f"config must be a LandConfig, got {type(config).__name__}")
        self.link = link
        self.config = config
        self.state = "start"
        self.state_since = now
        self.started = now
        self.now = now
        self.fix: PadFix | None = None
        self.last_seen: float | None = None
        self.last_target_t: float | None = None
        self.last_sample: VisionSample | None = None
        # The pad centre in local NED (the vehicle's own position frame), from the last fix.
        self.pad_est: tuple[float, float, float] | None = None
        # (the vehicle's attitudes by its clock: a fix is turned by its frame's)
        self._attitudes = AttitudeHistory()
        self._touchdown_truth = touchdown_truth
        self._on_change = on_change
        self._abort: str | None = None
        self._hand_over = False
        self._seen_armed = False
        self._abort_lock = threading.Lock()
        self.record = RunRecord(
            kind=self.kind,
            strategy=getattr(config, "strategy", None),
            config=self._config_dict(),
            started=now,
        )

    def _config_dict(self) -> dict[str, Any]:
        out = asdict(self.config)
        mount = self.config.mount
        out["mount"] = {"rotation": mount.rotation.tolist(), "offset_m": list(mount.offset_m)}
        return out

    # --- outside: the operator and the driver ------------------------------------------------
    @property
    def done(self) -> bool:
        return self.state in TERMINAL

    @property
    def outcome(self) -> str | None:
        return self.record.outcome

    def abort(self, reason: str = "operator abort", *, hand_over: bool = False) -> None:
        """Ask for an abort (any thread); acted on at the next ``step``.

        ``hand_over``: end without commanding anything (whoever asked holds the vehicle,
        as the station's ABORT does); otherwise switch to ``abort_mode``.
        """
        with self._abort_lock:
            if self._abort is None:
                self._abort = reason
                self._hand_over = hand_over

    def step(self, now: float, sample: VisionSample | None = None) -> None:
        """Advance the mission to ``now`` with the newest vision result (if any)."""
        if self.done:
            return
        if not isinstance(now, int | float) or not math.isfinite(now) or now < self.now:
            raise ValueError(f"now must be finite and not before {self.now}, got {now!r}")
        self.now = now
        tel = self.link.telemetry
        if tel.attitude is not None and tel.attitude_time_boot_ms is not None:
            a = tel.attitude
            self._attitudes.add(tel.attitude_time_boot_ms / 1000.0, (a.roll, a.pitch, a.yaw))
        self._observe(tel)
        if sample is not None:
            self._take(sample, tel)
        with self._abort_lock:
            reason = self._abort
        if reason is not None:
            if self._hand_over:
                self._end("aborted", reason)
            else:
                self._do_abort(reason)
            return
        if tel.state != LinkState.UP:
            # Nothing we send can arrive: the vehicle's own failsafe (FS_GCS_ENABLE) decides.
            self._end(
                "link_lost",
                f"link {tel.state}: left to the vehicle's own failsafe; Visland sends nothing",
            )
            return
        if self.state == "start" and not getattr(tel, "state_confirmed", True):
            # An arm, disarm or mode change was accepted and no HEARTBEAT has come since:
            # the armed flag and mode in hand are the old ones. Decide on the next one.
            if now - self.state_since > CONFIRM_S:
                self._fail(
                    f"no HEARTBEAT from the vehicle for {CONFIRM_S:g} s after it accepted a "
                    "command: its armed state and mode are not known"
                )
            return
        self._seen_armed = self._seen_armed or tel.armed
        if now - self.started > self.config.timeout_s:
            self._do_abort(f"mission time limit ({self.config.timeout_s:g} s)")
            return
        getattr(self, f"_s_{self.state}")(now, tel)

    def snapshot(self) -> dict[str, Any]:
        """Live state for the dashboard (JSON-serialisable)."""
        fix = self.fix
        age = None if self.last_target_t is None else self.now - self.last_target_t
        seen = None if self.last_seen is None else self.now - self.last_seen
        sample = self.last_sample
        return {
            "kind": self.kind,
            "strategy": self.record.strategy,
            "state": self.state,
            "state_age_s": round(self.now - self.state_since, 3),
            "elapsed_s": round(self.now - self.started, 3),
            "outcome": self.record.outcome,
            "message": self.record.message,
            "frames": self.record.frames,
            "detections": self.record.detections,
            "targets_sent": self.record.targets_sent,
            "target_age_s": None if age is None else round(age, 3),
            "pad_seen_age_s": None if seen is None else round(seen, 3),
            "fix": None if fix is None else _jsonable(fix.to_dict()),
            "image_size": None if sample is None else [sample.camera.width, sample.camera.height],
            "touchdown": None if self.record.touchdown is None else self.record.touchdown.to_dict(),
            "precland": self.record.precland,
        }

    # --- inside -----------------------------------------------------------------------------
    def _observe(self, tel: Telemetry) -> None:
        """Every step, before anything else: what a mission notes from the telemetry."""

    def _set_state(self, name: str, reason: str = "") -> None:
        if name == self.state:
            return
        self.state = name
        self.state_since = self.now
        self.record.state(self.now, name, reason)
        if self._on_change is not None:
            self._on_change(self)

    def _end(self, outcome: str, message: str) -> None:
        self.record.finish(self.now, outcome, message)
        self._set_state(outcome, message)

    def _fail(self, message: str) -> None:
        self._end("failed", message)

    def _do_abort(self, reason: str) -> None:
        mode = self.config.abort_mode
        note = ""
        throttle = self._throttle_pwm()
        if mode == "LOITER" and throttle is not None and throttle < LOITER_MIN_THROTTLE_PWM:
            # LOITER climbs or sinks with the pilot's throttle stick; with none (or the
            # stick down) it would come straight down. GUIDED holds where it is.
            mode = "GUIDED"
            note = f" (not LOITER: the RC throttle reads {throttle} us, it would descend)"
        result = self.link.set_mode(mode)
        if result.ok and mode == "GUIDED":
            # Already in GUIDED the last velocity target would stand: stop where we are.
            self._send_velocity(0.0, 0.0, 0.0, 0.0)
        if result.ok:
            self._end("aborted", f"{reason}: vehicle in {mode}{note}")
        else:
            self._end("aborted", f"{reason}: switching to {mode} failed ({result.detail})")

    def _throttle_pwm(self) -> int | None:
        """RC channel 3 as the vehicle last reported it (RC_CHANNELS), if it did."""
        latest = getattr(self.link, "latest", None)
        if latest is None:
            return None
        msg = latest("RC_CHANNELS")
        value = getattr(msg, "chan3_raw", None)
        return int(value) if isinstance(value, int) and value > 0 else None

    def _take(self, sample: VisionSample, tel: Telemetry) -> None:
        self.record.frames += 1
        self.last_sample = sample
        res = sample.result
        if not res.detected or res.pose is None or tel.attitude is None:
            return
        if res.pose.ambiguous:
            # Made without the attitude (none came near the frame's moment), a pose the
            # pixels do not pin may be tilted the wrong way, or a look-alike taken for a
            # tilted pad: on the design bench's empty views, 61 of the 62 so taken were
            # flagged so. No fix; the vehicle holds on the last one, or loses the pad.
            if AMBIGUOUS_NOTE not in self.record.notes:
                self.record.notes.append(AMBIGUOUS_NOTE)
            return
        usec = sample.time_usec
        if usec is None:
            usec = vehicle_time_usec(tel, sample.t_capture)
        if usec is None:
            return
        a = tel.attitude
        mount = self.config.mount
        try:
            fix = pad_fix(
                res.pose,
                sample.camera,
                self._attitudes.at(usec / 1e6) or (a.roll, a.pitch, a.yaw),
                t_capture=sample.t_capture,
                time_usec=usec,
                mount_rotation=mount.rotation,
                mount_offset_m=mount.offset_m,
            )
        except ValueError:
            return
        self.record.detections += 1
        self.fix = fix
        if tel.position_ned is not None:
            # Where the vehicle was at capture: its position now less what it moved since.
            p, v = tel.position_ned, tel.velocity_ned
            lag = max(0.0, self.now - sample.t_capture)
            vn, ve, vd = (v.x, v.y, v.z) if v is not None else (0.0, 0.0, 0.0)
            self.pad_est = (
                p.x - vn * lag + fix.offset_ned[0],
                p.y - ve * lag + fix.offset_ned[1],
                p.z - vd * lag + fix.offset_ned[2],
            )
        self.last_seen = sample.t_capture
        self._new_fix = True

    _new_fix = False

    def _take_new_fix(self) -> PadFix | None:
        """The fix that arrived since the last call, if fresh enough to act on."""
        if not self._new_fix:
            return None
        self._new_fix = False
        return self._fresh_fix()

    def _fresh_fix(self) -> PadFix | None:
        fix = self.fix
        if fix is None or self.now - fix.t_capture > self.config.fix_max_age_s:
            return None
        return fix

    def _disarmed(self, tel: Telemetry) -> bool:
        """The vehicle went from armed to disarmed (telemetry's armed flag comes with the
        1 Hz HEARTBEAT, so a vehicle armed a moment ago may not show it yet)."""
        if tel.armed:
            return False
        return self._seen_armed or self.now - self.state_since > 3.0

    def _unseen_s(self) -> float:
        """How long the pad has not been seen (since the state began, if never)."""
        if self.last_seen is None:
            return self.now - self.state_since
        return self.now - self.last_seen

    def _height(self, tel: Telemetry) -> float | None:
        """Height of the vehicle above the pad (m): telemetry, else the last fix."""
        if tel.position_ned is not None:
            return self.config.pad_down_m - tel.position_ned.z
        return None if self.fix is None else self.fix.height_m

    def _steer(self, fix: PadFix, vd: float = 0.0) -> tuple[float, float, float, float]:
        """Velocity (N, E, D) and yaw rate (deg/s) that centre and turn over the pad."""
        c = self.config
        vn = c.gain_xy * fix.offset_ned[0]
        ve = c.gain_xy * fix.offset_ned[1]
        speed = math.hypot(vn, ve)
        if speed > c.max_speed_mps:
            vn, ve = vn * c.max_speed_mps / speed, ve * c.max_speed_mps / speed
        rate = -c.gain_yaw * fix.heading_error_deg
        rate = max(-c.max_yaw_rate_dps, min(c.max_yaw_rate_dps, rate))
        return vn, ve, vd, rate

    def _send_velocity(self, vn: float, ve: float, vd: float, yaw_rate_dps: float) -> None:
        result = self.link.set_velocity_ned(vn, ve, vd, yaw_rate_dps=yaw_rate_dps)
        if result.ok:
            self.record.target(self.now, "velocity", vn, ve, vd, yaw_rate_dps)
            self.last_target_t = self.now

    def _goto(self, north: float, east: float, down: float) -> None:
        result = self.link.goto_local_ned(north, east, down)
        if result.ok:
            self.record.target(self.now, "position", north, east, down)
            self.last_target_t = self.now

    def _predicted_target(self, tel: Telemetry) -> tuple[float, float, float] | None:
        """The pad relative to the camera (body FRD), predicted from :attr:`pad_est` and the
        vehicle's position now: for the blind last metres, when the pad fills the view."""
        if self.pad_est is None or tel.position_ned is None or tel.attitude is None:
            return None
        p, a = tel.position_ned, tel.attitude
        rel = np.array([self.pad_est[0] - p.x, self.pad_est[1] - p.y, self.pad_est[2] - p.z])
        body = rot_ned_body(a.roll, a.pitch, a.yaw).T @ rel
        body -= np.asarray(self.config.mount.offset_m, float)
        return float(body[0]), float(body[1]), float(body[2])

    def _centred(self, fix: PadFix, tolerance_m: float) -> bool:
        return (
            math.hypot(fix.offset_ned[0], fix.offset_ned[1]) <= tolerance_m
            and abs(fix.heading_error_deg) <= self.config.yaw_tolerance_deg
        )

    def _mode(self, name: str) -> bool:
        """Switch flight mode; on refusal the mission fails with the vehicle's words."""
        result = self.link.set_mode(name)
        if not result.ok:
            reasons = "; ".join(result.reasons) if result.reasons else result.detail
            self._fail(f"the vehicle refused {name}: {result.result_name} ({reasons})")
            return False
        return True

    def _touchdown(self, tel: Telemetry) -> Touchdown | None:
        truth = self._touchdown_truth() if self._touchdown_truth is not None else None
        c = self.config
        if truth is not None:
            n, e, yaw, source = truth.north_m, truth.east_m, truth.yaw_deg, "truth"
        elif tel.position_ned is not None and tel.attitude is not None:
            n, e = tel.position_ned.x, tel.position_ned.y
            yaw, source = math.degrees(tel.attitude.yaw), "telemetry"
        else:
            return None
        return Touchdown(
            north_m=n,
            east_m=e,
            yaw_deg=yaw,
            error_m=math.hypot(n - c.pad_north_m, e - c.pad_east_m),
            heading_error_deg=abs(heading_error_deg(yaw, c.pad_heading_deg)),
            source=source,
        )


def _jsonable(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    return value


__all__ = ["TERMINAL", "Mission", "TouchdownTruth", "VisionSample", "vehicle_time_usec", "wrap90"]
