"""ArduCopter flight modes as the stand-in flies them: STABILIZE, ALT_HOLD, LOITER,
POSHOLD, GUIDED (take-off, position, velocity), LAND (with precision landing), RTL,
BRAKE. Each mode turns pilot sticks or GCS targets into shaped position/velocity
targets, or lean angles and throttle, for the controllers in `control`.
"""

from __future__ import annotations

import math

from backend.link.modes import COPTER_MODES
from sim.vehicle.control import (
    AttitudeController,
    PositionController,
    lean_from_accel,
    mix,
    wrap_pi,
)
from sim.vehicle.params import ParamStore
from sim.vehicle.physics import GRAVITY, Airframe, QuadBody
from sim.vehicle.precland import (
    FAILSAFE,
    HOLD_POS,
    RETRYING,
    PrecLand,
    PrecLandStateMachine,
)
from sim.vehicle.state import Estimate, GuidedTarget

# ArduCopter's mode numbers and names: the same table the GCS side knows
# (8, 10, 12, 26 and 29 do not exist on a quad).
MODE_NAMES: dict[int, str] = dict(COPTER_MODES)
STABILIZE, ALT_HOLD, GUIDED, LOITER, RTL, LAND, POSHOLD, BRAKE = 0, 2, 4, 5, 6, 9, 16, 17
SIMULATED_MODES = frozenset({STABILIZE, ALT_HOLD, GUIDED, LOITER, RTL, LAND, POSHOLD, BRAKE})
# Modes whose Mode::requires_GPS() is true in ArduCopter.
REQUIRES_POSITION = frozenset({3, GUIDED, LOITER, RTL, 7, 13, POSHOLD, BRAKE, 21, 23, 24, 27})
ARMABLE_MODES = frozenset({STABILIZE, ALT_HOLD, GUIDED, LOITER, POSHOLD})
MANUAL_THROTTLE = frozenset({STABILIZE})


class FlightModes:
    """The mode logic of `SimVehicle` (a mixin: it flies the vehicle's own state)."""

    # State and helpers provided by SimVehicle (also: rc(), _stick(), _pilot_climb(),
    # rangefinder_m()).
    params: ParamStore
    airframe: Airframe
    body: QuadBody
    precland: PrecLand
    _plnd_sm: PrecLandStateMachine
    home_ned: tuple[float, float, float]
    position_ok: bool
    mode: int
    armed: bool
    land_complete: bool
    time_s: float
    _poscon: PositionController
    _attcon: AttitudeController
    _guided: GuidedTarget
    _spool: float
    _collective: float
    _motor_cmd: list[float]
    _yaw_t: float
    _yaw_rate_t: float
    _yaw_goal: float | None
    _yaw_goal_rate: float
    _speed_override: float | None
    _rtl_state: str | None
    _rtl_alt: float
    _rtl_t: float

    def _gains_xy(self) -> dict[str, float]:
        p = self.params
        return {
            "pos_p": p.get("PSC_POSXY_P"),
            "vel_p": p.get("PSC_VELXY_P"),
            "vel_i": p.get("PSC_VELXY_I"),
            "vel_d": p.get("PSC_VELXY_D"),
        }

    def _gains_z(self) -> dict[str, float]:
        p = self.params
        return {"pos_p": p.get("PSC_POSZ_P"), "vel_p": p.get("PSC_VELZ_P"), "vel_i": 2.0}

    def _ground_idle(self, est: Estimate) -> None:
        """Motors at ground idle: no thrust demand, controllers held at the vehicle."""
        self._poscon.reset(est.position_ned, (0.0, 0.0, 0.0))
        self._poscon.reset_z_integrator()
        self._attcon.reset()
        self._yaw_t = est.yaw
        self._collective = 0.0
        self._motor_cmd = [0.01 * self._spool] * 4

    def _fly(self, est: Estimate, dt: float) -> None:
        mode = self.mode
        p = self.params
        angle_max = math.radians(p.get("ANGLE_MAX") / 100.0)
        poscon = self._poscon
        xy_accel = p.get("WPNAV_ACCEL") / 100.0
        speed_xy = self._speed_override or p.get("WPNAV_SPEED") / 100.0
        yaw_rate_pilot = self._stick(4) * math.radians(p.get("PILOT_Y_RATE"))
        lean: tuple[float, float] | None = None  # pilot lean angles (manual xy)
        collective: float | None = None  # manual throttle (N)

        if mode == STABILIZE:
            thr = max(0.0, min(1.0, (self.rc(3) - 1000) / 1000.0))
            if thr <= 0.03 and self.land_complete:
                self._ground_idle(est)
                return
            h = self.airframe.hover_throttle
            out = thr / 0.5 * h if thr < 0.5 else h + (thr - 0.5) / 0.5 * (1 - h)
            collective = out * self.airframe.max_thrust_total
            lean = (self._stick(1) * angle_max, self._stick(2) * angle_max)
            self._yaw_t = wrap_pi(self._yaw_t + yaw_rate_pilot * dt)
        elif mode in (ALT_HOLD, LOITER, POSHOLD):
            climb = self._pilot_climb(self.rc(3))
            taking_off = self._guided.kind == "takeoff"
            if self.land_complete and climb <= 0 and not taking_off:
                self._ground_idle(est)
                return
            if self.land_complete and climb > 0:
                self.land_complete = False
                poscon.reset(est.position_ned, (0.0, 0.0, 0.0))
            if taking_off:
                down = self.home_ned[2] - self._guided.alt
                poscon.z.to_position(
                    down, 0, p.get("PILOT_SPEED_UP") / 100, p.get("PSC_POSZ_P"), 1.0, dt
                )
                if abs(poscon.z.pos - down) < 0.05 or climb != 0:
                    self._guided = GuidedTarget()
            else:
                poscon.z.to_velocity(-climb, p.get("PILOT_ACCEL_Z") / 100.0, dt)
            self._yaw_t = wrap_pi(self._yaw_t + yaw_rate_pilot * dt)
            if mode == ALT_HOLD:
                lean = (self._stick(1) * angle_max, self._stick(2) * angle_max)
            else:
                fwd = -self._stick(2) * p.get("LOIT_SPEED") / 100.0
                right = self._stick(1) * p.get("LOIT_SPEED") / 100.0
                cy, sy = math.cos(est.yaw), math.sin(est.yaw)
                poscon.xy.to_velocity(
                    fwd * cy - right * sy, fwd * sy + right * cy, p.get("LOIT_ACC_MAX") / 100, dt
                )
        elif mode == GUIDED:
            if self.land_complete and self._guided.kind != "takeoff":
                self._ground_idle(est)
                return
            self._run_guided(est, dt, speed_xy, xy_accel)
        elif mode == LAND:
            if self.land_complete:
                self._ground_idle(est)
                return
            self._run_land(est, dt, speed_xy, xy_accel)
            if not self.position_ok:
                # Mode LAND without a position (nogps_run): level, pilot's lean only.
                lean = (self._stick(1) * angle_max, self._stick(2) * angle_max)
        elif mode == RTL:
            if self.land_complete:
                self._ground_idle(est)
                return
            self._run_rtl(est, dt, speed_xy, xy_accel)
        elif mode == BRAKE:
            if self.land_complete:
                self._ground_idle(est)
                return
            poscon.xy.to_velocity(0.0, 0.0, 8.0, dt)
            poscon.z.to_velocity(0.0, 2.5, dt)

        # Vertical: shaped target -> down acceleration -> collective thrust.
        roll_est, pitch_est = est.roll, est.pitch
        tilt_cos = max(0.5, math.cos(roll_est) * math.cos(pitch_est))
        if collective is None:
            frozen = self._collective >= self.airframe.max_thrust_total * 0.98
            a_d = poscon.accel_z(
                est.position_ned[2], est.velocity_ned[2], self._gains_z(), dt, frozen
            )
            a_d = max(-GRAVITY, min(0.8 * GRAVITY, a_d))
            collective = self.airframe.mass * (GRAVITY - a_d) / tilt_cos
        if lean is None:
            an, ae = poscon.accel_xy(
                est.position_ned,
                est.velocity_ned,
                self._gains_xy(),
                GRAVITY * math.tan(angle_max),
                dt,
            )
            lean = lean_from_accel(an, ae, est.yaw, angle_max)
        self._update_yaw_goal(dt)
        lower = 0.03 * self.airframe.max_thrust_total
        collective = max(lower, min(self.airframe.max_thrust_total, collective))
        collective = min(collective, self._spool * self.airframe.max_thrust_total)
        self._collective = collective
        torques = self._attcon.torques(
            self.body.quat,
            self.body.rates,
            lean[0],
            lean[1],
            self._yaw_t,
            0.0,
            p.get("ATC_ANG_RLL_P"),
            math.radians(p.get("ATC_ACCEL_R_MAX") / 100.0),
            math.radians(p.get("ATC_ACCEL_Y_MAX") / 100.0),
            dt,
            integrate=not self.body.on_ground,
        )
        self._motor_cmd = mix(self.airframe, collective, torques, 0.03 * self._spool)

    def _update_yaw_goal(self, dt: float) -> None:
        goal = self._yaw_goal
        if self.mode not in (GUIDED, LAND):  # the modes that take CONDITION_YAW
            self._yaw_goal = None
            return
        if goal is not None:
            rate = self._yaw_goal_rate
            err = wrap_pi(goal - self._yaw_t)
            step = rate * dt
            self._yaw_t = wrap_pi(self._yaw_t + max(-step, min(step, err)))
        elif self._yaw_rate_t:
            self._yaw_t = wrap_pi(self._yaw_t + self._yaw_rate_t * dt)

    def _run_guided(self, est: Estimate, dt: float, speed_xy: float, accel_xy: float) -> None:
        p = self.params
        poscon = self._poscon
        g = self._guided
        sub = g.kind
        up = p.get("WPNAV_SPEED_UP") / 100.0
        dn = p.get("WPNAV_SPEED_DN") / 100.0
        acc_z = p.get("WPNAV_ACCEL_Z") / 100.0
        pz = p.get("PSC_POSZ_P")
        pxy = p.get("PSC_POSXY_P")
        if sub == "takeoff":
            down = self.home_ned[2] - g.alt  # MAV_CMD_NAV_TAKEOFF's altitude is above home
            poscon.xy.to_velocity(0.0, 0.0, accel_xy, dt)
            poscon.z.to_position(down, dn, up, pz, acc_z, dt)
            if abs(poscon.z.pos - down) < 0.01 and abs(poscon.z.vel) < 0.02:
                self._guided = GuidedTarget()
        elif sub == "pos":
            poscon.xy.to_position(g.north, g.east, speed_xy, pxy, accel_xy, dt)
            poscon.z.to_position(g.down, dn, up, pz, acc_z, dt)
        elif sub == "vel":
            vn, ve, vd = g.velocity
            if self.time_s - g.since > p.get("GUID_TIMEOUT"):
                vn = ve = vd = 0.0
                self._yaw_rate_t = 0.0
            poscon.xy.to_velocity(vn, ve, accel_xy, dt)
            poscon.z.to_velocity(max(-up, min(dn, vd)), acc_z, dt)
        else:
            poscon.xy.to_velocity(0.0, 0.0, accel_xy, dt)
            poscon.z.to_velocity(0.0, acc_z, dt)

    def _land_descent(self, est: Estimate, precision: bool) -> float:
        """Descent rate (m/s) as Mode::land_run_vertical_control computes it: fast above
        LAND_ALT_LOW, LAND_SPEED below; with a precision-landing target, no descent
        while it is over PLND_XY_DIST_MAX away, and slower the farther it is while
        the target's measured depth is between 0.35 and 2 m (not the rangefinder)."""
        p = self.params
        rf = self.rangefinder_m()
        alt = rf if rf is not None else self.home_ned[2] - est.position_ned[2]
        if alt > p.get("LAND_ALT_LOW") / 100.0:
            speed = (p.get("LAND_SPEED_HIGH") or p.get("WPNAV_SPEED_DN")) / 100.0
        else:
            speed = p.get("LAND_SPEED") / 100.0
        pl = self.precland
        if precision and pl.target_ne is not None:
            err_cm = 100.0 * math.hypot(
                pl.target_ne[0] - est.position_ned[0], pl.target_ne[1] - est.position_ned[1]
            )
            max_err_cm = 100.0 * p.get("PLND_XY_DIST_MAX")
            depth = pl.meas_down
            if max_err_cm > 0 and err_cm > max_err_cm:
                speed = 0.0
            elif depth is not None and 0.35 < depth < 2.0:
                max_desc = abs(p.get("LAND_SPEED")) * 0.5
                slow = max(0.0, err_cm * (max_desc / 15.0))
                speed = max(10.0, max_desc - slow) / 100.0
        return speed

    def _run_land_xy(self, est: Estimate, dt: float, speed_xy: float, accel_xy: float) -> bool:
        """Horizontal part of landing: precision landing when the target is acquired,
        else hold (with pilot repositioning). Returns whether precision landing runs."""
        p = self.params
        poscon = self._poscon
        pl = self.precland
        if pl.acquired and pl.target_ne is not None:
            cy, sy = math.cos(est.yaw), math.sin(est.yaw)
            ox, oy = p.get("PLND_LAND_OFS_X") / 100.0, p.get("PLND_LAND_OFS_Y") / 100.0
            tn = pl.target_ne[0] + ox * cy - oy * sy
            te = pl.target_ne[1] + ox * sy + oy * cy
            poscon.xy.to_position(tn, te, speed_xy, p.get("PSC_POSXY_P"), accel_xy, dt)
            return True
        fwd = -self._stick(2) * p.get("LOIT_SPEED") / 100.0
        right = self._stick(1) * p.get("LOIT_SPEED") / 100.0
        cy, sy = math.cos(est.yaw), math.sin(est.yaw)
        poscon.xy.to_velocity(fwd * cy - right * sy, fwd * sy + right * cy, accel_xy, dt)
        return False

    def _land_controllers(
        self, est: Estimate, dt: float, speed_xy: float, accel_xy: float, pause: bool
    ) -> None:
        """Mode::run_land_controllers: horizontal hold or precision, vertical descent."""
        precision = self._run_land_xy(est, dt, speed_xy, accel_xy)
        descent = 0.0 if pause else self._land_descent(est, precision)
        self._poscon.z.to_velocity(descent, self.params.get("WPNAV_ACCEL_Z") / 100.0, dt)

    def _run_land_phase(self, est: Estimate, dt: float, speed_xy: float, accel_xy: float) -> None:
        """Mode::land_run_normal_or_precland: with PLND_ENABLED the precision-landing
        state machine decides (descend, retry elsewhere, or its failsafe hold)."""
        p = self.params
        pl = self.precland
        if not pl.param_enabled:
            self._land_controllers(est, dt, speed_xy, accel_xy, pause=False)
            return
        status, retry = self._plnd_sm.update(
            pl,
            self.time_s,
            est.position_ned,
            int(p.get("PLND_STRICT")),
            p.get("PLND_TIMEOUT"),
            int(p.get("PLND_RET_MAX")),
            int(p.get("PLND_RET_BEHAVE")),
        )
        if status == RETRYING and retry is not None:
            poscon = self._poscon
            poscon.xy.to_position(retry[0], retry[1], speed_xy, p.get("PSC_POSXY_P"), accel_xy, dt)
            poscon.z.to_position(
                retry[2],
                p.get("WPNAV_SPEED_DN") / 100.0,
                p.get("WPNAV_SPEED_UP") / 100.0,
                p.get("PSC_POSZ_P"),
                p.get("WPNAV_ACCEL_Z") / 100.0,
                dt,
            )
            return
        hold = status == FAILSAFE and (
            self._plnd_sm.failsafe_action(pl, self.time_s, int(p.get("PLND_STRICT"))) == HOLD_POS
        )
        self._land_controllers(est, dt, speed_xy, accel_xy, pause=hold)

    def _run_land(self, est: Estimate, dt: float, speed_xy: float, accel_xy: float) -> None:
        self._run_land_phase(est, dt, speed_xy, accel_xy)
        self._yaw_t = wrap_pi(
            self._yaw_t + self._stick(4) * math.radians(self.params.get("PILOT_Y_RATE")) * dt
        )

    def _run_rtl(self, est: Estimate, dt: float, speed_xy: float, accel_xy: float) -> None:
        p = self.params
        poscon = self._poscon
        acc_z = p.get("WPNAV_ACCEL_Z") / 100.0
        up = p.get("WPNAV_SPEED_UP") / 100.0
        dn = p.get("WPNAV_SPEED_DN") / 100.0
        speed = (p.get("RTL_SPEED") / 100.0) or speed_xy
        state = self._rtl_state
        hn, he, hd = self.home_ned  # RTL returns to home (where it armed), not the origin
        alt_now = hd - est.position_ned[2]
        if state == "climb":
            target_alt = max(p.get("RTL_ALT") / 100.0, alt_now + p.get("RTL_CLIMB_MIN") / 100.0)
            self._rtl_alt = target_alt
            self._rtl_state = state = "return"
        if state == "return":
            target_alt = self._rtl_alt
            poscon.z.to_position(hd - target_alt, dn, up, p.get("PSC_POSZ_P"), acc_z, dt)
            climbed = alt_now > target_alt - 1.0 or abs(poscon.z.pos - (hd - target_alt)) < 0.5
            if climbed:
                poscon.xy.to_position(hn, he, speed, p.get("PSC_POSXY_P"), accel_xy, dt)
            else:
                poscon.xy.to_velocity(0.0, 0.0, accel_xy, dt)
            near = math.hypot(poscon.xy.pos[0] - hn, poscon.xy.pos[1] - he) < 0.05
            if near and math.hypot(*poscon.xy.vel) < 0.05:
                self._rtl_state = "loiter"
                self._rtl_t = self.time_s
        elif state == "loiter":
            poscon.xy.to_position(hn, he, speed, p.get("PSC_POSXY_P"), accel_xy, dt)
            poscon.z.to_velocity(0.0, acc_z, dt)
            if self.time_s - self._rtl_t >= p.get("RTL_LOIT_TIME") / 1000.0:
                final = p.get("RTL_ALT_FINAL") / 100.0
                self._rtl_state = "final" if final > 0 else "land"
                self._plnd_sm.init()
        elif state == "final":
            final = p.get("RTL_ALT_FINAL") / 100.0
            poscon.xy.to_position(hn, he, speed, p.get("PSC_POSXY_P"), accel_xy, dt)
            poscon.z.to_position(hd - final, dn, up, p.get("PSC_POSZ_P"), acc_z, dt)
        else:  # land, as LAND mode does (precision landing included)
            self._run_land_phase(est, dt, speed_xy, accel_xy)

    @property
    def rtl_state(self) -> str | None:
        """RTL phase ("return", "loiter", "final", "land") or None outside RTL."""
        return self._rtl_state if self.mode == RTL else None
