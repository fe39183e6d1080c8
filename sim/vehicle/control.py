"""ArduCopter-style controllers: kinematic target shaping, position/velocity loops,
attitude loop with rate loop, and the motor mixer.

The structure follows AC_PosControl / AC_AttitudeControl: a shaped target (position,
velocity) moves toward the goal within speed and acceleration limits, the vehicle
tracks the target with P on position, PID on velocity, the acceleration becomes lean
angles and collective thrust, a square-root angle controller feeds a rate loop.
"""

from __future__ import annotations

import math

from sim.vehicle.physics import (
    GRAVITY,
    MOTORS,
    Airframe,
    Quat,
    Vec3,
    quat_from_euler,
    quat_mul,
)


def sqrt_controller(error: float, p: float, accel_max: float) -> float:
    """ArduPilot's square-root controller: linear near zero, sqrt(2 a e) further out,
    so that a target approached at the returned speed can stop within ``accel_max``."""
    if accel_max <= 0.0 or p <= 0.0:
        return error * p
    linear = accel_max / (p * p)
    if error > linear:
        return math.sqrt(2.0 * accel_max * (error - linear / 2.0))
    if error < -linear:
        return -math.sqrt(2.0 * accel_max * (-error - linear / 2.0))
    return error * p


def wrap_pi(angle: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


class Shaper1D:
    """A target (position, velocity) moved toward a goal with speed/accel limits."""

    def __init__(self) -> None:
        self.pos = 0.0
        self.vel = 0.0

    def reset(self, pos: float, vel: float = 0.0) -> None:
        self.pos, self.vel = pos, vel

    def to_velocity(self, vel_goal: float, accel: float, dt: float) -> None:
        """Move the target velocity toward ``vel_goal`` within ``accel``; integrate."""
        dv = vel_goal - self.vel
        step = accel * dt
        self.vel += max(-step, min(step, dv))
        self.pos += self.vel * dt

    def to_position(
        self, goal: float, speed_pos: float, speed_neg: float, p: float, accel: float, dt: float
    ) -> None:
        """Move toward ``goal`` at most ``speed_pos`` (positive direction) or
        ``speed_neg`` (negative direction, a positive number) and stop on it."""
        want = sqrt_controller(goal - self.pos, p, accel)
        want = max(-speed_neg, min(speed_pos, want))
        self.to_velocity(want, accel, dt)


class Shaper2D:
    """Horizontal (north, east) target with a speed limit on the vector's length."""

    def __init__(self) -> None:
        self.pos = [0.0, 0.0]
        self.vel = [0.0, 0.0]
        self.acc = [0.0, 0.0]  # feed-forward for the velocity loop

    def reset(self, n: float, e: float, vn: float = 0.0, ve: float = 0.0) -> None:
        self.pos = [n, e]
        self.vel = [vn, ve]
        self.acc = [0.0, 0.0]

    def to_velocity(self, vn: float, ve: float, accel: float, dt: float) -> None:
        dn, de = vn - self.vel[0], ve - self.vel[1]
        mag = math.hypot(dn, de)
        step = accel * dt
        if mag > step:
            dn, de = dn * step / mag, de * step / mag
        self.vel[0] += dn
        self.vel[1] += de
        if dt > 0:
            self.acc = [dn / dt, de / dt]
        self.pos[0] += self.vel[0] * dt
        self.pos[1] += self.vel[1] * dt

    def to_position(
        self, n: float, e: float, speed: float, p: float, accel: float, dt: float
    ) -> None:
        en, ee = n - self.pos[0], e - self.pos[1]
        dist = math.hypot(en, ee)
        if dist < 1e-9:
            self.to_velocity(0.0, 0.0, accel, dt)
            return
        v = min(speed, sqrt_controller(dist, p, accel))
        self.to_velocity(v * en / dist, v * ee / dist, accel, dt)


class PositionController:
    """Tracks the shaped targets: returns desired NED acceleration."""

    def __init__(self) -> None:
        self.xy = Shaper2D()
        self.z = Shaper1D()
        self.int_xy = [0.0, 0.0]
        self.int_z = 0.0
        self._prev_verr: list[float] | None = None
        self._d_xy = [0.0, 0.0]

    def reset(self, pos: Vec3, vel: Vec3) -> None:
        """Start the targets where the vehicle is, as ArduCopter does on a mode change."""
        self.xy.reset(pos[0], pos[1], vel[0], vel[1])
        self.z.reset(pos[2], vel[2])
        self.int_xy = [0.0, 0.0]
        self._prev_verr = None
        self._d_xy = [0.0, 0.0]

    def reset_z_integrator(self) -> None:
        self.int_z = 0.0

    def accel_xy(
        self, pos: Vec3, vel: Vec3, gains: dict[str, float], accel_max: float, dt: float
    ) -> tuple[float, float]:
        """NE acceleration demand to follow the xy target."""
        out = []
        verrs = [
            self.xy.vel[i] + gains["pos_p"] * (self.xy.pos[i] - pos[i]) - vel[i] for i in range(2)
        ]
        prev = self._prev_verr or verrs
        # Derivative of the velocity error through a 5 Hz low-pass (PSC_VELXY_FLTD).
        alpha = dt / (dt + 1 / (2 * math.pi * 5.0)) if dt > 0 else 0.0
        for i in range(2):
            verr = verrs[i]
            d_raw = (verr - prev[i]) / dt if dt > 0 else 0.0
            self._d_xy[i] += alpha * (d_raw - self._d_xy[i])
            self.int_xy[i] += gains["vel_i"] * verr * dt
            self.int_xy[i] = max(-3.0, min(3.0, self.int_xy[i]))
            a = self.xy.acc[i] + gains["vel_p"] * verr + self.int_xy[i]
            out.append(a + gains["vel_d"] * self._d_xy[i])
        self._prev_verr = verrs
        mag = math.hypot(out[0], out[1])
        if mag > accel_max:
            out = [out[0] * accel_max / mag, out[1] * accel_max / mag]
        return out[0], out[1]

    def accel_z(
        self, pos_d: float, vel_d: float, gains: dict[str, float], dt: float, frozen: bool
    ) -> float:
        """Down acceleration demand to follow the z target (NED: negative is up)."""
        v_cmd = self.z.vel + gains["pos_p"] * (self.z.pos - pos_d)
        verr = v_cmd - vel_d
        if not frozen:
            self.int_z += gains["vel_i"] * verr * dt
            self.int_z = max(-4.0, min(4.0, self.int_z))
        return gains["vel_p"] * verr + self.int_z


def lean_from_accel(an: float, ae: float, yaw: float, angle_max: float) -> tuple[float, float]:
    """Roll and pitch (rad) that produce a horizontal acceleration, as ArduCopter does."""
    fwd = an * math.cos(yaw) + ae * math.sin(yaw)
    right = -an * math.sin(yaw) + ae * math.cos(yaw)
    pitch = math.atan(-fwd / GRAVITY)
    roll = math.atan(right * math.cos(pitch) / GRAVITY)
    # Keep the total tilt within angle_max, preserving direction.
    tilt = math.hypot(roll, pitch)
    if tilt > angle_max:
        roll, pitch = roll * angle_max / tilt, pitch * angle_max / tilt
    return roll, pitch


class AttitudeController:
    """Angle P (square-root) controller feeding a rate loop; outputs body torques."""

    def __init__(self, airframe: Airframe) -> None:
        self.af = airframe
        self.rate_int = [0.0, 0.0, 0.0]

    def reset(self) -> None:
        self.rate_int = [0.0, 0.0, 0.0]

    def torques(
        self,
        q: Quat,
        rates: Vec3,
        roll_t: float,
        pitch_t: float,
        yaw_t: float,
        yaw_rate_ff: float,
        angle_p: float,
        accel_max_rp: float,
        accel_max_y: float,
        dt: float,
        integrate: bool,
    ) -> Vec3:
        """Body torques (N m) that turn the vehicle toward (roll_t, pitch_t, yaw_t)."""
        qt = quat_from_euler(roll_t, pitch_t, yaw_t)
        w, x, y, z = q
        qe = quat_mul((w, -x, -y, -z), qt)  # rotation from current to target, body frame
        if qe[0] < 0:
            qe = (-qe[0], -qe[1], -qe[2], -qe[3])
        s = math.sqrt(qe[1] ** 2 + qe[2] ** 2 + qe[3] ** 2)
        if s > 1e-9:
            angle = 2 * math.atan2(s, qe[0])
            err = (qe[1] / s * angle, qe[2] / s * angle, qe[3] / s * angle)
        else:
            err = (0.0, 0.0, 0.0)
        limits = (accel_max_rp, accel_max_rp, accel_max_y)
        rate_t = [sqrt_controller(err[i], angle_p, limits[i]) for i in range(3)]
        # Yaw rate feed-forward expressed in the body frame (small-angle approximation).
        rate_t[2] += yaw_rate_ff
        inertia = (self.af.ixx, self.af.iyy, self.af.izz)
        kp = (28.0, 28.0, 14.0)
        ki = (8.0, 8.0, 4.0)
        out = []
        for i in range(3):
            e = rate_t[i] - rates[i]
            if integrate:
                self.rate_int[i] = max(-5.0, min(5.0, self.rate_int[i] + ki[i] * e * dt))
            out.append(inertia[i] * (kp[i] * e + self.rate_int[i]))
        return out[0], out[1], out[2]


def mix(airframe: Airframe, collective: float, torques: Vec3, min_frac: float) -> list[float]:
    """Motor commands (fraction of full thrust) for a collective thrust (N) and body
    torques, keeping roll/pitch authority first, as ArduCopter's mixer does."""
    per_max = airframe.max_thrust_total / 4
    arm = airframe.arm
    tx, ty, tz = torques
    # Positions are arm*(+-1/sqrt2): sum(y^2) = 2 arm^2, so the roll share is -y tx/(2 arm^2).
    rp = [(-my * tx + mx * ty) / (2 * arm) for mx, my, _ in MOTORS]
    yaw = [spin * tz / (4 * airframe.yaw_coeff) for _, _, spin in MOTORS]
    base = collective / 4
    lo, hi = min_frac * per_max, per_max
    # Yaw gets what headroom is left after roll/pitch around the collective.
    rp_hi = max(rp)
    rp_lo = min(rp)
    room = max(0.0, min(hi - (base + rp_hi), (base + rp_lo) - lo))
    ymax = max(abs(v) for v in yaw)
    if ymax > room and ymax > 0:
        scale = max(0.0, room) / ymax
        # Never scale yaw below a quarter: a little yaw authority beats none.
        scale = max(scale, 0.25) if room > 0 else 0.0
        yaw = [v * scale for v in yaw]
    cmds = [base + rp[i] + yaw[i] for i in range(4)]
    top, bottom = max(cmds), min(cmds)
    if top > hi:
        shift = top - hi
        cmds = [c - shift for c in cmds]
    elif bottom < lo:
        shift = lo - bottom
        cmds = [c + shift for c in cmds]
    return [min(1.0, max(min_frac, c / per_max)) for c in cmds]
