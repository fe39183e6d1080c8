"""ArduCopter parameters the stand-in honours, with ArduCopter 4.5 / SITL defaults.

Only parameters that change the simulated behaviour (or that the project reads) are
listed; unknown names are ignored on PARAM_SET and PARAM_REQUEST_READ, as ArduPilot
does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

_F = mavlink.MAV_PARAM_TYPE_REAL32
_I8 = mavlink.MAV_PARAM_TYPE_INT8
_I16 = mavlink.MAV_PARAM_TYPE_INT16
_I32 = mavlink.MAV_PARAM_TYPE_INT32

# (name, default, MAVLink type). Units as in ArduCopter (cm, cm/s, cdeg, ms).
_DEFAULTS: tuple[tuple[str, float, int], ...] = (
    ("SYSID_THISMAV", 1, _I16),
    ("SYSID_MYGCS", 255, _I16),
    ("FRAME_CLASS", 1, _I8),
    ("FRAME_TYPE", 0, _I8),
    ("ARMING_CHECK", 1, _I32),
    ("DISARM_DELAY", 10, _I8),
    ("ANGLE_MAX", 3000, _I16),
    ("PILOT_SPEED_UP", 250, _I16),
    ("PILOT_SPEED_DN", 0, _I16),
    ("PILOT_ACCEL_Z", 250, _I16),
    ("PILOT_TKOFF_ALT", 0, _F),
    ("PILOT_Y_RATE", 202.5, _F),
    ("THR_DZ", 100, _I16),
    ("WPNAV_SPEED", 1000, _F),
    ("WPNAV_SPEED_UP", 250, _F),
    ("WPNAV_SPEED_DN", 150, _F),
    ("WPNAV_ACCEL", 250, _F),
    ("WPNAV_ACCEL_Z", 100, _F),
    ("WPNAV_RADIUS", 200, _F),
    ("LOIT_SPEED", 1250, _F),
    ("LOIT_ACC_MAX", 500, _F),
    ("LAND_SPEED", 50, _I16),
    ("LAND_SPEED_HIGH", 0, _I16),
    ("LAND_ALT_LOW", 1000, _I16),
    ("RTL_ALT", 1500, _I16),
    ("RTL_ALT_FINAL", 0, _I16),
    ("RTL_CLIMB_MIN", 0, _I16),
    ("RTL_SPEED", 0, _I16),
    ("RTL_LOIT_TIME", 5000, _I32),
    ("GUID_TIMEOUT", 3, _F),
    ("RC_OVERRIDE_TIME", 3, _F),
    ("PSC_POSXY_P", 1.0, _F),
    ("PSC_VELXY_P", 2.0, _F),
    ("PSC_VELXY_I", 1.0, _F),
    ("PSC_VELXY_D", 0.5, _F),
    ("PSC_POSZ_P", 1.0, _F),
    ("PSC_VELZ_P", 5.0, _F),
    ("PSC_ACCZ_P", 0.5, _F),
    ("PSC_ACCZ_I", 1.0, _F),
    ("ATC_ANG_RLL_P", 4.5, _F),
    ("ATC_ANG_PIT_P", 4.5, _F),
    ("ATC_ANG_YAW_P", 4.5, _F),
    ("ATC_RAT_RLL_P", 0.135, _F),
    ("ATC_RAT_PIT_P", 0.135, _F),
    ("ATC_RAT_YAW_P", 0.3, _F),  # copter.parm
    ("ATC_ACCEL_R_MAX", 110000, _F),
    ("ATC_ACCEL_P_MAX", 110000, _F),
    ("ATC_ACCEL_Y_MAX", 27000, _F),
    ("MOT_THST_HOVER", 0.39, _F),
    ("MOT_SPIN_ARM", 0.1, _F),
    ("MOT_SPIN_MIN", 0.15, _F),
    ("MOT_SPOOL_TIME", 0.5, _F),
    ("BATT_MONITOR", 4, _I8),
    ("BATT_CAPACITY", 3300, _I32),
    ("BATT_LOW_VOLT", 10.5, _F),
    ("BATT_CRT_VOLT", 0, _F),
    ("BATT_LOW_MAH", 0, _F),
    ("BATT_CRT_MAH", 0, _F),
    ("BATT_LOW_TIMER", 10, _I8),
    ("BATT_FS_LOW_ACT", 0, _I8),
    ("BATT_FS_CRT_ACT", 0, _I8),
    # SITL's copter.parm configures no rangefinder (0); 100 would be a SITL one.
    ("RNGFND1_TYPE", 0, _I8),
    ("RNGFND1_MIN_CM", 20, _I16),
    ("RNGFND1_MAX_CM", 700, _I16),
    ("RNGFND1_ORIENT", 25, _I8),
    ("PLND_ENABLED", 0, _I8),
    ("PLND_TYPE", 0, _I8),
    ("PLND_EST_TYPE", 1, _I8),
    ("PLND_YAW_ALIGN", 0, _F),
    ("PLND_LAND_OFS_X", 0, _F),
    ("PLND_LAND_OFS_Y", 0, _F),
    ("PLND_CAM_POS_X", 0, _F),
    ("PLND_CAM_POS_Y", 0, _F),
    ("PLND_CAM_POS_Z", 0, _F),
    ("PLND_BUS", -1, _I8),
    ("PLND_LAG", 0.02, _F),
    ("PLND_XY_DIST_MAX", 2.5, _F),
    ("PLND_STRICT", 1, _I8),
    ("PLND_RET_MAX", 4, _I8),
    ("PLND_TIMEOUT", 4, _F),
    ("PLND_RET_BEHAVE", 0, _I8),
    ("PLND_ALT_MIN", 0.75, _F),
    ("PLND_ALT_MAX", 8, _F),
    ("PLND_OPTIONS", 0, _I16),
    ("PLND_ORIENT", 25, _I8),
    ("PLND_ACC_P_NSE", 2.5, _F),
    # EKF3 source sets (3 GPS, 6 ExternalNav, 1 baro, 0 none), visual odometry, failsafe
    ("EK3_SRC1_POSXY", 3, _I8),
    ("EK3_SRC1_VELXY", 3, _I8),
    ("EK3_SRC1_POSZ", 1, _I8),
    ("EK3_SRC1_VELZ", 3, _I8),
    ("EK3_SRC1_YAW", 1, _I8),
    ("EK3_SRC2_POSXY", 0, _I8),
    ("EK3_SRC2_VELXY", 0, _I8),
    ("EK3_SRC2_POSZ", 1, _I8),
    ("EK3_SRC2_VELZ", 0, _I8),
    ("EK3_SRC2_YAW", 0, _I8),
    ("EK3_SRC3_POSXY", 0, _I8),
    ("EK3_SRC3_VELXY", 0, _I8),
    ("EK3_SRC3_POSZ", 1, _I8),
    ("EK3_SRC3_VELZ", 0, _I8),
    ("EK3_SRC3_YAW", 0, _I8),
    ("EK3_SRC_OPTIONS", 1, _I16),
    ("VISO_TYPE", 0, _I8),
    ("VISO_DELAY_MS", 10, _I16),
    ("VISO_POS_M_NSE", 0.2, _F),
    ("VISO_VEL_M_NSE", 0.1, _F),
    ("VISO_YAW_M_NSE", 0.2, _F),
    ("FS_EKF_ACTION", 1, _I8),
    ("FS_EKF_THRESH", 0.8, _F),
    ("SIM_GPS_DISABLE", 0, _I8),
)


@dataclass(frozen=True)
class ParamInfo:
    """One parameter as PARAM_VALUE reports it."""

    name: str
    value: float
    param_type: int
    index: int
    count: int


class ParamStore:
    """The vehicle's parameter table: ordered, typed, survives a reboot.

    Examples
    --------
    >>> p = ParamStore()
    >>> p.get("DISARM_DELAY")
    10.0
    >>> p.set("PLND_ENABLED", 1).value
    1.0
    """

    def __init__(self, overrides: dict[str, float] | None = None) -> None:
        self._names = [name for name, _, _ in _DEFAULTS]
        self._types = {name: ptype for name, _, ptype in _DEFAULTS}
        self._values = {name: float(value) for name, value, _ in _DEFAULTS}
        for name, value in (overrides or {}).items():
            if self.set(name, value) is None:
                raise ValueError(f"overrides: unknown parameter {name!r}")

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: object) -> bool:
        return name in self._values

    def get(self, name: str) -> float:
        """Value of a known parameter (KeyError for an unknown name)."""
        return self._values[name]

    def info(self, name: str) -> ParamInfo | None:
        """PARAM_VALUE fields of a parameter, None when unknown."""
        if name not in self._values:
            return None
        return ParamInfo(
            name,
            self._values[name],
            self._types[name],
            self._names.index(name),
            len(self._names),
        )

    def info_by_index(self, index: int) -> ParamInfo | None:
        """PARAM_VALUE fields of the parameter at ``index``, None when out of range."""
        if not 0 <= index < len(self._names):
            return None
        return self.info(self._names[index])

    def all(self) -> list[ParamInfo]:
        """Every parameter in index order (what PARAM_REQUEST_LIST streams)."""
        return [info for name in self._names if (info := self.info(name)) is not None]

    def set(self, name: str, value: float) -> ParamInfo | None:
        """Store a value, rounded for integer types; None for an unknown name or NaN.

        Like ArduPilot, integer parameters are rounded and clamped to their type's
        range; float parameters are stored as float32 would hold them.
        """
        if name not in self._values or not math.isfinite(value):
            return None
        ptype = self._types[name]
        if ptype != _F:
            bits = {_I8: 8, _I16: 16, _I32: 32}[ptype]
            lo, hi = -(2 ** (bits - 1)), 2 ** (bits - 1) - 1
            value = float(min(hi, max(lo, round(value))))
        self._values[name] = float(value)
        return self.info(name)
