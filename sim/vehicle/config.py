"""Configuration of the simulated ArduCopter (what SITL would take as command-line options)."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class SimConfig:
    """Everything that makes one simulated flight different from another.

    Parameters
    ----------
    seed : int
        Seed of every random process (wind gusts, sensor noise): same seed and same
        inputs give the same flight.
    ready_after_scale : float
        Multiplies the readiness timeline of SITL (GPS fix ~10 s, EKF origin ~20 s,
        pre-arm ok ~24 s, position estimate for GUIDED ~42 s). Tests pass e.g. 0.05.
    home_lat, home_lon, home_alt : float
        Where the vehicle boots (degrees, degrees, metres AMSL). Default: ArduPilot's
        SITL default location (CMAC, Canberra).
    pad_north, pad_east, pad_heading_deg : float
        The helipad's centre relative to home (m) and its heading (deg, 0 = north).
    wind_mps, wind_dir_deg : float
        Mean wind speed and the direction it blows *from* (deg, 0 = from north).
    gust_mps : float
        Standard deviation of the gusts (filtered noise) on each horizontal axis.
    physics_hz : float
        Physics and controller rate (ArduCopter's main loop runs at 400 Hz).
    signing_key : bytes or None
        32-byte MAVLink 2 signing key; when set, unsigned messages are rejected.
    battery_mah : float
        Battery capacity.
    """

    seed: int = 0
    ready_after_scale: float = 1.0
    home_lat: float = -35.363262
    home_lon: float = 149.165237
    home_alt: float = 584.0
    pad_north: float = 0.0
    pad_east: float = 0.0
    pad_heading_deg: float = 0.0
    wind_mps: float = 0.0
    wind_dir_deg: float = 0.0
    gust_mps: float = 0.0
    physics_hz: float = 400.0
    signing_key: bytes | None = None
    battery_mah: float = 3300.0

    def __post_init__(self) -> None:
        if not self.ready_after_scale >= 0.0:
            raise ValueError(f"ready_after_scale must be >= 0, got {self.ready_after_scale}")
        if not -90.0 <= self.home_lat <= 90.0:
            raise ValueError(f"home_lat must be within [-90, 90], got {self.home_lat}")
        if not -180.0 <= self.home_lon <= 180.0:
            raise ValueError(f"home_lon must be within [-180, 180], got {self.home_lon}")
        for name in ("home_alt", "pad_north", "pad_east", "pad_heading_deg", "wind_dir_deg"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")
        if not 0.0 <= self.wind_mps <= 30.0:
            raise ValueError(f"wind_mps must be within [0, 30], got {self.wind_mps}")
        if not 0.0 <= self.gust_mps <= 15.0:
            raise ValueError(f"gust_mps must be within [0, 15], got {self.gust_mps}")
        if not 50.0 <= self.physics_hz <= 2000.0:
            raise ValueError(f"physics_hz must be within [50, 2000], got {self.physics_hz}")
        if self.signing_key is not None and len(self.signing_key) != 32:
            raise ValueError(f"signing_key must be 32 bytes, got {len(self.signing_key)} bytes")
        if not self.battery_mah > 0.0:
            raise ValueError(f"battery_mah must be > 0, got {self.battery_mah}")

    @property
    def pad_ned(self) -> tuple[float, float]:
        """The pad centre (north, east) in metres from home."""
        return (self.pad_north, self.pad_east)
