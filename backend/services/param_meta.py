"""What ArduCopter 4.5 documents about the parameters an operator of this station touches.

Units, ranges, choices and whether a reboot is needed, from ArduPilot's parameter
reference (Copter 4.5). Parameters not listed here are still shown and editable: their
value is then checked only against their MAVLink type (an integer type takes whole
numbers within its bounds).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink2


@dataclass(frozen=True)
class ParamMeta:
    """One parameter's documentation: ``low``/``high`` bound the value when known."""

    description: str
    units: str = ""
    low: float | None = None
    high: float | None = None
    values: dict[int, str] = field(default_factory=dict)
    reboot: bool = False


_ONOFF = {0: "Disabled", 1: "Enabled"}
_BATT_FS = {
    0: "None",
    1: "Land",
    2: "RTL",
    3: "SmartRTL or RTL",
    4: "SmartRTL or Land",
    5: "Terminate",
}
_ORIENT = {0: "Forward", 4: "Back", 25: "Down"}

META: dict[str, ParamMeta] = {
    # --- precision landing (AC_PrecLand) ---
    "PLND_ENABLED": ParamMeta("Precision landing enabled", values=_ONOFF, reboot=True),
    "PLND_TYPE": ParamMeta(
        "Precision landing sensor type (read at boot)",
        values={
            0: "None",
            1: "CompanionComputer (MAVLink)",
            2: "IRLock",
            3: "SITL_Gazebo",
            4: "SITL",
        },
        reboot=True,
    ),
    "PLND_EST_TYPE": ParamMeta(
        "Precision landing estimator", values={0: "RawSensor", 1: "KalmanFilter"}
    ),
    "PLND_YAW_ALIGN": ParamMeta("Sensor yaw alignment", "cdeg", 0, 36000),
    "PLND_LAND_OFS_X": ParamMeta("Land offset forward", "cm", -20, 20),
    "PLND_LAND_OFS_Y": ParamMeta("Land offset right", "cm", -20, 20),
    "PLND_CAM_POS_X": ParamMeta("Camera X position offset (forward)", "m", -5, 5),
    "PLND_CAM_POS_Y": ParamMeta("Camera Y position offset (right)", "m", -5, 5),
    "PLND_CAM_POS_Z": ParamMeta("Camera Z position offset (down)", "m", -5, 5),
    "PLND_BUS": ParamMeta("Sensor bus (IRLock only)", low=-1, high=3),
    "PLND_LAG": ParamMeta(
        "Sensor lag: capture to the autopilot receiving the target", "s", 0.02, 0.25, reboot=True
    ),
    "PLND_XY_DIST_MAX": ParamMeta(
        "Largest horizontal distance to the target to descend (0: any)", "m", 0, 10
    ),
    "PLND_STRICT": ParamMeta(
        "When the target is lost",
        values={0: "Land vertically (not strict)", 1: "Retry landing (strict)", 2: "Do not land"},
    ),
    "PLND_RET_MAX": ParamMeta("Landing retries allowed", low=0, high=10),
    "PLND_TIMEOUT": ParamMeta("Target lost after this long", "s", 0, 20),
    "PLND_RET_BEHAVE": ParamMeta(
        "Retry behaviour", values={0: "Go to the last location the target was seen", 1: "Go up"}
    ),
    "PLND_ALT_MIN": ParamMeta("Lowest altitude the target is used from", "m", 0, 5),
    "PLND_ALT_MAX": ParamMeta("Highest altitude the target is used from", "m", 0, 50),
    "PLND_OPTIONS": ParamMeta("Precision landing options (bitmask)", low=0, high=7),
    "PLND_ORIENT": ParamMeta("Camera orientation", values=_ORIENT, reboot=True),
    "PLND_ACC_P_NSE": ParamMeta("Kalman filter accelerometer noise", "m/s/s", 0.5, 5),
    # --- battery (AP_BattMonitor) ---
    "BATT_MONITOR": ParamMeta(
        "Battery monitoring",
        values={0: "Disabled", 3: "Analog voltage only", 4: "Analog voltage and current"},
        reboot=True,
    ),
    "BATT_CAPACITY": ParamMeta("Battery capacity", "mAh", 0, 1000000),
    "BATT_LOW_VOLT": ParamMeta("Low battery voltage (0: off)", "V", 0, 120),
    "BATT_CRT_VOLT": ParamMeta("Critical battery voltage (0: off)", "V", 0, 120),
    "BATT_LOW_MAH": ParamMeta("Low battery capacity left (0: off)", "mAh", 0, 1000000),
    "BATT_CRT_MAH": ParamMeta("Critical battery capacity left (0: off)", "mAh", 0, 1000000),
    "BATT_LOW_TIMER": ParamMeta("Time below the low voltage before the failsafe", "s", 0, 120),
    "BATT_FS_LOW_ACT": ParamMeta("Low battery failsafe action", values=_BATT_FS),
    "BATT_FS_CRT_ACT": ParamMeta("Critical battery failsafe action", values=_BATT_FS),
    # --- external navigation (AP_VisualOdom, EKF3 source sets) ---
    "VISO_TYPE": ParamMeta(
        "Visual odometry camera connection type (read at boot)",
        values={0: "None", 1: "MAVLink", 2: "IntelT265", 3: "VOXL"},
        reboot=True,
    ),
    "VISO_DELAY_MS": ParamMeta("Visual odometry sensor delay", "ms", 0, 250),
    **{
        f"EK3_SRC{n}_POSXY": ParamMeta(
            f"EKF source set {n}: horizontal position",
            values={0: "None", 3: "GPS", 4: "Beacon", 6: "ExternalNav"},
        )
        for n in (1, 2, 3)
    },
    **{
        f"EK3_SRC{n}_VELXY": ParamMeta(
            f"EKF source set {n}: horizontal velocity",
            values={0: "None", 3: "GPS", 4: "Beacon", 5: "OpticalFlow", 6: "ExternalNav"},
        )
        for n in (1, 2, 3)
    },
    **{
        f"EK3_SRC{n}_POSZ": ParamMeta(
            f"EKF source set {n}: vertical position",
            values={
                0: "None",
                1: "Baro",
                2: "RangeFinder",
                3: "GPS",
                4: "Beacon",
                6: "ExternalNav",
            },
        )
        for n in (1, 2, 3)
    },
    **{
        f"EK3_SRC{n}_YAW": ParamMeta(
            f"EKF source set {n}: yaw",
            values={
                0: "None",
                1: "Compass",
                2: "GPS",
                3: "GPS with Compass fallback",
                6: "ExternalNav",
            },
        )
        for n in (1, 2, 3)
    },
    # --- failsafes ---
    "FS_GCS_ENABLE": ParamMeta(
        "Ground station failsafe",
        values={
            0: "Disabled",
            1: "RTL",
            2: "RTL or continue mission",
            3: "SmartRTL or RTL",
            4: "SmartRTL or Land",
            5: "Land",
            6: "Auto DO_LAND_START or RTL",
            7: "Brake or Land",
        },
    ),
    "FS_GCS_TIMEOUT": ParamMeta("Ground station failsafe timeout", "s", 2, 120),
    "FS_EKF_ACTION": ParamMeta(
        "EKF failsafe action", values={1: "Land", 2: "AltHold", 3: "Land even in Stabilize"}
    ),
    "FS_EKF_THRESH": ParamMeta("EKF failsafe variance threshold", low=0.6, high=1.0),
    "FS_THR_ENABLE": ParamMeta(
        "Throttle (radio) failsafe",
        values={0: "Disabled", 1: "RTL", 3: "Land", 4: "SmartRTL or RTL"},
    ),
    # --- arming, flight ---
    # bits 1 (all) .. 20 (OSD); 18 is the visual odometry's
    "ARMING_CHECK": ParamMeta("Arming checks (bitmask; 1: all)", low=0, high=2**21 - 1),
    "DISARM_DELAY": ParamMeta("Disarm delay after landing", "s", 0, 127),
    "ANGLE_MAX": ParamMeta("Largest lean angle", "cdeg", 1000, 8000),
    "PILOT_SPEED_UP": ParamMeta("Pilot climb rate", "cm/s", 50, 500),
    "PILOT_SPEED_DN": ParamMeta("Pilot descent rate (0: as PILOT_SPEED_UP)", "cm/s", 0, 500),
    "PILOT_ACCEL_Z": ParamMeta("Pilot vertical acceleration", "cm/s/s", 50, 500),
    "PILOT_TKOFF_ALT": ParamMeta("Pilot take-off altitude", "cm", 0, 1000),
    "WPNAV_SPEED": ParamMeta("Horizontal speed in AUTO and GUIDED", "cm/s", 10, 2000),
    "WPNAV_SPEED_UP": ParamMeta("Climb speed in AUTO and GUIDED", "cm/s", 10, 1000),
    "WPNAV_SPEED_DN": ParamMeta("Descent speed in AUTO and GUIDED", "cm/s", 10, 500),
    "WPNAV_ACCEL": ParamMeta("Horizontal acceleration", "cm/s/s", 50, 500),
    "WPNAV_ACCEL_Z": ParamMeta("Vertical acceleration", "cm/s/s", 50, 500),
    "WPNAV_RADIUS": ParamMeta("Waypoint radius", "cm", 5, 1000),
    "LOIT_SPEED": ParamMeta("Loiter horizontal speed", "cm/s", 20, 3500),
    "LOIT_ACC_MAX": ParamMeta("Loiter largest correction acceleration", "cm/s/s", 100, 981),
    "LAND_SPEED": ParamMeta("Final landing speed", "cm/s", 30, 200),
    "LAND_SPEED_HIGH": ParamMeta(
        "Landing speed above LAND_ALT_LOW (0: WPNAV_SPEED_DN)", "cm/s", 0, 500
    ),
    "LAND_ALT_LOW": ParamMeta("Altitude where the final slow descent starts", "cm", 100, 10000),
    "RTL_ALT": ParamMeta("RTL altitude (0: current)", "cm", 200, 300000),
    "RTL_ALT_FINAL": ParamMeta("RTL final altitude (0: land)", "cm", 0, 1000),
    "RTL_CLIMB_MIN": ParamMeta("RTL least climb", "cm", 0, 3000),
    "RTL_SPEED": ParamMeta("RTL speed (0: WPNAV_SPEED)", "cm/s", 0, 2000),
    "RTL_LOIT_TIME": ParamMeta("RTL loiter time over home", "ms", 0, 60000),
    "GUID_TIMEOUT": ParamMeta("GUIDED velocity/attitude target timeout", "s", 0.1, 5),
    "RC_OVERRIDE_TIME": ParamMeta("RC override timeout (-1: never)", "s", -1, 120),
    "SYSID_THISMAV": ParamMeta("This vehicle's MAVLink system id", low=1, high=255, reboot=True),
    "SYSID_MYGCS": ParamMeta("The ground station's MAVLink system id", low=1, high=255),
    "FRAME_CLASS": ParamMeta(
        "Frame class", values={0: "Undefined", 1: "Quad", 2: "Hexa", 3: "Octa"}, reboot=True
    ),
    "FRAME_TYPE": ParamMeta("Frame type", values={0: "Plus", 1: "X", 2: "V", 3: "H"}, reboot=True),
    "MOT_THST_HOVER": ParamMeta("Hover throttle", low=0.2, high=0.8),
    "MOT_SPIN_ARM": ParamMeta("Motor spin when armed", low=0.0, high=0.2),
    "MOT_SPIN_MIN": ParamMeta("Lowest motor spin in flight", low=0.0, high=0.3),
    "MOT_SPOOL_TIME": ParamMeta("Spool-up time", "s", 0, 2),
    "RNGFND1_TYPE": ParamMeta("Rangefinder type (100: SITL)", low=0, high=100, reboot=True),
    "RNGFND1_MIN_CM": ParamMeta("Rangefinder shortest distance", "cm", 0, 10000),
    "RNGFND1_MAX_CM": ParamMeta("Rangefinder longest distance", "cm", 0, 10000),
    "RNGFND1_ORIENT": ParamMeta("Rangefinder orientation", values=_ORIENT),
}

#: Integer MAVLink parameter types and their bounds.
INTEGER_BOUNDS: dict[int, tuple[int, int]] = {
    mavlink2.MAV_PARAM_TYPE_UINT8: (0, 2**8 - 1),
    mavlink2.MAV_PARAM_TYPE_INT8: (-(2**7), 2**7 - 1),
    mavlink2.MAV_PARAM_TYPE_UINT16: (0, 2**16 - 1),
    mavlink2.MAV_PARAM_TYPE_INT16: (-(2**15), 2**15 - 1),
    mavlink2.MAV_PARAM_TYPE_UINT32: (0, 2**32 - 1),
    mavlink2.MAV_PARAM_TYPE_INT32: (-(2**31), 2**31 - 1),
}


def check_value(name: str, value: float, param_type: int) -> str | None:
    """Why ``value`` cannot be written to ``name`` (one sentence), or None when it can.

    >>> check_value("PLND_LAG", 0.5, mavlink2.MAV_PARAM_TYPE_REAL32)
    'PLND_LAG must be between 0.02 and 0.25 s; 0.5 is outside.'
    >>> check_value("PLND_TYPE", 1.5, mavlink2.MAV_PARAM_TYPE_INT8)
    'PLND_TYPE takes whole numbers; 1.5 is not one.'
    >>> check_value("PLND_TYPE", 1, mavlink2.MAV_PARAM_TYPE_INT8) is None
    True
    """
    bounds = INTEGER_BOUNDS.get(param_type)
    if bounds is not None:
        if value != int(value):
            return f"{name} takes whole numbers; {value:g} is not one."
        if not bounds[0] <= value <= bounds[1]:
            return f"{name} must be between {bounds[0]} and {bounds[1]}; {value:g} is outside."
    meta = META.get(name)
    if meta is None:
        return None
    if meta.values and int(value) not in meta.values:
        choices = ", ".join(f"{k} ({v})" for k, v in meta.values.items())
        return f"{name} takes one of {choices}; {value:g} is not one of them."
    unit = f" {meta.units}" if meta.units else ""
    if meta.low is not None and meta.high is not None and not meta.low <= value <= meta.high:
        return f"{name} must be between {meta.low:g} and {meta.high:g}{unit}; {value:g} is outside."
    return None
