"""Where the stand-in's EKF gets its horizontal position from, as ArduPilot's EKF3 does.

Measured on ArduCopter 4.5.6 SITL (notes/sitl-findings.md) and kept here:

- three source sets (EK3_SRC1_* .. EK3_SRC3_*); set 1 is GPS (POSXY = 3) by default,
  MAV_CMD_SET_EKF_SOURCE_SET picks the active one; nothing is announced on a switch;
- ExternalNav (POSXY = 6) needs VISO_TYPE = 1 at boot and VISION_POSITION_ESTIMATE
  (healthy: one within the last 0.3 s). Switching to it resets the estimate to the
  vision position: a vision frame offset from the EKF origin makes the estimate jump
  by that offset (and a GUIDED target then moves with it);
- when the active source stops (SIM_GPS_DISABLE = 1 on a GPS set, the vision stream
  ending on an ExternalNav set) the EKF dead-reckons: the estimate drifts for about
  8 s, then "EKF variance" and the position is lost (no more LOCAL_POSITION_NED);
  the autopilot's EKF failsafe then lands (see `autopilot`); "EKF3 IMU0 stopped
  aiding" follows ~15 s after the source went.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

from sim.vehicle.params import ParamStore
from sim.vehicle.physics import Vec3

GPS, EXTNAV = 3, 6  # EK3_SRCn_POSXY values
VISION_HEALTHY_S = 0.3  # AP_VisualOdom: data within this long is healthy
DEAD_RECKONING_S = 8.0  # measured: GPS or vision gone -> "EKF variance" ~8 s later
STOP_AIDING_S = 15.0  # measured: "EKF3 IMU0 stopped aiding" ~15 s after
DRIFT_ACCEL = 0.03  # m/s^2: the dead-reckoned estimate's error grows like this
VISION_SMOOTH_S = 0.2  # time constant of the estimate following the vision position


@dataclass(frozen=True)
class VisionSample:
    """One VISION_POSITION_ESTIMATE: receive time (sim s), position (vision frame, NED),
    and the vehicle's true position when it arrived (to carry it forward)."""

    t: float
    position: Vec3
    truth_at_rx: Vec3


class Navigation:
    """Position source selection, ExternalNav, dead reckoning; deterministic per seed.

    ``offset`` is what the estimate adds to the truth horizontally (vision frame
    offset, vision noise, dead-reckoning drift); ``position_ok`` says whether the
    EKF still has a horizontal position.
    """

    def __init__(self, params: ParamStore, seed: int) -> None:
        self.params = params
        self._rng = random.Random(f"visland-nav-{seed}")
        self.reset(viso_backend=False)

    def reset(self, viso_backend: bool) -> None:
        """At boot: AP_VisualOdom exists only if VISO_TYPE was 1 then."""
        self.viso_backend = viso_backend
        self.source_set = 1
        self.vision: VisionSample | None = None
        self.vision_messages = 0
        self.speed_messages = 0
        self.offset = (0.0, 0.0)
        self.using: int | None = None  # the POSXY source being fused now
        self.dead_reckoning_since: float | None = None
        self.lost = False
        self._stopped_aiding = False
        self._drift_dir = (1.0, 0.0)

    # ------------------------------------------------------------------ inputs
    def set_source_set(self, number: int) -> bool:
        """MAV_CMD_SET_EKF_SOURCE_SET: 1..3."""
        if number not in (1, 2, 3):
            return False
        self.source_set = number
        return True

    def vision_position(self, t: float, position: Vec3, truth: Vec3) -> bool:
        """VISION_POSITION_ESTIMATE; False when there is no visual odometry backend."""
        if not self.viso_backend or not all(math.isfinite(v) for v in position):
            return False
        self.vision = VisionSample(t, position, truth)
        self.vision_messages += 1
        return True

    def vision_speed(self) -> None:
        """VISION_SPEED_ESTIMATE: counted (the estimate's velocity stays the truth's)."""
        if self.viso_backend:
            self.speed_messages += 1

    # ------------------------------------------------------------------ state
    def posxy_source(self) -> int:
        """EK3_SRCn_POSXY of the active source set."""
        return int(self.params.get(f"EK3_SRC{self.source_set}_POSXY"))

    def vision_healthy(self, t: float) -> bool:
        """AP_VisualOdom's health: a pose within the last 0.3 s."""
        v = self.vision
        return self.viso_backend and v is not None and t - v.t <= VISION_HEALTHY_S

    def _available(self, source: int, t: float, gps_ok: bool) -> bool:
        if source == GPS:
            return gps_ok
        if source == EXTNAV:
            return self.vision_healthy(t)
        return False

    @property
    def position_ok(self) -> bool:
        """A horizontal position estimate exists (dead reckoning included)."""
        return self.using is not None and not self.lost

    def update(self, t: float, dt: float, truth: Vec3, gps_ok: bool) -> list[str]:
        """Advance by ``dt``; returns the EKF's STATUSTEXTs (already known texts only)."""
        texts: list[str] = []
        source = self.posxy_source()
        if self._available(source, t, gps_ok):
            if self.using != source or self.lost or self.dead_reckoning_since is not None:
                self._start_using(source, truth, t, texts)
            if source == EXTNAV:
                self._follow_vision(truth, dt)
            return texts
        if self.using is None:
            return texts  # never had a position (booting, or no source at all)
        if self.dead_reckoning_since is None:
            self.dead_reckoning_since = t
            a = self._rng.uniform(0.0, 2.0 * math.pi)
            self._drift_dir = (math.cos(a), math.sin(a))
        since = t - self.dead_reckoning_since
        if not self.lost:
            # the error's velocity grows with time: an uncorrected accelerometer bias
            step = DRIFT_ACCEL * since * dt
            self.offset = (
                self.offset[0] + self._drift_dir[0] * step,
                self.offset[1] + self._drift_dir[1] * step,
            )
            if since >= DEAD_RECKONING_S:
                self.lost = True
                texts.append("EKF variance")
        elif since >= STOP_AIDING_S and not self._stopped_aiding:
            self._stopped_aiding = True
            texts.append("EKF3 IMU0 stopped aiding")
        return texts

    def _start_using(self, source: int, truth: Vec3, t: float, texts: list[str]) -> None:
        was_lost = self.lost
        self.using = source
        self.lost = False
        self._stopped_aiding = False
        self.dead_reckoning_since = None
        if source == EXTNAV and self.vision is not None:
            # EKF3 resets its position to the new source's on a switch
            v = self.vision
            moved = (truth[0] - v.truth_at_rx[0], truth[1] - v.truth_at_rx[1])
            self.offset = (
                v.position[0] + moved[0] - truth[0],
                v.position[1] + moved[1] - truth[1],
            )
        else:
            self.offset = (0.0, 0.0)
            if was_lost:
                texts.append("EKF3 IMU0 is using GPS")

    def _follow_vision(self, truth: Vec3, dt: float) -> None:
        v = self.vision
        if v is None:
            return
        target = (v.position[0] - v.truth_at_rx[0], v.position[1] - v.truth_at_rx[1])
        a = min(1.0, dt / VISION_SMOOTH_S)
        self.offset = (
            self.offset[0] + a * (target[0] - self.offset[0]),
            self.offset[1] + a * (target[1] - self.offset[1]),
        )
