"""Flying a free-running simulated vehicle on its own clock, seen through the truth.

:class:`ObservedDriver` drives genuine ArduCopter SITL (or the stand-in served like it)
the way the lockstep driver drives the stand-in: the mission's clock is the vehicle's
(``time_boot_ms``), each ``advance`` waits for the vehicle's clock rather than the wall's,
so GUID_TIMEOUT, the precision-landing filter and every mission timeout see the same
rates at any speed-up the ground station keeps up with. The camera is rendered from the
simulator's true state (SIM_STATE, read by an independent observer on a second port, in
the EKF origin's frame: the frame of LOCAL_POSITION_NED), and the touchdown is measured
from it too: vision can be seen correcting the autopilot's own navigation error.

:class:`SitlDriver` starts a SITL of its own (a fresh eeprom: a new vehicle) for one run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from backend.link import DEFAULT_STREAM_RATES_HZ, LinkState, VehicleLink
from backend.missions import TouchdownTruth
from backend.missions.mission import vehicle_time_usec
from sim.camera import VehiclePose
from sim.sitl import OBSERVER_RATES_HZ, Sitl, SitlObserver

#: The link's telemetry for a driven run: ATTITUDE (the mission's clock) at 50 Hz.
STREAM_RATES_HZ = {**DEFAULT_STREAM_RATES_HZ, "ATTITUDE": 50.0}
#: The observer's: the true state (the camera's pose) at 50 Hz of vehicle time.
OBSERVER_RATES = {**OBSERVER_RATES_HZ, "SIM_STATE": 50.0}
#: Wall seconds a vehicle may take to come back from a reboot (SITL: ~0.3 s at 10x).
REBOOT_WALL_S = 60.0


class ObservedDriver:
    """A free-running vehicle: ``link`` on one port, ``observer`` on another.

    ``set_speedup(x)`` changes the simulation's speed-up (SITL: SIM_SPEEDUP);
    ``flight_speedup``: the speed-up while the camera is in the loop (the ground station
    must render and process a frame per ``1 / camera_hz`` of vehicle time).
    """

    deterministic = False

    def __init__(
        self,
        link: Any,
        observer: SitlObserver,
        *,
        set_speedup: Callable[[float], None] | None = None,
        setup_speedup: float = 10.0,
        flight_speedup: float = 1.0,
    ) -> None:
        self.raw = link
        self.link = link
        self.obs = observer
        self._set_speedup = set_speedup
        self.setup_speedup = setup_speedup
        self.flight_speedup = flight_speedup
        self._next: float | None = None
        #: The ground under the vehicle when it was ready: the true NED down (camera) and
        #: the EKF's (mission); the pad lies on it.
        self.ground_true_d = 0.0
        self.ground_ekf_d = 0.0
        self.skipped_ticks = 0
        self._truth_rx: float | None = None

    # ---------------------------------------------------------------- the clock
    def connect(self, timeout_s: float = 60.0) -> None:
        ok = self.raw.wait_until(
            lambda t: t.state == LinkState.UP and t.vehicle_time_boot_ms is not None, timeout_s
        )
        if not ok:
            raise RuntimeError(f"no vehicle at {self.raw.url}")
        self._next = None

    def now(self) -> float:
        ms = self.raw.telemetry.vehicle_time_boot_ms
        return 0.0 if ms is None else ms / 1000.0

    def advance(self, dt: float) -> None:
        """Wait until ``dt`` more of the vehicle's time has passed since the last tick
        (a tick the ground station was too slow for is skipped, never caught up)."""
        if self._next is None:
            self._next = self.now()
        self._next += dt
        target = self._next
        wall = max(5.0, 20.0 * dt)
        self.raw.wait_until(
            lambda t: t.state != LinkState.UP or (t.vehicle_time_boot_ms or 0) >= target * 1000,
            wall,
        )
        now = self.now()
        if now > self._next + dt:
            self.skipped_ticks += 1
            self._next = now

    def await_reboot(self, boots: int) -> None:
        ok = self.raw.wait_until(
            lambda t: t.boots > boots and t.state == LinkState.UP, REBOOT_WALL_S
        )
        if not ok:
            raise RuntimeError("set-up: the vehicle did not come back from its reboot")
        self._next = None  # its clock started again

    def on_ready(self) -> None:
        """The vehicle has its position: note the ground (true and estimated)."""
        truth = self._truth_wait()
        pos = self.raw.telemetry.position_ned
        self.ground_true_d = truth.position_ned[2]
        self.ground_ekf_d = 0.0 if pos is None else pos.z

    def begin_landing(self) -> None:
        """The camera comes into the loop: slow the simulation to ``flight_speedup``."""
        if self._set_speedup is not None:
            self._set_speedup(self.flight_speedup)
            self._next = None

    # ---------------------------------------------------------------- the truth
    def _truth_wait(self, timeout_s: float = 10.0) -> Any:
        end = time.monotonic() + timeout_s
        while (truth := self.obs.truth()) is None:
            if time.monotonic() > end:
                raise RuntimeError("no SIM_STATE / GPS_GLOBAL_ORIGIN from the observer")
            self.obs.wait_message("SIM_STATE", 0.5)
        return truth

    def camera_pose(self, t: float) -> VehiclePose | None:
        truth = self.obs.truth()
        if truth is None:
            return None
        self._truth_rx = truth.rx
        return VehiclePose(truth.position_ned, truth.roll, truth.pitch, truth.yaw, t)

    def time_usec(self) -> int | None:
        """The last camera pose's moment on the vehicle's clock: the true state's arrival
        mapped through the link's latest ATTITUDE (a busy machine delays both ports
        alike), not the clock's latest reading, which a slow render has left behind."""
        tel = self.raw.telemetry
        if self._truth_rx is not None:
            usec = vehicle_time_usec(tel, self._truth_rx)
            if usec is not None:
                return usec
        ms = tel.vehicle_time_boot_ms
        return None if ms is None else max(1, ms * 1000)

    def touchdown(self) -> TouchdownTruth | None:
        truth = self.obs.truth()
        if truth is None:
            return None
        n, e, _ = truth.position_ned
        return TouchdownTruth(n, e, math.degrees(truth.yaw))

    def close(self) -> None:
        self.raw.close()
        self.obs.close()


class SitlDriver(ObservedDriver):
    """Genuine ArduCopter SITL of its own (fresh eeprom), set up at ``setup_speedup`` and
    flown with the camera at ``flight_speedup`` (SIM_SPEEDUP, changed while it runs)."""

    def __init__(self, *, setup_speedup: float = 10.0, flight_speedup: float = 1.0) -> None:
        self.sitl = Sitl(speedup=setup_speedup).start()
        try:
            link = VehicleLink(self.sitl.url, stream_rates_hz=STREAM_RATES_HZ)
            observer = SitlObserver(self.sitl.serial2_url, rates_hz=OBSERVER_RATES)
            link.start()
            observer.start()
        except BaseException:
            self.sitl.stop()
            raise
        super().__init__(
            link,
            observer,
            set_speedup=self._sim_speedup,
            setup_speedup=setup_speedup,
            flight_speedup=flight_speedup,
        )

    def _sim_speedup(self, value: float) -> None:
        result = self.link.set_param("SIM_SPEEDUP", value)
        if not result.ok:
            raise RuntimeError(f"could not set SIM_SPEEDUP: {result.detail}")

    def close(self) -> None:
        try:
            super().close()
        finally:
            self.sitl.stop()
