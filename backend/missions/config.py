"""Mission settings: frozen dataclasses checked on construction (ValueError names the field)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from backend.frames import DOWN_MOUNT

STRATEGIES = ("plnd", "guided", "extnav")
ABORT_MODES = ("LOITER", "RTL")


def _check_positive(obj: object, names: tuple[str, ...]) -> None:
    for name in names:
        value = getattr(obj, name)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{name} must be a number, got {value!r}")
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite number, got {value!r}")


def _check_finite(obj: object, names: tuple[str, ...]) -> None:
    for name in names:
        value = getattr(obj, name)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{name} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value!r}")


@dataclass(frozen=True, eq=False)
class Mount:
    """The camera on the vehicle: ``R_body_cam`` and the camera centre in body FRD (m)."""

    rotation: np.ndarray = field(default_factory=lambda: DOWN_MOUNT.copy())
    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        R = np.asarray(self.rotation, float)
        if (
            R.shape != (3, 3)
            or not np.allclose(R @ R.T, np.eye(3), atol=1e-6)
            or not np.isclose(np.linalg.det(R), 1.0, atol=1e-6)
        ):
            raise ValueError("rotation must be a 3x3 rotation matrix (R_body_cam)")
        if len(self.offset_m) != 3 or not all(math.isfinite(v) for v in self.offset_m):
            raise ValueError(f"offset_m must be 3 finite numbers, got {self.offset_m!r}")


@dataclass(frozen=True)
class LandConfig:
    """How to land on the pad.

    Parameters
    ----------
    strategy : "plnd" or "guided"
        ``plnd``: ArduCopter's precision landing (LAND mode fed LANDING_TARGET);
        ``guided``: GUIDED velocity targets from the vision pose, then a blind LAND;
        ``extnav``: GPS-denied: centred over the pad on GPS, then the vision pose becomes
        ArduPilot's position source (VISION_POSITION_ESTIMATE, EKF source set 2) and LAND
        holds over the pad on it, with or without GPS (:mod:`backend.missions.extnav`).
    pad_north_m, pad_east_m, pad_down_m : float
        Where the pad is expected (local NED, m): flown to while it is not in view, and
        the reference for touchdown errors taken from telemetry.
    pad_heading_deg : float
        Where the pad picture's top edge faces (deg clockwise from north).
    approach_alt_m : float
        Height above the pad to look for it from (the H is found up to about 6 m).
    align_tolerance_m, yaw_tolerance_deg : float
        Centred and turned enough to start descending.
    final_alt_m : float
        Below this height the pad fills the view: losing it is expected, the last metres
        are a blind descent.
    descent_speed_mps : float
        Top descent speed of the guided strategy.
    max_speed_mps, gain_xy, gain_yaw, max_yaw_rate_dps : float
        Horizontal guidance: velocity = gain_xy * offset (clamped), yaw rate =
        gain_yaw * heading error (clamped).
    lost_hold_s : float
        Pad unseen this long (above ``final_alt_m``): stop descending and hold.
    lost_timeout_s : float
        Pad unseen this long: climb ``search_climb_m`` and search for ``search_s``.
    abort_mode : "LOITER" or "RTL"
        Where an aborted mission leaves the vehicle. LOITER follows the pilot's
        throttle stick: when the vehicle reports RC throttle below mid-stick (no pilot,
        as with a GCS-only set-up), the mission holds in GUIDED instead and says so.
    fix_max_age_s : float
        Vision fixes older than this are not steered by.
    timeout_s : float
        The whole mission's time limit.
    """

    strategy: str = "plnd"
    pad_north_m: float = 0.0
    pad_east_m: float = 0.0
    pad_down_m: float = 0.0
    pad_heading_deg: float = 0.0
    approach_alt_m: float = 4.0
    align_tolerance_m: float = 0.3
    yaw_tolerance_deg: float = 1.5
    final_alt_m: float = 0.7
    final_tolerance_m: float = 0.03
    descent_speed_mps: float = 0.6
    max_speed_mps: float = 1.0
    gain_xy: float = 0.8
    gain_yaw: float = 1.2
    max_yaw_rate_dps: float = 30.0
    lost_hold_s: float = 1.0
    lost_timeout_s: float = 5.0
    search_climb_m: float = 1.5
    search_s: float = 8.0
    abort_mode: str = "LOITER"
    fix_max_age_s: float = 0.5
    timeout_s: float = 240.0
    mount: Mount = field(default_factory=Mount)

    def __post_init__(self) -> None:
        if self.strategy not in STRATEGIES:
            raise ValueError(f"strategy must be one of {STRATEGIES}, got {self.strategy!r}")
        if self.abort_mode not in ABORT_MODES:
            raise ValueError(f"abort_mode must be one of {ABORT_MODES}, got {self.abort_mode!r}")
        _check_finite(self, ("pad_north_m", "pad_east_m", "pad_down_m", "pad_heading_deg"))
        positive = tuple(
            f.name
            for f in fields(self)
            if f.name
            not in (
                "strategy",
                "abort_mode",
                "mount",
                "pad_north_m",
                "pad_east_m",
                "pad_down_m",
                "pad_heading_deg",
            )
        )
        _check_positive(self, positive)
        if not isinstance(self.mount, Mount):
            raise ValueError("mount must be a Mount")

    @property
    def pad_ned(self) -> tuple[float, float, float]:
        return (self.pad_north_m, self.pad_east_m, self.pad_down_m)


@dataclass(frozen=True)
class HoverConfig:
    """Hover over the pad: take off, fly to where it should be, hold while recording.

    ``altitude_m``: hover height above home; ``hold_s``: how long to hold (frames are
    acquired and recorded meanwhile); the pad location and the guidance gains are
    those of :class:`LandConfig` (``land``). Once the pad is seen, the vehicle centres
    over it by vision.
    """

    altitude_m: float = 4.0
    hold_s: float = 20.0
    arrive_tolerance_m: float = 0.5
    takeoff_timeout_s: float = 60.0
    land: LandConfig = field(default_factory=LandConfig)

    def __post_init__(self) -> None:
        _check_positive(self, ("altitude_m", "hold_s", "arrive_tolerance_m", "takeoff_timeout_s"))
        if self.altitude_m > 100:
            raise ValueError(f"altitude_m must be <= 100, got {self.altitude_m}")
        if not isinstance(self.land, LandConfig):
            raise ValueError("land must be a LandConfig")
