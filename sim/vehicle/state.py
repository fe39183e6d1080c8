"""Value types shared by the autopilot and its flight modes."""

from __future__ import annotations

from dataclasses import dataclass

from sim.vehicle.physics import Vec3


@dataclass(frozen=True)
class VehicleTruth:
    """Ground truth of the simulated vehicle (not what telemetry reports)."""

    time_s: float
    position_ned: Vec3
    velocity_ned: Vec3
    roll: float
    pitch: float
    yaw: float
    armed: bool
    mode: int
    on_ground: bool
    landed_at: tuple[float, float] | None

    @property
    def attitude(self) -> Vec3:
        """(roll, pitch, yaw) in radians."""
        return (self.roll, self.pitch, self.yaw)


@dataclass(frozen=True)
class GuidedTarget:
    """What GUIDED (or a pilot take-off) is doing: hold, takeoff, pos or vel."""

    kind: str = "hold"
    north: float = 0.0
    east: float = 0.0
    down: float = 0.0
    velocity: Vec3 = (0.0, 0.0, 0.0)
    since: float = 0.0
    alt: float = 0.0


@dataclass(frozen=True)
class Estimate:
    """What the autopilot believes (EKF output): truth plus small, slowly varying error."""

    position_ned: Vec3
    velocity_ned: Vec3
    roll: float
    pitch: float
    yaw: float
    rates: Vec3
