"""The simulated ArduCopter: physics plus an autopilot that behaves like ArduCopter 4.5
where a ground station relies on it (readiness, arming, modes, take-off, landing, RTL,
RC override, precision landing, parameters). No I/O: `VehicleServer` speaks MAVLink.
"""

from __future__ import annotations

import math
import random
from collections import deque

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim.vehicle.config import SimConfig
from sim.vehicle.control import (
    AttitudeController,
    PositionController,
    wrap_pi,
)
from sim.vehicle.modes import (
    ALT_HOLD,
    ARMABLE_MODES,
    GUIDED,
    LAND,
    LOITER,
    MANUAL_THROTTLE,
    MODE_NAMES,
    POSHOLD,
    REQUIRES_POSITION,
    RTL,
    SIMULATED_MODES,
    STABILIZE,
    FlightModes,
)
from sim.vehicle.navigation import GPS, Navigation
from sim.vehicle.params import ParamInfo, ParamStore
from sim.vehicle.physics import (
    GRAVITY,
    Airframe,
    QuadBody,
    Quat,
    Vec3,
    Wind,
    euler_from_quat,
)
from sim.vehicle.precland import LandingTargetMsg, PrecLand, PrecLandStateMachine
from sim.vehicle.state import Estimate, GuidedTarget, VehicleTruth

ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
FAILED = mavlink.MAV_RESULT_FAILED
DENIED = mavlink.MAV_RESULT_DENIED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED

SEV_CRITICAL = mavlink.MAV_SEVERITY_CRITICAL
SEV_WARNING = mavlink.MAV_SEVERITY_WARNING
SEV_INFO = mavlink.MAV_SEVERITY_INFO

# SITL's readiness timeline (s after boot), multiplied by SimConfig.ready_after_scale.
T_ATTITUDE, T_GPS_FIX, T_ORIGIN, T_PREARM, T_POSITION = 4.0, 10.0, 20.0, 24.0, 42.0
PREARM_DISPLAY_PERIOD = 30.0  # ArduPilot repeats failing pre-arm checks every 30 s
LAND_DETECT_S = 1.0  # LAND_DETECTOR_TRIGGER_SEC
FORCE_ARM_MAGIC = 21196
ARMING_CHECK_VISION = 1 << 18  # AP_Arming::Check::VISION
VISION_HISTORY_S = 1.0  # vision stamped further back is compared with the oldest truth
EARTH_RADIUS = 6378137.0


def _ou(x: float, std: float, tau: float, dt: float, rng: random.Random) -> float:
    """One step of an Ornstein-Uhlenbeck process (random walk pulled back to zero)."""
    a = math.exp(-dt / tau)
    return a * x + std * math.sqrt(1 - a * a) * rng.gauss()


class SimVehicle(FlightModes):
    """Physics and autopilot of one quadrotor; deterministic for a given seed.

    Examples
    --------
    >>> v = SimVehicle(SimConfig(seed=1, ready_after_scale=0.01))
    >>> v.step(1.0)
    >>> v.truth.mode, v.truth.armed
    (0, False)
    """

    def __init__(self, config: SimConfig, params: ParamStore | None = None) -> None:
        self.config = config
        self.params = params or ParamStore()
        self.airframe = Airframe()
        self._dt = 1.0 / config.physics_hz
        self._wind_rng = random.Random(f"visland-wind-{config.seed}")
        self._est_rng = random.Random(f"visland-est-{config.seed}")
        self.wind = Wind(config.wind_mps, config.wind_dir_deg, config.gust_mps, self._wind_rng)
        self.body = QuadBody(self.airframe, self.wind)
        self.time_s = 0.0
        self.battery_mah_used = 0.0
        self.landed_at: tuple[float, float] | None = None
        self._texts: list[tuple[int, str]] = []
        self.nav = Navigation(self.params, config.seed)
        self._battery_levels: set[str] = set()  # failsafe levels announced
        self._battery_timers: dict[str, float] = {}
        self._boot()

    # ------------------------------------------------------------------ boot, state
    def _boot(self) -> None:
        """(Re)initialise the autopilot; physics, parameters and battery are kept."""
        p = self.params
        self.boot_time = self.time_s
        self.armed = False
        self.mode = STABILIZE
        self.land_complete = True
        self._land_detect_t = 0.0
        self._disarm_timer = 0.0
        self._land_disarm_t = 0.0
        self._spool = 0.0
        self._last_prearm_text = -PREARM_DISPLAY_PERIOD + 5.0
        self._announced: set[str] = set()
        self._poscon = PositionController()
        self._attcon = AttitudeController(self.airframe)
        self._yaw_t = euler_from_quat(self.body.quat)[2]
        self._yaw_rate_t = 0.0
        self._guided = GuidedTarget()
        self._rtl_state: str | None = None
        self._rtl_alt = 0.0
        self._rtl_t = 0.0
        self._overrides: dict[int, tuple[int, float]] = {}
        self._collective = 0.0
        self._motor_cmd = [0.0, 0.0, 0.0, 0.0]
        self._last_ground_t = self.time_s
        self._bias = [0.0] * 6
        self._vel_noise = (0.0, 0.0, 0.0)
        self._est_t = -1.0
        self._speed_override: float | None = None
        self._yaw_goal: float | None = None
        self._yaw_goal_rate = math.radians(90)
        self._history: deque[tuple[float, Vec3, Quat]] = deque(
            maxlen=int(0.3 * self.config.physics_hz) + 2
        )
        # AC_PrecLand creates its backend at boot from PLND_TYPE; PLND_ENABLED gates it live.
        self.precland = PrecLand(
            backend=p.get("PLND_TYPE") == 1,
            param_enabled=p.get("PLND_ENABLED") == 1,
            est_type=int(p.get("PLND_EST_TYPE")),
        )
        self._plnd_sm = PrecLandStateMachine()
        # AP_VisualOdom likewise exists only if VISO_TYPE was 1 at boot.
        self.nav.reset(viso_backend=p.get("VISO_TYPE") == 1)
        # The true position over the last second (boot s), for vision stamped in the past,
        # and the smallest capture -> arrival lag seen (the jitter correction's offset).
        self._truth_history: deque[tuple[float, Vec3]] = deque(
            maxlen=int(VISION_HISTORY_S * self.config.physics_hz) + 2
        )
        self._vision_min_lag = math.inf
        # Home: where the vehicle boots (the EKF origin), then wherever it arms.
        self.home_ned: Vec3 = (0.0, 0.0, 0.0)
        self._update_estimate(force=True)

    def reboot(self, down_s: float = 0.0) -> int:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: refused while armed, as ArduCopter does.

        ``down_s``: how long the autopilot is down first; its clock starts after that (as
        SITL's: the new boot's first messages say a few ms).
        """
        if self.armed:
            return FAILED
        self._boot()
        self.boot_time += down_s
        return ACCEPTED

    @property
    def boot_s(self) -> float:
        """Seconds since (re)boot."""
        return self.time_s - self.boot_time

    @property
    def time_boot_ms(self) -> int:
        """Milliseconds since boot, as MAVLink's time_boot_ms."""
        return int(max(0.0, self.boot_s) * 1000.0) & 0xFFFFFFFF

    @property
    def truth(self) -> VehicleTruth:
        """Ground truth now."""
        b = self.body
        roll, pitch, yaw = euler_from_quat(b.quat)
        return VehicleTruth(
            self.time_s,
            b.pos,
            b.vel,
            roll,
            pitch,
            yaw,
            self.armed,
            self.mode,
            b.on_ground,
            self.landed_at,
        )

    def drain_texts(self) -> list[tuple[int, str]]:
        """STATUSTEXTs (severity, text) produced since the last call."""
        out = self._texts + self.precland.texts
        self._texts = []
        self.precland.texts = []
        return out

    def _text(self, severity: int, text: str) -> None:
        self._texts.append((severity, text))

    # ------------------------------------------------------------------ readiness
    def _t(self, base: float) -> float:
        return base * self.config.ready_after_scale

    @property
    def gps_fix(self) -> bool:
        """GPS has a 3D fix (never while SIM_GPS_DISABLE is 1)."""
        return self.boot_s >= self._t(T_GPS_FIX) and self.params.get("SIM_GPS_DISABLE") == 0

    @property
    def origin_set(self) -> bool:
        """EKF origin set: local and global positions are reported."""
        return self.boot_s >= self._t(T_ORIGIN)

    @property
    def home_set(self) -> bool:
        """Home position known (HOME_POSITION is available)."""
        return self.boot_s >= self._t(T_PREARM)

    @property
    def position_ok(self) -> bool:
        """The EKF has a horizontal position (GPS from ~42 s after boot, or ExternalNav):
        GPS modes work and LOCAL_POSITION_NED is sent."""
        return self.nav.position_ok

    def _gps_usable(self) -> bool:
        return self.gps_fix and self.boot_s >= self._t(T_POSITION)

    def _readiness_failures(self) -> list[str]:
        t = self.boot_s
        if t < self._t(T_ATTITUDE):
            return ["EKF attitude is bad", "GPS 1: Bad fix"]
        reasons = [] if self.gps_fix else ["GPS 1: Bad fix"]
        if self.gps_fix and t < self._t(T_PREARM):
            reasons.append("AHRS: waiting for home")
        if (
            self.nav.viso_backend
            and self._arming_check(ARMING_CHECK_VISION)
            and not self.nav.vision_healthy(self.time_s)
        ):
            reasons.append("VisOdom: not healthy")
        return reasons

    def _arming_check(self, bit: int) -> bool:
        """ARMING_CHECK has ``bit`` (or bit 0: all checks)."""
        value = int(self.params.get("ARMING_CHECK"))
        return bool(value & 1 or value & bit)

    def arming_failures(self, mode: int | None = None) -> list[str]:
        """Every reason ArduCopter would give for refusing to arm in ``mode`` now."""
        mode = self.mode if mode is None else mode
        reasons: list[str] = []
        if self.params.get("ARMING_CHECK") != 0:
            reasons += self._readiness_failures()
        if mode not in ARMABLE_MODES:
            reasons.append("Mode not armable")
        elif mode in REQUIRES_POSITION and not self.position_ok:
            reasons.append("Need Position Estimate")
        thr = self.rc(3)
        if (mode in MANUAL_THROTTLE and thr > 1030) or (
            mode not in MANUAL_THROTTLE and mode != GUIDED and self._pilot_climb(thr) > 0
        ):
            reasons.append("Throttle too high")
        return reasons

    @property
    def prearm_ok(self) -> bool:
        """What SYS_STATUS reports in the pre-arm bit: checks pass in the current mode."""
        return not self.arming_failures()

    # ------------------------------------------------------------------ RC
    def rc(self, channel: int) -> int:
        """Effective PWM of an RC channel (1-based): override if live, else SITL's RC."""
        ov = self._overrides.get(channel)
        timeout = self.params.get("RC_OVERRIDE_TIME")
        if ov is not None and (timeout < 0 or self.time_s - ov[1] <= timeout):
            return ov[0]
        return 1000 if channel == 3 else 1500

    def rc_override(self, sender_sysid: int, channels: list[int]) -> bool:
        """RC_CHANNELS_OVERRIDE: honoured only from SYSID_MYGCS; False when ignored.

        Channels 1-8: 0 releases, UINT16_MAX leaves as is; 9-18: 0 or UINT16_MAX
        leave as is, UINT16_MAX - 1 releases (MAVLink's convention).
        """
        if sender_sysid != int(self.params.get("SYSID_MYGCS")):
            return False
        if self.params.get("RC_OVERRIDE_TIME") == 0:
            return False
        for i, value in enumerate(channels[:18], start=1):
            if i <= 8:
                if value == 0:
                    self._overrides.pop(i, None)
                    continue
                if value == 0xFFFF:
                    continue
            else:
                if value in (0, 0xFFFF):
                    continue
                if value == 0xFFFE:
                    self._overrides.pop(i, None)
                    continue
            self._overrides[i] = (int(value), self.time_s)
        return True

    def rc_channels(self) -> list[int]:
        """Effective PWM of channels 1-16."""
        return [self.rc(i) for i in range(1, 17)]

    def _stick(self, channel: int, deadzone: int = 20) -> float:
        """Stick deflection in [-1, 1] around 1500 with a deadzone."""
        d = self.rc(channel) - 1500
        if abs(d) <= deadzone:
            return 0.0
        return max(-1.0, min(1.0, (d - math.copysign(deadzone, d)) / (500 - deadzone)))

    def _pilot_climb(self, pwm: int) -> float:
        """Climb rate (m/s, up positive) from the throttle stick, with THR_DZ."""
        p = self.params
        thr = max(0, min(1000, pwm - 1000))
        dz = p.get("THR_DZ")
        up = p.get("PILOT_SPEED_UP") / 100.0
        dn = (p.get("PILOT_SPEED_DN") or p.get("PILOT_SPEED_UP")) / 100.0
        if thr > 500 + dz:
            return up * (thr - 500 - dz) / (500 - dz)
        if thr < 500 - dz:
            return -dn * (500 - dz - thr) / (500 - dz)
        return 0.0

    # ------------------------------------------------------------------ commands
    def arm(self, force: bool = False) -> int:
        """MAV_CMD_COMPONENT_ARM_DISARM param1=1 (force: param2=21196)."""
        if self.armed:
            return ACCEPTED
        if not force:
            reasons = self.arming_failures()
            if reasons:
                for r in reasons:
                    self._text(SEV_CRITICAL, f"Arm: {r}")
                return FAILED
        self.armed = True
        self.land_complete = True
        self._spool = 0.0
        self._disarm_timer = 0.0
        if self.position_ok:
            # Arming sets home to the current location; the EKF origin stays put.
            self.home_ned = self.estimate.position_ned
        self._yaw_t = euler_from_quat(self.body.quat)[2]
        self._enter_mode(self.mode)
        self._text(SEV_INFO, "Arming motors")
        return ACCEPTED

    def disarm(self, force: bool = False) -> int:
        """MAV_CMD_COMPONENT_ARM_DISARM param1=0: a GCS may not disarm a vehicle that
        thinks it is flying, unless forced (AP_Arming_Copter::disarm)."""
        if not self.armed:
            return ACCEPTED
        if not force and not self.land_complete:
            return FAILED
        self._disarm()
        return ACCEPTED

    def _disarm(self) -> None:
        self.armed = False
        self.land_complete = True
        self._spool = 0.0
        self._text(SEV_INFO, "Disarming motors")

    def set_mode(self, mode: int) -> int:
        """Change flight mode like Copter::set_mode(); a refusal says why."""
        if mode == self.mode:
            return ACCEPTED
        name = MODE_NAMES.get(mode)
        if name is None:
            self._text(SEV_WARNING, f"No such mode {mode}")
            return FAILED
        if self.armed and mode in REQUIRES_POSITION and not self.position_ok:
            self._text(SEV_WARNING, f"Mode change to {name} failed: requires position")
            return FAILED
        if mode not in SIMULATED_MODES:
            # The stand-in does not fly this mode; ArduCopter's own refusal wording.
            self._text(SEV_WARNING, f"Mode change to {name} failed: init failed")
            return FAILED
        if mode == RTL and not self.home_set and self.armed:
            self._text(SEV_WARNING, f"Mode change to {name} failed: init failed")
            return FAILED
        self.mode = mode
        self._enter_mode(mode)
        return ACCEPTED

    def _enter_mode(self, mode: int) -> None:
        est = self.estimate
        self._poscon.reset(est.position_ned, est.velocity_ned)
        self._yaw_t = est.yaw
        self._yaw_rate_t = 0.0
        self._guided = GuidedTarget()
        self._speed_override = None
        self._yaw_goal = None
        self._rtl_state = "climb" if mode == RTL else None
        self._plnd_sm.init()

    def takeoff(self, alt_m: float, must_navigate: bool = True) -> int:
        """MAV_CMD_NAV_TAKEOFF (Mode::do_user_takeoff): armed, landed, a mode that
        takes off (GUIDED, LOITER, POSHOLD; ALT_HOLD only without navigation)."""
        if not self.armed or not self.land_complete:
            return FAILED
        if not math.isfinite(alt_m):
            return FAILED
        allowed = {GUIDED, LOITER, POSHOLD} | ({ALT_HOLD} if not must_navigate else set())
        if self.mode not in allowed:
            return FAILED
        est = self.estimate
        if alt_m <= self.home_ned[2] - est.position_ned[2]:  # already above it (home-relative)
            return FAILED
        self._poscon.reset(est.position_ned, (0.0, 0.0, 0.0))
        self._poscon.reset_z_integrator()
        self.land_complete = False
        self._guided = GuidedTarget("takeoff", alt=alt_m)
        return ACCEPTED

    def guided_position(self, north: float, east: float, down: float | None) -> bool:
        """GUIDED position target (NED from home, metres); False when not accepted."""
        if self.mode != GUIDED or not self.armed or self.land_complete:
            return False
        if not all(math.isfinite(v) for v in (north, east, down if down is not None else 0.0)):
            return False
        if down is None:
            down = self._poscon.z.pos
        self._guided = GuidedTarget("pos", north, east, down)
        return True

    def guided_velocity(self, vn: float, ve: float, vd: float) -> bool:
        """GUIDED velocity target (NED, m/s); it times out after GUID_TIMEOUT s."""
        if self.mode != GUIDED or not self.armed or self.land_complete:
            return False
        if not all(math.isfinite(v) for v in (vn, ve, vd)):
            return False
        self._guided = GuidedTarget("vel", velocity=(vn, ve, vd), since=self.time_s)
        return True

    def guided_yaw(self, yaw_rad: float | None, yaw_rate: float | None) -> None:
        """Yaw target for GUIDED (absolute heading or rate)."""
        if self.mode != GUIDED:
            return
        if yaw_rad is not None and math.isfinite(yaw_rad):
            self._yaw_goal = wrap_pi(yaw_rad)
        elif yaw_rate is not None and math.isfinite(yaw_rate):
            self._yaw_goal = None
            self._yaw_rate_t = yaw_rate

    def condition_yaw(
        self, angle_deg: float, rate_dps: float, direction: int, relative: bool
    ) -> int:
        """MAV_CMD_CONDITION_YAW in GUIDED and in LAND (ArduCopter's LAND follows a
        fixed yaw too; a mode change forgets it)."""
        if self.mode not in (GUIDED, LAND) or not self.armed:
            return FAILED
        if not math.isfinite(angle_deg):
            return FAILED
        goal = math.radians(angle_deg)
        if relative:
            goal = self._yaw_t + (goal if direction >= 0 else -goal)
        self._yaw_goal = wrap_pi(goal)
        self._yaw_goal_rate = math.radians(rate_dps) if rate_dps > 0 else math.radians(90)
        return ACCEPTED

    def change_speed(self, speed_ms: float) -> int:
        """MAV_CMD_DO_CHANGE_SPEED: horizontal speed for GUIDED/RTL legs."""
        if not math.isfinite(speed_ms) or speed_ms <= 0:
            return FAILED
        self._speed_override = speed_ms
        return ACCEPTED

    def landing_target(self, msg: LandingTargetMsg) -> None:
        """LANDING_TARGET from a companion computer or GCS."""
        self.precland.handle_landing_target(msg, self.time_s)

    def vision_position(
        self, north: float, east: float, down: float, time_usec: int | None = None
    ) -> bool:
        """VISION_POSITION_ESTIMATE (NED, metres, in the vision system's frame) taken at
        ``time_usec`` on this vehicle's clock. As AP_VisualOdom: the jitter correction
        takes the smallest capture -> arrival lag for clock offset, and the EKF fuses the
        pose VISO_DELAY_MS before that corrected time; the pose is compared with where
        the vehicle truly was then (a wrong VISO_DELAY_MS shows as a lag error)."""
        truth = self.body.pos
        if time_usec:
            captured = time_usec / 1e6
            lag = self.boot_s - captured
            if lag >= 0:
                self._vision_min_lag = min(self._vision_min_lag, lag)
                delay = self.params.get("VISO_DELAY_MS") / 1000.0
                truth = self._truth_at(captured + self._vision_min_lag - delay)
        return self.nav.vision_position(self.time_s, (north, east, down), truth)

    def _truth_at(self, boot_s: float) -> Vec3:
        """The true position at ``boot_s`` (the oldest kept, if earlier; now, if later)."""
        for t, pos in reversed(self._truth_history):
            if t <= boot_s:
                return pos
        return self._truth_history[0][1] if self._truth_history else self.body.pos

    def vision_speed(self) -> None:
        """VISION_SPEED_ESTIMATE."""
        self.nav.vision_speed()

    def set_ekf_source_set(self, number: float) -> int:
        """MAV_CMD_SET_EKF_SOURCE_SET (param1 = 1..3)."""
        if not math.isfinite(number) or not self.nav.set_source_set(round(number)):
            return FAILED
        return ACCEPTED

    def param_set(self, name: str, value: float) -> ParamInfo | None:
        """PARAM_SET. As in ArduPilot, PLND_ENABLED and PLND_EST_TYPE act at once, but
        the precision-landing backend exists only if PLND_TYPE was 1 at boot."""
        info = self.params.set(name, value)
        if info is not None and name == "PLND_EST_TYPE":
            self.precland.est_type = int(info.value)
        if info is not None and name == "PLND_ENABLED":
            self.precland.param_enabled = info.value == 1
        return info

    # ------------------------------------------------------------------ geodesy
    def ned_to_global(self, n: float, e: float, d: float) -> tuple[float, float, float]:
        """(lat deg, lon deg, alt m AMSL) of a NED point relative to home."""
        c = self.config
        lat = c.home_lat + math.degrees(n / EARTH_RADIUS)
        lon = c.home_lon + math.degrees(e / (EARTH_RADIUS * math.cos(math.radians(c.home_lat))))
        return lat, lon, c.home_alt - d

    def global_to_ned(self, lat: float, lon: float) -> tuple[float, float]:
        """(north, east) in metres from home of a latitude/longitude."""
        c = self.config
        n = math.radians(lat - c.home_lat) * EARTH_RADIUS
        e = math.radians(lon - c.home_lon) * EARTH_RADIUS * math.cos(math.radians(c.home_lat))
        return n, e

    # ------------------------------------------------------------------ sensors
    def _update_estimate(self, force: bool = False) -> None:
        """Refresh the EKF-like error terms at 50 Hz (cheaper than every step)."""
        if not force and self.time_s - self._est_t < 0.02:
            return
        dt = 0.02 if self._est_t >= 0 else 0.0
        self._est_t = self.time_s
        rng = self._est_rng
        if dt > 0:
            b = self._bias
            for i, (std, tau) in enumerate(
                ((0.02, 8.0), (0.02, 8.0), (0.03, 8.0), (0.002, 20.0), (0.002, 20.0), (0.004, 20.0))
            ):
                b[i] = _ou(b[i], std, tau, dt, rng)
        self._vel_noise = (rng.gauss() * 0.01, rng.gauss() * 0.01, rng.gauss() * 0.01)

    @property
    def estimate(self) -> Estimate:
        """The autopilot's belief (what telemetry reports)."""
        b = self.body
        roll, pitch, yaw = euler_from_quat(b.quat)
        bias = self._bias
        vn = self._vel_noise
        off = self.nav.offset
        return Estimate(
            (b.pos[0] + bias[0] + off[0], b.pos[1] + bias[1] + off[1], b.pos[2] + bias[2]),
            (b.vel[0] + vn[0], b.vel[1] + vn[1], b.vel[2] + vn[2]),
            roll + bias[3],
            pitch + bias[4],
            wrap_pi(yaw + bias[5]),
            b.rates,
        )

    def rangefinder_m(self) -> float | None:
        """Downward rangefinder distance (m); None without one (RNGFND1_TYPE = 0, SITL's
        default) or outside RNGFND1_MIN/MAX_CM."""
        if self.params.get("RNGFND1_TYPE") == 0:
            return None
        roll, pitch, _ = euler_from_quat(self.body.quat)
        c = math.cos(roll) * math.cos(pitch)
        if c < 0.5:
            return None
        dist = -self.body.pos[2] / c + 0.05  # sensor mounted 5 cm above the skids
        p = self.params
        if not p.get("RNGFND1_MIN_CM") / 100 <= dist <= p.get("RNGFND1_MAX_CM") / 100:
            return None
        return dist

    @property
    def throttle_fraction(self) -> float:
        """Average motor output in [0, 1] (VFR_HUD throttle)."""
        return sum(self._motor_cmd) / 4 if self.armed else 0.0

    @property
    def battery_current_a(self) -> float:
        """Current drawn now (A): avionics plus motors, growing as thrust^1.5."""
        hover = self.airframe.mass * GRAVITY
        if not self.armed:
            return 0.4
        return 0.4 + 14.0 * (max(0.0, self.body.total_thrust) / hover) ** 1.5

    @property
    def battery_voltage(self) -> float:
        """Terminal voltage of a 3S pack: open-circuit by charge left, minus sag."""
        frac = max(0.0, 1.0 - self.battery_mah_used / self.config.battery_mah)
        return 10.5 + 2.1 * frac - 0.015 * self.battery_current_a

    @property
    def battery_remaining(self) -> int:
        """Percent of capacity left."""
        return max(0, round(100 * (1 - self.battery_mah_used / self.config.battery_mah)))

    # ------------------------------------------------------------------ stepping
    def step(self, dt: float) -> None:
        """Advance the simulation by ``dt`` seconds (in physics-rate sub-steps)."""
        if not dt >= 0 or not math.isfinite(dt):
            raise ValueError(f"dt must be a finite number >= 0, got {dt}")
        n = max(1, round(dt / self._dt)) if dt > 0 else 0
        for _ in range(n):
            self._step_once(dt / n)

    def _step_once(self, dt: float) -> None:
        self.time_s += dt
        self._update_estimate()
        self._navigate(dt)
        self._announce()
        est = self.estimate
        self._history.append((self.time_s, est.position_ned, self.body.quat))
        self._run_precland()
        if self.armed:
            self._spool = min(1.0, self._spool + dt / max(0.05, self.params.get("MOT_SPOOL_TIME")))
            self._fly(est, dt)
        else:
            self._motor_cmd = [0.0, 0.0, 0.0, 0.0]
            self._collective = 0.0
        was_on_ground = self.body.on_ground
        self.body.step(dt, self._motor_cmd)
        self._truth_history.append((self.boot_s, self.body.pos))
        self._after_physics(was_on_ground, dt)

    def _announce(self) -> None:
        """Boot-time STATUSTEXTs and the periodic pre-arm report."""
        t = self.boot_s
        for key, when, text in (
            ("tilt", 1.0, "EKF3 IMU0 tilt alignment complete"),
            ("origin", T_ORIGIN, "EKF3 IMU0 origin set"),
        ):
            if key not in self._announced and t >= self._t(when):
                self._announced.add(key)
                self._text(SEV_INFO, text)
        if not self.armed and t - self._last_prearm_text >= PREARM_DISPLAY_PERIOD:
            self._last_prearm_text = t
            for r in self.arming_failures():
                if r != "Mode not armable":
                    self._text(SEV_CRITICAL, f"PreArm: {r}")

    def _navigate(self, dt: float) -> None:
        """The EKF's position source; its failsafe when the position is lost."""
        nav = self.nav
        was_using, was_lost = nav.using, nav.lost
        for text in nav.update(self.time_s, dt, self.body.pos, self._gps_usable()):
            self._text(SEV_INFO if text.startswith("EKF3") else SEV_CRITICAL, text)
        if nav.using == GPS and was_using != GPS and not was_lost:
            self._text(SEV_INFO, "EKF3 IMU0 is using GPS")
        if nav.lost and not was_lost:
            self._ekf_failsafe()

    def _ekf_failsafe(self) -> None:
        """Copter::failsafe_ekf_event: land (FS_EKF_ACTION 1) or ALT_HOLD (2) from a mode
        that needs a position; LAND goes on, without a position."""
        action = int(self.params.get("FS_EKF_ACTION"))
        if not self.armed or action == 0 or self.mode not in REQUIRES_POSITION:
            return
        new = ALT_HOLD if action == 2 else LAND
        self.mode = new
        self._enter_mode(new)
        self._text(SEV_CRITICAL, f"EKF Failsafe: changed to {MODE_NAMES[new]} Mode")

    def _run_precland(self) -> None:
        """AC_PrecLand::update: the estimator (backend and PLND_ENABLED), then the
        target's state (any backend); cheap when neither applies."""
        pl = self.precland
        if not pl.backend:
            return
        p = self.params
        rangefinder = self.rangefinder_m()
        if pl.enabled:
            lag = min(0.25, max(0.02, p.get("PLND_LAG")))
            idx = max(0, len(self._history) - 1 - round(lag * self.config.physics_hz))
            _, pos, quat = self._history[idx]
            pl.update(
                self.time_s,
                pos,
                quat,
                rangefinder,
                (p.get("PLND_CAM_POS_X"), p.get("PLND_CAM_POS_Y"), p.get("PLND_CAM_POS_Z")),
            )
        pl.check_target_status(
            self.time_s,
            self._history[-1][1],
            rangefinder,
            p.get("PLND_ALT_MIN"),
            p.get("PLND_ALT_MAX"),
        )

    def _after_physics(self, was_on_ground: bool, dt: float) -> None:
        b = self.body
        if b.last_impact_speed is not None:
            if self.time_s - self._last_ground_t > 1.0:
                self._text(SEV_INFO, f"SIM Hit ground at {b.last_impact_speed:.2f} m/s")
            b.last_impact_speed = None
            self._last_ground_t = self.time_s
        if b.on_ground:
            if not was_on_ground:
                self.landed_at = (b.pos[0], b.pos[1])
            self._last_ground_t = self.time_s
        # Battery.
        self.battery_mah_used += self.battery_current_a * dt / 3.6
        self._battery_monitor(dt)
        if not self.armed:
            return
        self._land_detector(dt)
        self._auto_disarm(dt)

    def _battery_monitor(self, dt: float) -> None:
        """AP_BattMonitor's failsafe levels: below BATT_LOW_VOLT (or BATT_CRT_VOLT) for
        BATT_LOW_TIMER s, or less than BATT_LOW_MAH (BATT_CRT_MAH) left, once each; the
        action is BATT_FS_LOW_ACT / BATT_FS_CRT_ACT (1 Land, 2 RTL), as ArduCopter does."""
        p = self.params
        volts = self.battery_voltage
        left = p.get("BATT_CAPACITY") - self.battery_mah_used
        for level, volt_name, mah_name, action_name in (
            ("critical", "BATT_CRT_VOLT", "BATT_CRT_MAH", "BATT_FS_CRT_ACT"),
            ("low", "BATT_LOW_VOLT", "BATT_LOW_MAH", "BATT_FS_LOW_ACT"),
        ):
            if level in self._battery_levels:
                return
            limit, mah = p.get(volt_name), p.get(mah_name)
            under = limit > 0 and volts < limit
            timer = self._battery_timers.get(level, 0.0) + dt if under else 0.0
            self._battery_timers[level] = timer
            if (under and timer >= max(0.0, p.get("BATT_LOW_TIMER"))) or (mah > 0 and left < mah):
                self._battery_levels.add(level)
                if level == "critical":
                    self._battery_levels.add("low")
                self._text(
                    SEV_CRITICAL,
                    f"Battery 1 is {level} {volts:.2f}V used {self.battery_mah_used:.0f} mAh",
                )
                action = int(p.get(action_name))
                if self.armed and action in (1, 2):
                    self._text(SEV_WARNING, "Battery Failsafe")
                    self.set_mode(LAND if action == 1 else RTL)
                return

    def _land_detector(self, dt: float) -> None:
        """ArduCopter's land detector: throttle at its lower limit, not accelerating,
        not descending fast, rangefinder low, all for one second."""
        hover = self.airframe.mass * GRAVITY
        b = self.body
        if self.land_complete:
            if self._collective > 0.9 * hover and not b.on_ground:
                self.land_complete = False
            return
        acc_dev = math.sqrt(b.accel[0] ** 2 + b.accel[1] ** 2 + b.accel[2] ** 2)
        rf = self.rangefinder_m()
        if (
            self._collective < 0.25 * hover
            and acc_dev < 1.0
            and abs(b.vel[2]) < 1.0
            and (rf is None or rf < 2.0)
        ):
            self._land_detect_t += dt
            if self._land_detect_t >= LAND_DETECT_S:
                self.land_complete = True
                self._land_detect_t = 0.0
        else:
            self._land_detect_t = 0.0

    def _auto_disarm(self, dt: float) -> None:
        """Disarm after DISARM_DELAY s landed with throttle low; LAND disarms at once."""
        if self.land_complete and (self.mode == LAND or self.rtl_state == "land"):
            # ModeLand disarms once the motors have spooled down to ground idle.
            self._land_disarm_t += dt
            if self._land_disarm_t >= max(0.5, self.params.get("MOT_SPOOL_TIME")):
                self._disarm()
            return
        self._land_disarm_t = 0.0
        delay = self.params.get("DISARM_DELAY")
        thr_low = self.rc(3) <= 1030
        if delay <= 0 or not self.land_complete or not thr_low:
            self._disarm_timer = 0.0
            return
        self._disarm_timer += dt
        if self._disarm_timer >= delay:
            self._disarm()
