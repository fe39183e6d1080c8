"""Precision landing from LANDING_TARGET, after ArduPilot's AC_PrecLand (MAVLink backend).

What is kept from ArduPilot 4.5: BODY_FRD only with position_valid = 1 and
distance > 0 (the line of sight is (x, y, z) / distance), angles otherwise; a
measurement is usable for 1 s; the target is lost 2 s after the last fused
measurement ("PrecLand: Target Lost"); the raw estimator (PLND_EST_TYPE 0) acquires
at once ("PrecLand: Target Found"), the Kalman filter (1) needs 2 s of measurements no
more than 0.5 s apart ("PrecLand: Target Found", then "PrecLand: Init Complete", or
"PrecLand: Init Failed"); the attitude used to rotate the measurement is the one
PLND_LAG seconds before it is processed. The estimate is kept in the NED frame of the
position estimate as the target's absolute position (a static target), which is what
ArduPilot's relative estimate plus inertial prediction amounts to.

The backend exists only if PLND_TYPE was 1 at boot; PLND_ENABLED acts at once. LAND
consults :class:`PrecLandStateMachine` whenever PLND_ENABLED is 1, backend or not
(AC_PrecLand_StateMachine, ArduPilot 4.5): a target never seen means FAILSAFE
("PrecLand: Failsafe Measures", hold 7 s with PLND_STRICT = 1, then descend); a
target state of "out of range" (no healthy rangefinder while PLND_ALT_MIN/MAX are
set, SITL's default) means descend; a target lost within range means descend for
PLND_TIMEOUT, then retry from above the last sighting ("PrecLand: Retrying"). On
genuine SITL without a rangefinder: no backend (PLND_TYPE set without a reboot)
gives the failsafe stop, a backend with no targets descends silently, and targets
that stop give "PrecLand: Target Lost" and a descent.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from sim.vehicle.physics import Quat, Vec3, body_to_ned

MEAS_STALE_S = 1.0
TARGET_TIMEOUT_S = 2.0
TARGET_LOST_TIMEOUT_S = 180.0  # a target lost longer than this counts as never seen
TARGET_LOST_DIST_M = 30.0
FAILSAFE_HOLD_S = 7.0  # FAILSAFE_INIT_TIMEOUT_MS
RETRY_CLIMB_M = 1.5  # RETRY_OFFSET_ALT_M
RETRY_REACHED_M = 0.75  # MAX_POS_ERROR_M
KF_INIT_TIME_S = 2.0
KF_INIT_MIN_UPDATE_S = 0.5
MAV_FRAME_BODY_FRD = 12


@dataclass(frozen=True)
class LandingTargetMsg:
    """The LANDING_TARGET fields precision landing reads."""

    time_usec: int
    frame: int
    angle_x: float
    angle_y: float
    distance: float
    x: float
    y: float
    z: float
    position_valid: int


class _AxisKF:
    """Two-state (position, velocity) Kalman filter of the target on one axis."""

    def __init__(self, pos: float, pos_var: float) -> None:
        self.x = [pos, 0.0]
        self.p = [[pos_var, 0.0], [0.0, 0.25]]

    def predict(self, dt: float, accel_noise: float) -> None:
        x, p = self.x, self.p
        x[0] += x[1] * dt
        q = (accel_noise * dt) ** 2
        p00 = p[0][0] + dt * (p[1][0] + p[0][1]) + dt * dt * p[1][1]
        p01 = p[0][1] + dt * p[1][1]
        p10 = p[1][0] + dt * p[1][1]
        p11 = p[1][1] + q
        # A static target: velocity decays, so noise cannot make it run away.
        x[1] *= max(0.0, 1.0 - 0.5 * dt)
        self.p = [[p00 + 0.25 * q * dt * dt, p01], [p10, p11]]

    def nis(self, z: float, r: float) -> float:
        s = self.p[0][0] + r
        return (z - self.x[0]) ** 2 / s

    def fuse(self, z: float, r: float) -> None:
        p = self.p
        s = p[0][0] + r
        k0, k1 = p[0][0] / s, p[1][0] / s
        y = z - self.x[0]
        self.x[0] += k0 * y
        self.x[1] += k1 * y
        self.p = [
            [(1 - k0) * p[0][0], (1 - k0) * p[0][1]],
            [p[1][0] - k1 * p[0][0], p[1][1] - k1 * p[0][1]],
        ]


# AC_PrecLand::TargetState
NEVER_SEEN, FOUND, RECENTLY_LOST, OUT_OF_RANGE = (
    "never_seen",
    "found",
    "recently_lost",
    "out_of_range",
)


class PrecLand:
    """Target estimator; ``texts`` collects STATUSTEXTs (severity, text) to send.

    ``backend``: PLND_TYPE was 1 at boot; ``param_enabled``: PLND_ENABLED now.
    """

    def __init__(self, backend: bool, param_enabled: bool, est_type: int) -> None:
        self.backend = backend
        self.param_enabled = param_enabled
        self.est_type = est_type
        self.texts: list[tuple[int, str]] = []
        self._meas: tuple[float, Vec3, float] | None = None  # (t, los body, distance)
        self._meas_fused_t: float | None = None
        self._last_update_t = -1e9
        self._acquired = False
        self._initialised = False
        self._init_t = 0.0
        self._kf: tuple[_AxisKF, _AxisKF] | None = None
        self._raw: tuple[float, float] | None = None
        self._outliers = 0
        self._wrong_frame_t = -1e9
        self._clock_offset: deque[float] = deque(maxlen=50)
        self.target_ne: tuple[float, float] | None = None  # last estimate, NE (m)
        self.measurements = 0
        self.state = NEVER_SEEN
        self.meas_down: float | None = None  # the last measurement's depth of the target (m)
        self.last_valid_t: float | None = None
        self.last_target_ne: tuple[float, float] | None = None
        self.last_vehicle_ned: Vec3 | None = None

    @property
    def enabled(self) -> bool:
        """The estimator runs: a backend exists and PLND_ENABLED is 1."""
        return self.backend and self.param_enabled

    # -- input ---------------------------------------------------------------------
    def handle_landing_target(self, msg: LandingTargetMsg, now: float) -> None:
        """Take one LANDING_TARGET message received at ``now`` (sim seconds)."""
        if not self.enabled:
            return
        if msg.position_valid == 1:
            if msg.frame != MAV_FRAME_BODY_FRD:
                # ArduPilot says so once; repeat at most every 5 s so a GCS notices.
                if now - self._wrong_frame_t >= 5.0:
                    self._wrong_frame_t = now
                    self.texts.append((6, "Plnd: Frame not supported "))
                return
            if not msg.distance > 0.0 or not math.isfinite(msg.distance):
                return
            d = msg.distance
            los = (msg.x / d, msg.y / d, msg.z / d)
        else:
            if not (math.isfinite(msg.angle_x) and math.isfinite(msg.angle_y)):
                return
            v = (-math.tan(msg.angle_y), math.tan(msg.angle_x), 1.0)
            n = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
            los = (v[0] / n, v[1] / n, v[2] / n)
            d = msg.distance
        if not all(math.isfinite(c) for c in los):
            return
        self._meas = (self._correct_time(msg.time_usec, now), los, d)
        self.measurements += 1

    def _correct_time(self, time_usec: int, now: float) -> float:
        """Map the sender's timestamp onto the sim clock (minimum-offset jitter filter)."""
        if time_usec <= 0:
            return now
        self._clock_offset.append(now - time_usec * 1e-6)
        t = time_usec * 1e-6 + min(self._clock_offset)
        return min(now, t)

    # -- per control loop ------------------------------------------------------------
    def update(
        self,
        now: float,
        delayed_pos: Vec3,
        delayed_quat: Quat,
        rangefinder_m: float | None,
        cam_offset: Vec3,
    ) -> None:
        """Run the estimator: fuse a new measurement if one waits, check timeouts."""
        if not self.enabled:
            return
        meas = self._meas
        self._meas = None
        if meas is not None and now - meas[0] <= MEAS_STALE_S:
            rel = self._relative_ned(meas[1], meas[2], delayed_quat, rangefinder_m, cam_offset)
            if rel is not None:
                tn, te = delayed_pos[0] + rel[0], delayed_pos[1] + rel[1]
                self.meas_down = rel[2]
                self._fuse(now, tn, te, rel[2])
        self._check_timeouts(now)
        if self.acquired and self.target_ne is not None:
            self.last_valid_t = now
            self.last_target_ne = self.target_ne
            self.last_vehicle_ned = delayed_pos

    def check_target_status(
        self,
        now: float,
        vehicle_ned: Vec3,
        rangefinder_m: float | None,
        alt_min: float,
        alt_max: float,
    ) -> None:
        """AC_PrecLand::check_target_status (runs only with a backend)."""
        if not self.backend:
            return
        if self.acquired:
            self.state = FOUND
            return
        self.state = RECENTLY_LOST if self.state in (FOUND, RECENTLY_LOST) else NEVER_SEEN
        if not _sensor_in_range(rangefinder_m, alt_min, alt_max):
            self.state = OUT_OF_RANGE
            return
        if self.state == RECENTLY_LOST and self.last_valid_t is not None:
            far = self.last_target_ne is not None and (
                math.dist(vehicle_ned[:2], self.last_target_ne) > TARGET_LOST_DIST_M
                or (
                    self.last_vehicle_ned is not None
                    and math.dist(vehicle_ned[:2], self.last_vehicle_ned[:2]) > TARGET_LOST_DIST_M
                )
            )
            if now - self.last_valid_t > TARGET_LOST_TIMEOUT_S or far:
                self.state = NEVER_SEEN

    def _relative_ned(
        self, los: Vec3, dist: float, q: Quat, rangefinder_m: float | None, cam: Vec3
    ) -> Vec3 | None:
        los_ned = body_to_ned(q, los)
        if los_ned[2] <= 0.0:  # pointing up: not at a target on the ground
            return None
        cam_ned = body_to_ned(q, cam)
        if dist > 0.0:
            d = dist
        elif rangefinder_m is not None and rangefinder_m > 0.0:
            d = max(rangefinder_m - cam_ned[2], 0.0) / los_ned[2]
        else:
            return None
        return (
            los_ned[0] * d + cam_ned[0],
            los_ned[1] * d + cam_ned[1],
            los_ned[2] * d + cam_ned[2],
        )

    def _fuse(self, now: float, tn: float, te: float, down: float) -> None:
        if self.est_type == 0:
            if not self._initialised:
                self._initialised = True
                self.texts.append((6, "PrecLand: Target Found"))
            self._raw = (tn, te)
            self._last_update_t = now
            self._acquired = True
            self.target_ne = self._raw
            return
        var = (abs(down) * 0.01 + 0.02) ** 2
        if not self._initialised or self._kf is None:
            self._kf = (_AxisKF(tn, var), _AxisKF(te, var))
            self._initialised = True
            self._init_t = now
            self._last_update_t = now
            self._meas_fused_t = now
            self.texts.append((6, "PrecLand: Target Found"))
            return
        kx, ky = self._kf
        dt = max(0.0, now - (self._meas_fused_t or now))
        kx.predict(dt, 0.5)
        ky.predict(dt, 0.5)
        self._meas_fused_t = now
        if max(kx.nis(tn, var), ky.nis(te, var)) < 3.0 or self._outliers >= 3:
            self._outliers = 0
            kx.fuse(tn, var)
            ky.fuse(te, var)
            self._last_update_t = now
        else:
            self._outliers += 1
        if self._acquired:
            self.target_ne = (kx.x[0], ky.x[0])

    def _check_timeouts(self, now: float) -> None:
        if now - self._last_update_t > TARGET_TIMEOUT_S:
            if self._acquired:
                self.texts.append((2, "PrecLand: Target Lost"))
            self._acquired = False
            self._initialised = False
            self.target_ne = None
        if self.est_type != 0 and not self._acquired and self._initialised:
            if now - self._last_update_t > KF_INIT_MIN_UPDATE_S:
                self._initialised = False
                self.texts.append((2, "PrecLand: Init Failed"))
            elif now - self._init_t > KF_INIT_TIME_S and self._kf is not None:
                self._acquired = True
                self.target_ne = (self._kf[0].x[0], self._kf[1].x[0])
                self.texts.append((6, "PrecLand: Init Complete"))

    @property
    def acquired(self) -> bool:
        """The estimate is usable for landing."""
        return self._acquired and self.target_ne is not None

    def measurement_fresh(self, now: float) -> bool:
        """A measurement was fused within the last second."""
        return now - self._last_update_t <= MEAS_STALE_S


def _sensor_in_range(rangefinder_m: float | None, alt_min: float, alt_max: float) -> bool:
    """AC_PrecLand::check_if_sensor_in_range: needs a rangefinder once limits are set."""
    if alt_min == 0 and alt_max == 0:
        return True
    if rangefinder_m is None:
        return False
    if alt_max != 0 and rangefinder_m > alt_max:
        return False
    return not (alt_min != 0 and rangefinder_m < alt_min)


# AC_PrecLand_StateMachine::Status and FailSafeAction
DESCEND, RETRYING, FAILSAFE = "descend", "retrying", "failsafe"
HOLD_POS = "hold_pos"


class PrecLandStateMachine:
    """What LAND does with precision landing enabled (AC_PrecLand_StateMachine).

    ``init`` at every mode change; ``update`` each loop gives the status and, while
    retrying, the position (NED, m) to fly to; ``failsafe_action`` the hold/descend.
    """

    def __init__(self) -> None:
        self.init()

    def init(self) -> None:
        self.retry_count = 0
        self._reset()

    def _reset(self) -> None:
        self._lost_action = "init"
        self._retry_state = "init"
        self._failsafe_started: float | None = None

    def update(
        self,
        pl: PrecLand,
        now: float,
        vehicle_ned: Vec3,
        strict: int,
        timeout_s: float,
        retry_max: int,
        retry_behave: int,
    ) -> tuple[str, Vec3 | None]:
        state = pl.state
        if state == NEVER_SEEN:
            return FAILSAFE, None
        if state in (FOUND, OUT_OF_RANGE):
            self._reset()
            return DESCEND, None
        # recently lost
        if self._lost_action == "init":
            self._lost_action = "land_vertically" if strict == 0 else "descend"
            return DESCEND, None
        if self._lost_action == "descend":
            if pl.last_valid_t is not None and now - pl.last_valid_t >= timeout_s:
                self._lost_action = "retry"
                self._retry_state = "init"
            return DESCEND, None
        if self._lost_action == "land_vertically":
            return DESCEND, None
        return self._retry(pl, vehicle_ned, retry_max, retry_behave)

    def _retry(
        self, pl: PrecLand, vehicle_ned: Vec3, retry_max: int, retry_behave: int
    ) -> tuple[str, Vec3 | None]:
        if retry_max == 0 or self.retry_count > retry_max:
            return FAILSAFE, None
        if retry_behave == 1 and pl.last_target_ne is not None and pl.last_vehicle_ned is not None:
            base: Vec3 = (*pl.last_target_ne, pl.last_vehicle_ned[2])
        elif pl.last_vehicle_ned is not None:
            base = pl.last_vehicle_ned
        else:
            return FAILSAFE, None
        go_to = (base[0], base[1], base[2] - RETRY_CLIMB_M)
        if self._retry_state == "init":
            self.retry_count += 1
            self._retry_state = "in_progress"
            if self.retry_count <= retry_max:
                pl.texts.append((6, "PrecLand: Retrying"))
            return RETRYING, go_to
        if self._retry_state == "in_progress":
            if math.dist(go_to, vehicle_ned) < RETRY_REACHED_M:
                self._retry_state = "descend"
            return RETRYING, go_to
        if self._retry_state == "descend":
            target = (vehicle_ned[0], vehicle_ned[1], base[2])
            if abs(vehicle_ned[2] - target[2]) < RETRY_REACHED_M:
                self._retry_state = "complete"
                pl.texts.append((6, "PrecLand: Retry Completed"))
            return RETRYING, target
        return FAILSAFE, None

    def failsafe_action(self, pl: PrecLand, now: float, strict: int) -> str:
        """HOLD_POS or DESCEND; announces "PrecLand: Failsafe Measures" once."""
        if self._failsafe_started is None:
            self._failsafe_started = now
            pl.texts.append((6, "PrecLand: Failsafe Measures"))
        if strict == 2:
            return HOLD_POS
        if strict == 1 and now - self._failsafe_started < FAILSAFE_HOLD_S:
            return HOLD_POS
        return DESCEND
