"""Rigid-body quadrotor, motors, wind and ground contact (no autopilot, no I/O).

Frames: NED world (x north, y east, z down, origin at home on the ground) and FRD
body (x forward, y right, z down). Quaternions are (w, x, y, z), body -> NED.
Written with plain floats: at 400 Hz per step a handful of 3-vectors is much cheaper
in pure Python than in numpy.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

GRAVITY = 9.80665

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def quat_from_euler(roll: float, pitch: float, yaw: float) -> Quat:
    """Quaternion (w, x, y, z) of a ZYX (yaw, pitch, roll) rotation, body -> NED."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )


def euler_from_quat(q: Quat) -> Vec3:
    """(roll, pitch, yaw) in radians of a body -> NED quaternion; yaw in (-pi, pi]."""
    w, x, y, z = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def quat_mul(a: Quat, b: Quat) -> Quat:
    """Hamilton product a * b."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def rotation_matrix(q: Quat) -> tuple[Vec3, Vec3, Vec3]:
    """Rows of the body -> NED rotation matrix of ``q``."""
    w, x, y, z = q
    return (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def body_to_ned(q: Quat, v: Vec3) -> Vec3:
    """Rotate a body-frame vector into NED."""
    r0, r1, r2 = rotation_matrix(q)
    return (
        r0[0] * v[0] + r0[1] * v[1] + r0[2] * v[2],
        r1[0] * v[0] + r1[1] * v[1] + r1[2] * v[2],
        r2[0] * v[0] + r2[1] * v[1] + r2[2] * v[2],
    )


def ned_to_body(q: Quat, v: Vec3) -> Vec3:
    """Rotate a NED vector into the body frame."""
    r0, r1, r2 = rotation_matrix(q)
    return (
        r0[0] * v[0] + r1[0] * v[1] + r2[0] * v[2],
        r0[1] * v[0] + r1[1] * v[1] + r2[1] * v[2],
        r0[2] * v[0] + r1[2] * v[1] + r2[2] * v[2],
    )


@dataclass(frozen=True)
class Airframe:
    """A 1.5 kg quad in X configuration, roughly SITL's default copter."""

    mass: float = 1.5
    arm: float = 0.25  # motor distance from the centre, m
    ixx: float = 0.015
    iyy: float = 0.015
    izz: float = 0.026
    hover_throttle: float = 0.39  # fraction of full thrust that hovers (MOT_THST_HOVER)
    motor_tau: float = 0.025  # first-order motor lag, s
    yaw_coeff: float = 0.016  # reaction torque per newton of thrust, m
    drag_linear: float = 0.15  # rotor drag, N per m/s of airspeed
    drag_quad: float = 0.04  # body drag, N per (m/s)^2
    rot_damping: float = 0.003  # N m per rad/s

    @property
    def max_thrust_total(self) -> float:
        """Thrust of all four motors at full throttle, N."""
        return self.mass * GRAVITY / self.hover_throttle


# Motor positions (x forward, y right) and spin sense (+1: reaction torque is +yaw).
# ArduCopter X quad: 1 front-right CCW, 2 back-left CCW, 3 front-left CW, 4 back-right CW.
_D = 1 / math.sqrt(2)
MOTORS: tuple[tuple[float, float, float], ...] = (
    (_D, _D, 1.0),
    (-_D, -_D, 1.0),
    (_D, -_D, -1.0),
    (-_D, _D, -1.0),
)


class Wind:
    """Mean wind plus gusts: first-order (Dryden-like) filtered noise on each axis."""

    def __init__(self, speed: float, from_deg: float, gust_std: float, rng: random.Random) -> None:
        heading = math.radians(from_deg)
        # Wind *from* the north blows towards the south: velocity points away from it.
        self.mean: Vec3 = (-speed * math.cos(heading), -speed * math.sin(heading), 0.0)
        self.gust_std = gust_std
        self.tau = 2.0  # gust correlation time, s (length scale / airspeed)
        self._gust = [0.0, 0.0, 0.0]
        self._rng = rng

    def step(self, dt: float) -> Vec3:
        """Advance the gust process by ``dt`` and return the wind velocity (NED, m/s)."""
        if self.gust_std > 0.0:
            a = math.exp(-dt / self.tau)
            b = math.sqrt(1 - a * a)
            for i, scale in enumerate((1.0, 1.0, 0.3)):
                self._gust[i] = a * self._gust[i] + b * self.gust_std * scale * self._rng.gauss()
        return (
            self.mean[0] + self._gust[0],
            self.mean[1] + self._gust[1],
            self.mean[2] + self._gust[2],
        )


class QuadBody:
    """State and dynamics of the airframe: motors with lag, drag, wind, ground contact."""

    def __init__(self, airframe: Airframe, wind: Wind, yaw: float = 0.0) -> None:
        self.af = airframe
        self.wind = wind
        self.pos: Vec3 = (0.0, 0.0, 0.0)
        self.vel: Vec3 = (0.0, 0.0, 0.0)
        self.accel: Vec3 = (0.0, 0.0, 0.0)  # last kinematic NED acceleration, m/s^2
        self.quat: Quat = quat_from_euler(0.0, 0.0, yaw)
        self.rates: Vec3 = (0.0, 0.0, 0.0)
        self.thrusts = [0.0, 0.0, 0.0, 0.0]
        self.on_ground = True
        self.wind_now: Vec3 = (0.0, 0.0, 0.0)
        self.last_impact_speed: float | None = None  # set on touchdown, read and cleared

    @property
    def total_thrust(self) -> float:
        """Sum of motor thrusts, N."""
        return sum(self.thrusts)

    def step(self, dt: float, motor_cmd: list[float]) -> None:
        """Advance by ``dt`` seconds with motor commands in [0, 1] of full thrust."""
        af = self.af
        per_motor_max = af.max_thrust_total / 4
        k = min(1.0, dt / af.motor_tau)
        thr = self.thrusts
        for i in range(4):
            target = min(1.0, max(0.0, motor_cmd[i])) * per_motor_max
            thr[i] += (target - thr[i]) * k
        total = thr[0] + thr[1] + thr[2] + thr[3]

        q = self.quat
        r0, r1, r2 = rotation_matrix(q)
        self.wind_now = self.wind.step(dt)
        vx, vy, vz = self.vel
        ax_rel, ay_rel, az_rel = (
            vx - self.wind_now[0],
            vy - self.wind_now[1],
            vz - self.wind_now[2],
        )
        speed = math.sqrt(ax_rel * ax_rel + ay_rel * ay_rel + az_rel * az_rel)
        drag = af.drag_linear + af.drag_quad * speed
        m = af.mass
        # Thrust acts along -z body: its NED direction is minus the third column of R.
        ax = (-total * r0[2] - drag * ax_rel) / m
        ay = (-total * r1[2] - drag * ay_rel) / m
        az = (-total * r2[2] - drag * az_rel) / m + GRAVITY

        # Torques from the motors: r x F with F = (0, 0, -T) gives (-y T, x T, 0).
        arm = af.arm
        tx = ty = tz = 0.0
        for (mx, my, spin), t in zip(MOTORS, thr, strict=True):
            tx -= my * arm * t
            ty += mx * arm * t
            tz += spin * af.yaw_coeff * t
        p, qr, r = self.rates
        tx -= af.rot_damping * p
        ty -= af.rot_damping * qr
        tz -= af.rot_damping * r
        # Euler's equations with the gyroscopic term w x (I w).
        dp = (tx - (af.izz - af.iyy) * qr * r) / af.ixx
        dq = (ty - (af.ixx - af.izz) * p * r) / af.iyy
        dr = (tz - (af.iyy - af.ixx) * p * qr) / af.izz
        p += dp * dt
        qr += dq * dt
        r += dr * dt

        vx += ax * dt
        vy += ay * dt
        vz += az * dt
        px, py, pz = self.pos
        px += vx * dt
        py += vy * dt
        pz += vz * dt

        # Ground contact at z = 0: no sinking; gear friction and levelling while pressed.
        if pz >= 0.0:
            if not self.on_ground and vz > 0.0:
                self.last_impact_speed = vz
            pz = 0.0
            pressed = az >= -0.05
            if vz > 0.0:
                vz = 0.0
            if pressed:
                self.on_ground = True
                vz = 0.0
                ax = ay = az = 0.0  # the ground's reaction cancels what thrust does not
                decay = max(0.0, 1.0 - 25.0 * dt)
                vx *= decay
                vy *= decay
                roll, pitch, yaw = euler_from_quat(q)
                level = max(0.0, 1.0 - 20.0 * dt)
                q = quat_from_euler(roll * level, pitch * level, yaw)
                p *= level
                qr *= level
                r *= max(0.0, 1.0 - 10.0 * dt)
            else:
                self.on_ground = False
        else:
            self.on_ground = False

        # Integrate the attitude: q' = q + dt/2 * q * (0, w), then renormalise.
        w0, x0, y0, z0 = q
        h = 0.5 * dt
        w1 = w0 + h * (-x0 * p - y0 * qr - z0 * r)
        x1 = x0 + h * (w0 * p + y0 * r - z0 * qr)
        y1 = y0 + h * (w0 * qr - x0 * r + z0 * p)
        z1 = z0 + h * (w0 * r + x0 * qr - y0 * p)
        n = math.sqrt(w1 * w1 + x1 * x1 + y1 * y1 + z1 * z1)
        self.quat = (w1 / n, x1 / n, y1 / n, z1 / n)
        self.rates = (p, qr, r)
        self.vel = (vx, vy, vz)
        self.pos = (px, py, pz)
        self.accel = (ax, ay, az)
