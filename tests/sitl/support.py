"""Helpers for the tests that fly genuine ArduCopter 4.5.6 SITL (marker ``sitl``).

Skipped when ``../shared/sitl`` (or ``$VISLAND_SITL_DIR``) is absent. One booted
SITL is shared by the tests that can reset what they change (``flight``); tests
about the boot itself get their own (``fresh_flight``). Every SITL is stopped with
its process group when its fixture ends, whatever the test did.

Waits are on the vehicle's own clock (``Flight.wait_sim``) or on events, each bounded
in wall time with room for a loaded 2-core machine.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest

from backend.frames import rot_ned_body
from backend.link import VehicleLink
from sim.sitl import Sitl, SitlObserver, default_speedup, find_sitl_dir, wait_ready
from sim.vehicle import SimConfig, SimVehicle, VehicleServer

SITL_DIR = find_sitl_dir()
requires_sitl = pytest.mark.skipif(
    SITL_DIR is None, reason="no ArduCopter SITL in ../shared/sitl (or $VISLAND_SITL_DIR)"
)
# The genuine-SITL case of a test run against several kinds of vehicle (``running_flight``).
SITL_KIND = pytest.param("sitl", id="sitl", marks=[pytest.mark.sitl, requires_sitl])


class StandIn:
    """The project's ArduCopter stand-in served like SITL: one TCP port for every client,
    SITL's timeline (``ready_after_scale`` 1), free-running at ``speedup``."""

    def __init__(self, *, speedup: float = 10.0, seed: int = 0) -> None:
        self.speedup = speedup
        self.server = VehicleServer(
            SimVehicle(SimConfig(seed=seed)), "tcp:127.0.0.1:0", speedup=speedup
        )

    def start(self) -> StandIn:
        self.server.start()
        self.url = self.serial1_url = self.serial2_url = self.server.address
        return self

    def stop(self) -> None:
        self.server.stop()


class Flight:
    """A vehicle (SITL or the stand-in) with the project's VehicleLink on SERIAL0 and an
    observer on SERIAL2."""

    def __init__(self, sitl: Sitl | StandIn) -> None:
        self.sitl = sitl
        self.speedup = sitl.speedup
        self.link = VehicleLink(sitl.url)
        self.obs = SitlObserver(sitl.serial2_url)
        self._changed: dict[str, float] = {}

    def start(self) -> Flight:
        self.started = time.monotonic()
        self.link.start()
        self.obs.start()
        return self

    def close(self) -> None:
        self.link.close()
        self.obs.close()

    # ---------------------------------------------------------------- time
    def wall(self, sim_seconds: float) -> float:
        """A wall-clock bound for ``sim_seconds`` of simulated time, generous."""
        return sim_seconds / min(self.speedup, 10.0) * 3.0 + 20.0

    def wait_sim(self, seconds: float) -> None:
        """Let ``seconds`` of the vehicle's time pass."""
        start = self.obs.boot_s or 0.0
        assert self.obs.wait(
            lambda: (self.obs.boot_s or 0.0) >= start + seconds, self.wall(seconds)
        )

    def wait_until(self, predicate: Callable[[Any], bool], sim_seconds: float) -> bool:
        """The link's telemetry satisfies ``predicate`` within ``sim_seconds`` (vehicle time)."""
        deadline = (self.obs.boot_s or 0.0) + sim_seconds
        wall_end = time.monotonic() + self.wall(sim_seconds)
        while time.monotonic() < wall_end:
            if self.link.wait_until(predicate, 0.2):
                return True
            if (self.obs.boot_s or 0.0) > deadline:
                return predicate(self.link.telemetry)
        return False

    def wait_ready(self) -> None:
        """Up, and flying on GPS is possible (the firmware's own readiness, since the
        latest boot: the link keeps a pre-reboot position until a new one comes)."""
        assert self.link.wait_until(lambda t: t.state.value == "up", self.wall(30))
        wait_ready(self.obs, timeout=self.wall(90))
        gps = self.obs.wait_text(r"^EKF3 IMU0 is using GPS$", 0, since=self.obs.epoch_texts)
        assert gps is not None
        assert self.wait_until(
            lambda t: (
                (t.local_position_rx_monotonic or 0.0) > gps.rx - 0.5 and t.state.value == "up"
            ),
            10,
        )

    def reboot(self) -> None:
        """Reboot through the link; wait for the TCP drop (SITL) or the clock going back
        (stand-in), the link coming back, and readiness since this boot."""
        epoch = self.obs.epoch_texts
        result = self.link.reboot()
        assert result.ok, result.detail
        assert self.obs.wait(lambda: self.obs.epoch_texts != epoch, self.wall(20)), "no reboot"
        self.wait_ready()

    @property
    def ready(self) -> bool:
        """ "EKF3 IMU0 is using GPS" since the latest boot."""
        return any(t.text == "EKF3 IMU0 is using GPS" for t in self.obs.texts(self.obs.epoch_texts))

    # ---------------------------------------------------------------- truth
    def origin(self) -> tuple[float, float, float]:
        origin = self.obs.ekf_origin()
        assert origin is not None, "no GPS_GLOBAL_ORIGIN yet"
        return origin

    def true_ned(self) -> tuple[float, float, float]:
        truth = self.obs.truth(self.origin())
        assert truth is not None, "no SIM_STATE"
        return truth.position_ned

    # ---------------------------------------------------------------- actions
    def set_param(self, name: str, value: float) -> None:
        """Set a parameter, remembering its old value for :meth:`reset`."""
        if name not in self._changed:
            old = self.link.get_param(name)
            assert old is not None, f"cannot read {name}"
            self._changed[name] = old
        result = self.link.set_param(name, value)
        assert result.ok, result.detail

    def mode(self, name: str) -> None:
        """Change mode and wait until the heartbeat confirms it."""
        for _ in range(5):
            result = self.link.set_mode(name)
            assert result.ok, result.detail
            if self.wait_until(lambda t: t.mode == name, 3):
                return
        pytest.fail(f"{name} acknowledged but never reported by the heartbeat")

    def takeoff(self, alt: float) -> None:
        """GUIDED, arm, take off and wait until the true height is within 0.5 m."""
        self.mode("GUIDED")
        arm = self.link.arm()
        assert arm.ok, arm.detail
        takeoff = self.link.takeoff(alt)
        assert takeoff.ok, takeoff.detail
        ground = self.true_ned()[2]
        assert self.obs.wait(
            lambda: ground - self.true_ned()[2] > alt - 0.5, self.wall(alt * 3 + 10)
        ), "never climbed"

    def land(self) -> None:
        """LAND and wait until the vehicle has disarmed itself."""
        result = self.link.land()
        assert result.ok, result.detail
        assert self.wait_until(lambda t: t.mode == "LAND", 3)
        alt = -self.true_ned()[2]
        assert self.wait_until(lambda t: not t.armed, alt * 4 + 30), "did not land and disarm"

    def reset(self) -> None:
        """Back to a ready, disarmed vehicle with the parameters a test changed restored."""
        if self.link.telemetry.armed:
            if self.link.telemetry.mode != "LAND":
                self.link.land()
            if not self.wait_until(lambda t: not t.armed, 60):
                self.link.force_disarm()
        for name, value in self._changed.items():
            self.link.set_param(name, value)
        self._changed.clear()
        if not self.ready or self.link.telemetry.state.value != "up":
            self.wait_ready()


def start_flight(kind: str = "sitl") -> tuple[Sitl | StandIn, Flight]:
    """Start a vehicle of ``kind`` ("sitl" or "standin") and connect to it."""
    sitl: Sitl | StandIn
    if kind == "sitl":
        sitl = Sitl(speedup=default_speedup()).start()
    else:
        sitl = StandIn(speedup=default_speedup()).start()
    try:
        return sitl, Flight(sitl).start()
    except BaseException:
        sitl.stop()
        raise


@contextmanager
def running_flight(kind: str = "sitl") -> Iterator[Flight]:
    """A fresh vehicle of ``kind``, connected; link and vehicle stopped on leaving, whatever
    happened."""
    sitl, flight = start_flight(kind)
    try:
        yield flight
    finally:
        flight.close()
        sitl.stop()


def send_landing_target(f: Flight, pad_ned: tuple[float, float, float]) -> None:
    """LANDING_TARGET (BODY_FRD, position_valid) of a pad at NED ``pad_ned``, from the truth."""
    truth = f.obs.truth(f.origin())
    assert truth is not None and f.obs.boot_s is not None
    rel = np.asarray(pad_ned) - np.asarray(truth.position_ned)
    body = rot_ned_body(truth.roll, truth.pitch, truth.yaw).T @ rel
    f.link.send_landing_target(
        *map(float, body),
        time_usec=int(f.obs.boot_s * 1e6),
        distance=float(np.linalg.norm(body)),
    )


def horizontal(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def assert_landed_blind(mission: Any) -> None:
    """A plnd landing whose targets ArduCopter ignored (no precision-landing backend:
    "PrecLand: Failsafe Measures") is reported as a blind landing, never a precise one."""
    rec = mission.record
    assert mission.outcome == "landed_blind", (rec.message, rec.states)
    assert rec.precland == "failsafe"
    assert rec.precland_texts[0] == "PrecLand: Failsafe Measures"
    assert "PrecLand: Target Found" not in rec.precland_texts
    assert rec.message.startswith("landed blind, not a precision landing")
    assert rec.targets_sent > 0  # the targets went out: the vehicle ignored them
