"""MAVLink messages that describe the simulated vehicle, as ArduCopter fills them in."""

from __future__ import annotations

import math
import random
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim.vehicle.autopilot import SimVehicle
from sim.vehicle.physics import GRAVITY, euler_from_quat, ned_to_body

MAVLinkMessage = mavlink.MAVLink_message

# REQUEST_DATA_STREAM groups, as GCS_MAVLink_Copter assigns messages to streams.
STREAM_GROUPS: dict[int, tuple[str, ...]] = {
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: ("SYS_STATUS", "GPS_RAW_INT"),
    mavlink.MAV_DATA_STREAM_RC_CHANNELS: ("SERVO_OUTPUT_RAW", "RC_CHANNELS"),
    mavlink.MAV_DATA_STREAM_POSITION: ("GLOBAL_POSITION_INT", "LOCAL_POSITION_NED"),
    mavlink.MAV_DATA_STREAM_EXTRA1: ("ATTITUDE",),
    mavlink.MAV_DATA_STREAM_EXTRA2: ("VFR_HUD",),
    mavlink.MAV_DATA_STREAM_EXTRA3: (
        "SYSTEM_TIME",
        "RANGEFINDER",
        "DISTANCE_SENSOR",
        "BATTERY_STATUS",
        "EKF_STATUS_REPORT",
    ),
}

# ArduCopter 4.5.6, official release: major << 24 | minor << 16 | patch << 8 | type.
FLIGHT_SW_VERSION = (4 << 24) | (5 << 16) | (6 << 8) | mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
)

_SENSORS = (
    mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | mavlink.MAV_SYS_STATUS_SENSOR_GPS
    | mavlink.MAV_SYS_STATUS_SENSOR_LASER_POSITION
    | mavlink.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | mavlink.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    | mavlink.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | mavlink.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
    | mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | mavlink.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
    | mavlink.MAV_SYS_STATUS_AHRS
    | mavlink.MAV_SYS_STATUS_SENSOR_BATTERY
    | mavlink.MAV_SYS_STATUS_PREARM_CHECK
)


class TelemetryBuilder:
    """Builds each supported message from the vehicle's estimate, with GPS noise."""

    def __init__(self, sim: SimVehicle, mav: mavlink.MAVLink, seed: int) -> None:
        self.sim = sim
        self.mav = mav
        self._rng = random.Random(f"visland-telemetry-{seed}")
        self._builders: dict[str, Callable[[], MAVLinkMessage | None]] = {
            "HEARTBEAT": self.heartbeat,
            "SYS_STATUS": self.sys_status,
            "GPS_RAW_INT": self.gps_raw_int,
            "ATTITUDE": self.attitude,
            "GLOBAL_POSITION_INT": self.global_position_int,
            "LOCAL_POSITION_NED": self.local_position_ned,
            "VFR_HUD": self.vfr_hud,
            "SYSTEM_TIME": self.system_time,
            "RANGEFINDER": self.rangefinder,
            "DISTANCE_SENSOR": self.distance_sensor,
            "BATTERY_STATUS": self.battery_status,
            "EKF_STATUS_REPORT": self.ekf_status_report,
            "RC_CHANNELS": self.rc_channels,
            "SERVO_OUTPUT_RAW": self.servo_output_raw,
            "HOME_POSITION": self.home_position,
            "AUTOPILOT_VERSION": self.autopilot_version,
            "SIM_STATE": self.sim_state,
            "GPS_GLOBAL_ORIGIN": self.gps_global_origin,
        }

    @property
    def names(self) -> frozenset[str]:
        """Message names this builder can produce."""
        return frozenset(self._builders)

    def build(self, name: str) -> MAVLinkMessage | None:
        """The message ``name`` now, or None when the vehicle has nothing to say yet."""
        return self._builders[name]()

    # -- individual messages -------------------------------------------------------
    def heartbeat(self) -> MAVLinkMessage:
        sim = self.sim
        # As GCS_MAVLINK_Copter::base_mode(): SITL reports 81 disarmed in STABILIZE.
        base = (
            mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
            | mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        )
        if sim.mode in (3, 4, 5, 6, 7, 16, 17, 19, 21, 23, 27):
            base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
        if sim.armed:
            base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        status = mavlink.MAV_STATE_ACTIVE if sim.armed else mavlink.MAV_STATE_STANDBY
        if sim.boot_s < sim._t(1.0):
            status = mavlink.MAV_STATE_BOOT
        return self.mav.heartbeat_encode(
            mavlink.MAV_TYPE_QUADROTOR,
            mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
            base,
            sim.mode,
            status,
        )

    def sys_status(self) -> MAVLinkMessage:
        sim = self.sim
        present = _SENSORS
        if sim.params.get("RNGFND1_TYPE") == 0:
            present &= ~mavlink.MAV_SYS_STATUS_SENSOR_LASER_POSITION
        health = present
        if not sim.gps_fix:
            health &= ~mavlink.MAV_SYS_STATUS_SENSOR_GPS
        if sim.boot_s < sim._t(4.0):
            health &= ~mavlink.MAV_SYS_STATUS_AHRS
        if sim.rangefinder_m() is None:
            health &= ~mavlink.MAV_SYS_STATUS_SENSOR_LASER_POSITION
        if not (sim.armed or sim.prearm_ok):
            health &= ~mavlink.MAV_SYS_STATUS_PREARM_CHECK
        return self.mav.sys_status_encode(
            present,
            present,
            health,
            150,
            round(sim.battery_voltage * 1000),
            round(sim.battery_current_a * 100),
            sim.battery_remaining,
            0,
            0,
            0,
            0,
            0,
            0,
        )

    def gps_raw_int(self) -> MAVLinkMessage:
        sim = self.sim
        t = sim.truth
        fix = sim.gps_fix
        n = t.position_ned[0] + self._rng.gauss() * 0.3
        e = t.position_ned[1] + self._rng.gauss() * 0.3
        d = t.position_ned[2] + self._rng.gauss() * 0.5
        lat, lon, alt = sim.ned_to_global(n, e, d)
        vn, ve = t.velocity_ned[0], t.velocity_ned[1]
        cog = math.degrees(math.atan2(ve, vn)) % 360.0
        return self.mav.gps_raw_int_encode(
            round(sim.boot_s * 1e6),
            mavlink.GPS_FIX_TYPE_3D_FIX if fix else mavlink.GPS_FIX_TYPE_NO_FIX,
            round(lat * 1e7) if fix else 0,
            round(lon * 1e7) if fix else 0,
            round(alt * 1000) if fix else 0,
            121 if fix else 9999,
            200 if fix else 9999,
            round(math.hypot(vn, ve) * 100) if fix else 0,
            round(cog * 100) if fix else 0,
            10 if fix else 0,
        )

    def attitude(self) -> MAVLinkMessage:
        sim = self.sim
        est = sim.estimate
        return self.mav.attitude_encode(
            sim.time_boot_ms,
            est.roll,
            est.pitch,
            est.yaw,
            est.rates[0],
            est.rates[1],
            est.rates[2],
        )

    def global_position_int(self) -> MAVLinkMessage:
        sim = self.sim
        est = sim.estimate
        heading = round(math.degrees(est.yaw) % 360.0 * 100)
        if not sim.origin_set:
            return self.mav.global_position_int_encode(
                sim.time_boot_ms, 0, 0, 0, 0, 0, 0, 0, heading
            )
        n, e, d = est.position_ned
        lat, lon, alt = sim.ned_to_global(n, e, d)
        vn, ve, vd = est.velocity_ned
        return self.mav.global_position_int_encode(
            sim.time_boot_ms,
            round(lat * 1e7),
            round(lon * 1e7),
            round(alt * 1000),
            round((sim.home_ned[2] - d) * 1000),  # relative to home, which moves on arming
            round(vn * 100),
            round(ve * 100),
            round(vd * 100),
            heading,
        )

    def local_position_ned(self) -> MAVLinkMessage | None:
        sim = self.sim
        # ArduPilot sends it only while the EKF has a horizontal position (GPS ~41.5 s
        # after boot, or ExternalNav), not from the origin being set.
        if not sim.position_ok:
            return None
        est = sim.estimate
        n, e, d = est.position_ned
        vn, ve, vd = est.velocity_ned
        return self.mav.local_position_ned_encode(sim.time_boot_ms, n, e, d, vn, ve, vd)

    def vfr_hud(self) -> MAVLinkMessage:
        sim = self.sim
        est = sim.estimate
        t = sim.truth
        vn, ve, vd = est.velocity_ned
        w = sim.body.wind_now
        airspeed = math.hypot(t.velocity_ned[0] - w[0], t.velocity_ned[1] - w[1])
        alt = sim.config.home_alt - est.position_ned[2]
        return self.mav.vfr_hud_encode(
            airspeed,
            math.hypot(vn, ve),
            round(math.degrees(est.yaw) % 360.0) % 360,
            round(sim.throttle_fraction * 100),
            alt,
            -vd,
        )

    def system_time(self) -> MAVLinkMessage:
        sim = self.sim
        # A fixed, plausible UNIX epoch plus sim time: deterministic, never wall time.
        unix_us = 1_763_800_000_000_000 + round(sim.time_s * 1e6) if sim.gps_fix else 0
        return self.mav.system_time_encode(unix_us, sim.time_boot_ms)

    def rangefinder(self) -> MAVLinkMessage | None:
        if self.sim.params.get("RNGFND1_TYPE") == 0:
            return None  # no rangefinder, no message
        dist = self.sim.rangefinder_m()
        d = 0.0 if dist is None else dist + self._rng.gauss() * 0.01
        return self.mav.rangefinder_encode(max(0.0, d), max(0.0, d) / 10.0)

    def distance_sensor(self) -> MAVLinkMessage | None:
        sim = self.sim
        p = sim.params
        if p.get("RNGFND1_TYPE") == 0:
            return None
        dist = sim.rangefinder_m()
        max_cm = int(p.get("RNGFND1_MAX_CM"))
        cm = max_cm + 1 if dist is None else round((dist + self._rng.gauss() * 0.01) * 100)
        return self.mav.distance_sensor_encode(
            sim.time_boot_ms,
            int(p.get("RNGFND1_MIN_CM")),
            max_cm,
            max(0, min(65535, cm)),
            mavlink.MAV_DISTANCE_SENSOR_LASER,
            0,
            int(p.get("RNGFND1_ORIENT")),
            0,
            signal_quality=0 if dist is None else 100,
        )

    def battery_status(self) -> MAVLinkMessage:
        sim = self.sim
        cells = [65535] * 10
        cells[0] = round(sim.battery_voltage * 1000)
        return self.mav.battery_status_encode(
            0,
            mavlink.MAV_BATTERY_FUNCTION_UNKNOWN,
            mavlink.MAV_BATTERY_TYPE_UNKNOWN,
            32767,
            cells,
            round(sim.battery_current_a * 100),
            round(sim.battery_mah_used),
            round(sim.battery_mah_used * 11.1 * 3.6 / 100),
            sim.battery_remaining,
        )

    def ekf_status_report(self) -> MAVLinkMessage:
        sim = self.sim
        flags = 0
        if sim.boot_s >= sim._t(4.0):
            flags |= (
                mavlink.EKF_ATTITUDE
                | mavlink.EKF_VELOCITY_VERT
                | mavlink.EKF_POS_VERT_ABS
                | mavlink.EKF_POS_VERT_AGL
            )
        if sim.position_ok:
            flags |= (
                mavlink.EKF_VELOCITY_HORIZ
                | mavlink.EKF_POS_HORIZ_REL
                | mavlink.EKF_POS_HORIZ_ABS
                | mavlink.EKF_PRED_POS_HORIZ_REL
                | mavlink.EKF_PRED_POS_HORIZ_ABS
            )
        else:
            flags |= mavlink.EKF_CONST_POS_MODE
        return self.mav.ekf_status_report_encode(flags, 0.02, 0.01, 0.02, 0.03, 0.0, 0.0)

    def rc_channels(self) -> MAVLinkMessage:
        sim = self.sim
        ch = [*sim.rc_channels(), 0, 0]
        return self.mav.rc_channels_encode(sim.time_boot_ms, 16, *ch[:18], 255)

    def servo_output_raw(self) -> MAVLinkMessage:
        sim = self.sim
        pwm = [round(1000 + 1000 * c) if sim.armed else 1000 for c in sim._motor_cmd]
        return self.mav.servo_output_raw_encode(
            round(sim.boot_s * 1e6) & 0xFFFFFFFF, 0, *pwm, 0, 0, 0, 0
        )

    def home_position(self) -> MAVLinkMessage | None:
        sim = self.sim
        if not sim.home_set:
            return None
        n, e, d = sim.home_ned
        lat, lon, alt = sim.ned_to_global(n, e, d)
        return self.mav.home_position_encode(
            round(lat * 1e7),
            round(lon * 1e7),
            round(alt * 1000),
            n,
            e,
            d,
            (1.0, 0.0, 0.0, 0.0),
            0.0,
            0.0,
            0.0,
            time_usec=round(sim.boot_s * 1e6),
        )

    def autopilot_version(self) -> MAVLinkMessage:
        return self.mav.autopilot_version_encode(
            CAPABILITIES,
            FLIGHT_SW_VERSION,
            0,
            0,
            0,
            list(b"v1sland0"),
            [0] * 8,
            [0] * 8,
            0x1209,
            0x5740,
            0,
        )

    def sim_state(self) -> MAVLinkMessage:
        """The simulator's truth, filled in as ArduPilot SITL does (lat/lon in degE7,
        also in the float fields; alt AMSL; accelerations in the body frame)."""
        sim = self.sim
        b = sim.body
        roll, pitch, yaw = euler_from_quat(b.quat)
        lat, lon, alt = sim.ned_to_global(*b.pos)
        acc = ned_to_body(b.quat, (b.accel[0], b.accel[1], b.accel[2] - GRAVITY))
        q = b.quat
        return self.mav.sim_state_encode(
            q[0],
            q[1],
            q[2],
            q[3],
            roll,
            pitch,
            yaw,
            acc[0],
            acc[1],
            acc[2],
            b.rates[0],
            b.rates[1],
            b.rates[2],
            lat * 1e7,
            lon * 1e7,
            alt,
            0.0,
            0.0,
            b.vel[0],
            b.vel[1],
            b.vel[2],
            round(lat * 1e7),
            round(lon * 1e7),
        )

    def gps_global_origin(self) -> MAVLinkMessage | None:
        """The EKF origin (where the vehicle booted), once set."""
        sim = self.sim
        if not sim.origin_set:
            return None
        c = sim.config
        return self.mav.gps_global_origin_encode(
            round(c.home_lat * 1e7),
            round(c.home_lon * 1e7),
            round(c.home_alt * 1000),
            round(sim.boot_s * 1e6),
        )
