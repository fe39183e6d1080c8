"""Landing scenarios: the stand-in vehicle and the simulated camera, through the real
link and the real mission code, from random starts; one JSON summary of many runs.

Each run draws (from ``seed`` and its index): the pad's heading, a start 1-3 m off the
pad and 4-8 m up with any heading, wind up to ``wind_max_mps`` from any direction
with gusts, and the camera's SNR (15-30 dB). The vehicle takes off and flies to the
start over the link, then :class:`~backend.missions.LandMission` lands it by vision.

Two drivers: :class:`LockstepDriver` owns the stand-in's clock (deterministic, faster
than real time); :class:`RealtimeDriver` flies any MAVLink vehicle (``--mavlink``,
e.g. ArduCopter SITL) in real time with the camera rendered from telemetry.
"""

from __future__ import annotations

import math
import random
import statistics
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import cv2

from backend.frames import vision_hints
from backend.link import DEFAULT_STREAM_RATES_HZ, LinkState, VehicleLink
from backend.missions import (
    LandConfig,
    Mission,
    RunRecord,
    TouchdownTruth,
    VisionSample,
)
from backend.missions.extnav import ARMING_CHECK_ALL_BUT_VISION, EXTNAV_PARAMS, land_mission
from backend.missions.geometry import heading_error_deg
from pipeline import Reference, process_frame
from pipeline.render import make_pad_image
from sim.camera import PadRenderer, SimCameraConfig, VehiclePose
from sim.vehicle.mavlink_server import REBOOT_SILENCE_S

PAD_SIZE_M = 0.55
#: Where the pad is, from home (the seed flew 6 m out).
PAD_NE = (6.0, 0.0)
#: A landing counts when the vehicle comes down on the pad (inside its half width).
ON_PAD_M = PAD_SIZE_M / 2
SETUP_TIMEOUT_S = 60.0  # simulated seconds to take off and reach the start


@dataclass(frozen=True)
class RunSpec:
    """One run's draw."""

    index: int
    seed: int
    strategy: str
    pad_heading_deg: float
    start_north_m: float
    start_east_m: float
    start_alt_m: float
    start_yaw_deg: float
    wind_mps: float
    wind_dir_deg: float
    gust_mps: float
    snr_db: float

    @classmethod
    def draw(cls, seed: int, index: int, strategy: str, wind_max_mps: float) -> RunSpec:
        """The ``index``-th run of ``seed`` (independent of the other runs)."""
        rng = random.Random(f"visland-scenario-{seed}-{index}")
        r, bearing = rng.uniform(1.0, 3.0), rng.uniform(0.0, 2 * math.pi)
        wind = rng.uniform(0.0, wind_max_mps)
        return cls(
            index=index,
            seed=rng.randrange(2**31),
            strategy=strategy,
            pad_heading_deg=rng.uniform(0.0, 360.0),
            start_north_m=PAD_NE[0] + r * math.cos(bearing),
            start_east_m=PAD_NE[1] + r * math.sin(bearing),
            start_alt_m=rng.uniform(4.0, 8.0),
            start_yaw_deg=rng.uniform(-180.0, 180.0),
            wind_mps=wind,
            wind_dir_deg=rng.uniform(0.0, 360.0),
            gust_mps=rng.uniform(0.0, 0.3) * wind,
            snr_db=rng.uniform(15.0, 30.0),
        )


@dataclass
class RunResult:
    """What one run gave."""

    spec: RunSpec
    outcome: str
    message: str
    touchdown_error_m: float | None
    heading_error_deg: float | None
    time_to_land_s: float | None
    frames: int
    detections: int
    wall_s: float
    states: list[dict[str, Any]] = field(default_factory=list)
    record: RunRecord | None = None
    #: "plnd": did ArduCopter take the targets (the record's verdict); None for "guided".
    precland: str | None = None
    precland_texts: list[str] = field(default_factory=list)
    #: Where the touchdown was measured: "truth" (the simulator's) or "telemetry".
    touchdown_source: str | None = None

    @property
    def success(self) -> bool:
        return (
            self.outcome == "landed"
            and self.touchdown_error_m is not None
            and self.touchdown_error_m <= ON_PAD_M
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "index": self.spec.index,
            "outcome": self.outcome,
            "success": self.success,
            "message": self.message,
            "touchdown_error_m": self.touchdown_error_m,
            "heading_error_deg": self.heading_error_deg,
            "time_to_land_s": self.time_to_land_s,
            "frames": self.frames,
            "detections": self.detections,
            "wall_s": round(self.wall_s, 2),
            "precland": self.precland,
            "precland_texts": self.precland_texts,
            "touchdown_source": self.touchdown_source,
            "spec": self.spec.__dict__,
        }


# --- drivers ---------------------------------------------------------------------------------
class LockstepDriver:
    """The in-process stand-in in lockstep: the runner's thread is its clock."""

    deterministic = True

    def __init__(self, spec: RunSpec, *, ready_after_scale: float = 0.01) -> None:
        from bench.scenarios.lockstep import LockstepLink
        from sim.vehicle import SimConfig, SimVehicle, VehicleServer

        self.sim = SimVehicle(
            SimConfig(
                seed=spec.seed,
                ready_after_scale=ready_after_scale,
                pad_north=PAD_NE[0],
                pad_east=PAD_NE[1],
                pad_heading_deg=spec.pad_heading_deg,
                wind_mps=spec.wind_mps,
                wind_dir_deg=spec.wind_dir_deg,
                gust_mps=spec.gust_mps,
            )
        )
        self.server = VehicleServer(self.sim, "tcp:127.0.0.1:0", lockstep=True)
        # The harness sets the telemetry rates itself, at simulated time 0: a link asking
        # at some wall-clock moment would start the streams in a different phase each run.
        for name, hz in DEFAULT_STREAM_RATES_HZ.items():
            self.server.set_interval(name, 1.0 / hz)
        self.server.start()
        # Heartbeats come once a simulated second, however long that takes on a loaded
        # machine: no wall-clock timeout may end the link (a stopped vehicle closes the
        # TCP stream, which the link notices at once).
        self.raw = VehicleLink(self.server.address, heartbeat_timeout_s=600.0, stream_rates_hz={})
        self.raw.start()
        self.link = LockstepLink(self.raw, self.server)

    def connect(self, timeout_s: float = 10.0, *, position: bool = True) -> None:
        """Bring the link up without letting simulated time depend on the wall clock;
        ``position``: and wait for the first position estimate."""
        deadline = time.monotonic() + timeout_s
        while self.server.peers < 1:  # nothing sent before the link listens
            if time.monotonic() > deadline:
                raise RuntimeError("the link did not connect to the stand-in")
            time.sleep(0.002)
        self.server.advance(0.05)
        if not self.raw.wait_until(lambda t: t.state == LinkState.UP, timeout=timeout_s):
            raise RuntimeError("the link to the stand-in did not come up")
        self.link.sync()
        limit = self.sim.time_s + 30.0
        while True:
            tel = self.raw.telemetry
            if tel.attitude is not None and (tel.position_ned is not None or not position):
                return
            if self.sim.time_s > limit:
                raise RuntimeError("the stand-in reported no position")
            self.advance(0.05)

    def await_reboot(self, boots: int) -> None:
        """Let the stand-in's reboot silence pass (no barrier: a rebooting vehicle answers
        nothing; a fixed span of simulated time keeps runs deterministic), then check
        that the link has seen the new boot."""

        end = self.sim.time_s + REBOOT_SILENCE_S + 0.5
        while self.sim.time_s < end:
            self.server.advance(0.05)
        self.link.sync()
        if not self.raw.wait_until(lambda t: t.boots > boots, 5.0):
            raise RuntimeError("set-up: the link did not see the stand-in's reboot")

    def now(self) -> float:
        return self.sim.time_s

    def advance(self, dt: float) -> None:
        # Barrier before time moves: what the mission (or a test) sent is in the
        # vehicle's inbox however late its reader thread gets the bytes from the socket
        # (under load it may not have, and the vehicle would fly on the old targets).
        self.link.sync()
        self.server.advance(dt)
        self.link.sync()

    def camera_pose(self, t: float) -> VehiclePose:
        truth = self.server.truth()
        return VehiclePose(truth.position_ned, truth.roll, truth.pitch, truth.yaw, t)

    def time_usec(self) -> int | None:
        return max(1, round(self.sim.boot_s * 1e6))

    def touchdown(self) -> TouchdownTruth | None:
        landed = self.sim.landed_at
        if landed is None:
            return None
        return TouchdownTruth(landed[0], landed[1], math.degrees(self.server.truth().yaw))

    def close(self) -> None:
        self.raw.close()
        self.server.stop()


class RealtimeDriver:
    """Any MAVLink vehicle in real time; the camera renders from telemetry."""

    deterministic = False

    def __init__(self, url: str) -> None:
        self.raw = VehicleLink(url, heartbeat_timeout_s=5.0)
        self.raw.start()
        self.link = self.raw
        self._next = time.monotonic()

    def connect(self, timeout_s: float = 30.0) -> None:
        if not self.raw.wait_until(lambda t: t.state == LinkState.UP, timeout=timeout_s):
            raise RuntimeError(f"no vehicle at {self.raw.url}")
        self._next = time.monotonic()

    def await_reboot(self, boots: int) -> None:
        if not self.raw.wait_until(lambda t: t.boots > boots and t.state == LinkState.UP, 60.0):
            raise RuntimeError("set-up: the vehicle did not come back from its reboot")

    def now(self) -> float:
        return time.monotonic()

    def advance(self, dt: float) -> None:
        self._next += dt
        time.sleep(max(0.0, self._next - time.monotonic()))

    def camera_pose(self, t: float) -> VehiclePose | None:
        tel = self.raw.telemetry
        if tel.position_ned is None or tel.attitude is None:
            return None
        p, a = tel.position_ned, tel.attitude
        return VehiclePose((p.x, p.y, p.z), a.roll, a.pitch, a.yaw, t)

    def time_usec(self) -> int | None:
        return None  # mapped through ATTITUDE's time_boot_ms by the mission

    def touchdown(self) -> TouchdownTruth | None:
        return None

    def close(self) -> None:
        self.raw.close()


# --- one run -------------------------------------------------------------------------------
def _wait(driver: Any, dt: float, until: Any, limit_s: float, what: str) -> None:
    t0 = driver.now()
    while not until(driver.link.telemetry):
        if driver.now() - t0 > limit_s:
            raise RuntimeError(f"set-up: {what} not done within {limit_s:g} s")
        driver.advance(dt)


#: What the runner writes for ArduCopter's precision landing (then reboots: PLND_TYPE
#: is read at boot).
PLND_SETUP = (("PLND_ENABLED", 1.0), ("PLND_TYPE", 1.0), ("PLND_EST_TYPE", 1.0))
#: Vehicle seconds to wait for a position estimate (ArduCopter: ~41 s after a boot).
READY_LIMIT_S = 120.0
#: Vehicle seconds for a HEARTBEAT to confirm an accepted command (one a second).
CONFIRM_LIMIT_S = 5.0


def set_up_precland(driver: Any) -> None:
    """Write :data:`PLND_SETUP`, reboot, and wait until the link has seen the new boot."""
    link = driver.link
    for name, value in PLND_SETUP:
        if link.get_param(name) != value:
            result = link.set_param(name, value)
            if not result.ok:
                raise RuntimeError(f"set-up: could not set {name}: {result.detail}")
    _reboot(driver)


def _reboot(driver: Any) -> None:
    """Reboot the vehicle and wait until the link has seen the new boot."""
    link = driver.link
    # The link sees a reboot as the vehicle's clock going back: a vehicle younger than
    # its reboot takes (the stand-in in lockstep) would not show one.
    _wait(driver, 0.1, lambda t: (t.vehicle_time_boot_ms or 0) > 5000, 30, "5 s of boot")
    boots = link.telemetry.boots
    result = link.reboot()
    if not result.ok:
        raise RuntimeError(f"set-up: reboot refused: {result.detail}")
    driver.await_reboot(boots)


def _confirmed_guided(driver: Any) -> None:
    """GUIDED, as a HEARTBEAT after the ACK says (ArduCopter undoes a mode set while it
    boots; a few tries)."""
    link = driver.link
    for _ in range(3):
        result = link.set_mode("GUIDED")
        if not result.ok:
            raise RuntimeError(f"set-up: GUIDED refused: {result.detail}")
        _wait(driver, 0.05, lambda t: t.state_confirmed, CONFIRM_LIMIT_S, "GUIDED (heartbeat)")
        if link.telemetry.mode == "GUIDED":
            return
    raise RuntimeError(f"set-up: GUIDED accepted, the heartbeat says {link.telemetry.mode}")


def fly_to_start(driver: Any, spec: RunSpec, *, precland: bool | None = None) -> None:
    """Take off and fly to the run's start; for ``plnd`` runs (or ``precland``) set up
    precision landing first (parameters, reboot). Waits on the vehicle's own readiness
    (its position estimate) and confirms GUIDED and arming by a heartbeat each."""
    link = driver.link
    if precland if precland is not None else spec.strategy == "plnd":
        set_up_precland(driver)
    if spec.strategy == "extnav":
        setup_extnav(driver)
    _wait(driver, 0.1, lambda t: t.position_ready, READY_LIMIT_S, "position estimate")
    on_ready = getattr(driver, "on_ready", None)
    if on_ready is not None:
        on_ready()
    _confirmed_guided(driver)
    t0 = driver.now()
    while not (result := link.arm()).ok:
        if driver.now() - t0 > 30:
            raise RuntimeError(f"set-up: the vehicle would not arm: {result.detail}")
        driver.advance(0.5)
    _wait(driver, 0.05, lambda t: t.state_confirmed, CONFIRM_LIMIT_S, "arming (heartbeat)")
    tel = link.telemetry
    if not tel.armed or tel.mode != "GUIDED":
        raise RuntimeError(f"set-up: after arming the heartbeat says {tel.mode}, armed={tel.armed}")
    if not (result := link.takeoff(spec.start_alt_m)).ok:
        raise RuntimeError(f"set-up: take-off refused: {result.detail}")
    _wait(
        driver,
        0.1,
        lambda t: t.position_ned is not None and -t.position_ned.z > spec.start_alt_m - 0.2,
        SETUP_TIMEOUT_S,
        "take-off",
    )
    t0 = driver.now()
    target = (spec.start_north_m, spec.start_east_m, -spec.start_alt_m)
    while True:
        link.goto_local_ned(*target, yaw_deg=spec.start_yaw_deg % 360.0)
        driver.advance(0.1)
        tel = link.telemetry
        p, v, a = tel.position_ned, tel.velocity_ned, tel.attitude
        if p is not None and v is not None and a is not None:
            close = math.dist((p.x, p.y, p.z), target) < 0.15
            still = math.hypot(v.x, v.y, v.z) < 0.1
            turned = abs(heading_error_deg(math.degrees(a.yaw), spec.start_yaw_deg) * 2) < 4.0
            if close and still and turned:
                return
        if driver.now() - t0 > SETUP_TIMEOUT_S:
            raise RuntimeError("set-up: did not reach the start")


def setup_extnav(driver: Any) -> None:
    """What the station's external-navigation set-up writes, then a reboot (VISO_TYPE is
    read at boot)."""
    link = driver.link
    wanted = [*EXTNAV_PARAMS, ("ARMING_CHECK", float(ARMING_CHECK_ALL_BUT_VISION))]
    for name, value in wanted:
        if link.get_param(name) != value and not link.set_param(name, value).ok:
            raise RuntimeError(f"set-up: could not set {name}")
    _reboot(driver)


def camera_config(spec: RunSpec, *, pad_down_m: float = 0.0) -> SimCameraConfig:
    """The simulated camera of a run: the pad where the stand-in has it (on the ground at
    ``pad_down_m``, true NED), the run's SNR."""
    return SimCameraConfig(
        pad_north_m=PAD_NE[0],
        pad_east_m=PAD_NE[1],
        pad_down_m=pad_down_m,
        pad_heading_deg=spec.pad_heading_deg,
        pad_size_m=PAD_SIZE_M,
        snr_db=spec.snr_db,
        seed=spec.seed,
    )


def fly(
    driver: Any,
    mission: Mission,
    cam_cfg: SimCameraConfig,
    *,
    camera_hz: float = 20.0,
    hide_pad: Callable[[Any, Mission], bool] | None = None,
    after_step: Callable[[Any, Mission], None] | None = None,
    latency_s: float | None = None,
) -> None:
    """Step ``mission`` until it is done: each tick the clock moves ``1 / camera_hz``, a
    frame is rendered and processed, and its result is handed over ``latency_s`` later
    (the pipeline's latency; default the next tick). ``hide_pad(driver, mission)`` True:
    something covers the pad (the frame is the plain ground); ``after_step`` may meddle
    (tests)."""
    threads = cv2.getNumThreads()
    if getattr(driver, "deterministic", False):
        # OpenCV's worker threads may sum floats in a different order from run to run;
        # in a closed loop that grows into a different flight. One thread: same flight.
        cv2.setNumThreads(1)
    try:
        _fly(driver, mission, cam_cfg, camera_hz, latency_s, hide_pad, after_step)
    finally:
        cv2.setNumThreads(threads)


def _fly(
    driver: Any,
    mission: Mission,
    cam_cfg: SimCameraConfig,
    camera_hz: float,
    latency_s: float | None,
    hide_pad: Callable[[Any, Mission], bool] | None,
    after_step: Callable[[Any, Mission], None] | None,
) -> None:
    renderer = PadRenderer(cam_cfg)
    blank: PadRenderer | None = None
    camera = cam_cfg.camera
    reference = _reference()
    dt = 1.0 / camera_hz
    heading, mount = cam_cfg.pad_heading_deg, cam_cfg.mount_rotation
    pending: deque[VisionSample] = deque()
    while not mission.done:
        driver.advance(dt)
        t = driver.now()
        sample = None
        while pending and (latency_s is None or pending[0].t_capture + latency_s <= t + 1e-9):
            sample = pending.popleft()  # the newest of those ready
        pose = driver.camera_pose(t)
        if pose is not None:
            if hide_pad is not None and hide_pad(driver, mission):
                if blank is None:
                    # The same ground with the pad far away: what a covered pad looks like.
                    blank = PadRenderer(replace(cam_cfg, pad_north_m=cam_cfg.pad_north_m + 1e4))
                image, _ = blank.render(pose)
            else:
                image, _ = renderer.render(pose)
            att = driver.link.telemetry.attitude
            hints = (
                {} if att is None else vision_hints(heading, att.roll, att.pitch, att.yaw, mount)
            )
            result = process_frame(image, reference, camera, **hints)
            pending.append(VisionSample(result, camera, t, driver.time_usec()))
        mission.step(t, sample)
        if after_step is not None:
            after_step(driver, mission)


def run_one(
    spec: RunSpec,
    *,
    url: str | None = None,
    camera_hz: float = 20.0,
    config_overrides: dict[str, Any] | None = None,
    hide_pad: Callable[[Any, Mission], bool] | None = None,
    after_step: Callable[[Any, Mission], None] | None = None,
    driver: Any = None,
    latency_s: float | None = None,
) -> RunResult:
    """Fly one landing run (take off, reach the start, land by vision) and measure it.

    The vehicle: ``driver`` (e.g. a :class:`~bench.scenarios.observed.SitlDriver`, closed
    here), else the vehicle at ``url`` in real time, else the stand-in in lockstep.
    """
    wall0 = time.perf_counter()
    if driver is None:
        driver = RealtimeDriver(url) if url else LockstepDriver(spec)
    try:
        driver.connect()
        fly_to_start(driver, spec)
        begin = getattr(driver, "begin_landing", None)
        if begin is not None:
            begin()
        overrides = dict(config_overrides or {})
        overrides.setdefault("pad_down_m", getattr(driver, "ground_ekf_d", 0.0))
        config = LandConfig(
            strategy=spec.strategy,
            pad_north_m=PAD_NE[0],
            pad_east_m=PAD_NE[1],
            pad_heading_deg=spec.pad_heading_deg,
            **overrides,
        )
        start = driver.now()
        mission = land_mission(driver.link, config, now=start, touchdown_truth=driver.touchdown)
        fly(
            driver,
            mission,
            camera_config(spec, pad_down_m=getattr(driver, "ground_true_d", 0.0)),
            camera_hz=camera_hz,
            hide_pad=hide_pad,
            after_step=after_step,
            latency_s=latency_s,
        )
        rec = mission.record
        td = rec.touchdown
        return RunResult(
            spec=spec,
            outcome=rec.outcome or "failed",
            message=rec.message,
            touchdown_error_m=None if td is None else td.error_m,
            heading_error_deg=None if td is None else td.heading_error_deg,
            time_to_land_s=(rec.ended - start) if rec.outcome == "landed" and rec.ended else None,
            frames=rec.frames,
            detections=rec.detections,
            wall_s=time.perf_counter() - wall0,
            states=rec.states,
            record=rec,
            precland=rec.precland,
            precland_texts=list(rec.precland_texts),
            touchdown_source=None if td is None else td.source,
        )
    finally:
        driver.close()


_REFERENCE: Reference | None = None


def _reference() -> Reference:
    global _REFERENCE
    if _REFERENCE is None:
        _REFERENCE = Reference.from_image(make_pad_image(800), PAD_SIZE_M)
    return _REFERENCE


# --- many runs --------------------------------------------------------------------------------
def _quantile(values: list[float], q: float) -> float:
    s = sorted(values)
    pos = (len(s) - 1) * q
    lo, hi = math.floor(pos), math.ceil(pos)
    return s[lo] + (s[hi] - s[lo]) * (pos - lo)


def summarize(strategy: str, results: list[RunResult]) -> dict[str, Any]:
    """The runner's JSON: exactly the keys the issue names (None where nothing landed)."""
    landed = [r for r in results if r.outcome == "landed" and r.touchdown_error_m is not None]
    errs = [r.touchdown_error_m for r in landed if r.touchdown_error_m is not None]
    heads = [r.heading_error_deg for r in landed if r.heading_error_deg is not None]
    times = [r.time_to_land_s for r in landed if r.time_to_land_s is not None]

    def stats(values: list[float], keys: tuple[str, ...]) -> dict[str, float | None]:
        out: dict[str, float | None] = {}
        for k in keys:
            if not values:
                out[k] = None
            elif k == "median":
                out[k] = round(statistics.median(values), 4)
            elif k == "p95":
                out[k] = round(_quantile(values, 0.95), 4)
            else:
                out[k] = round(max(values), 4)
        return out

    return {
        "strategy": strategy,
        "runs": len(results),
        "success_rate": round(sum(r.success for r in results) / len(results), 4)
        if results
        else 0.0,
        "touchdown_error_m": stats(errs, ("median", "p95", "max")),
        "heading_error_deg": stats(heads, ("median", "max")),
        "time_to_land_s": stats(times, ("median", "max")),
        "frames": sum(r.frames for r in results),
        "detections": sum(r.detections for r in results),
    }
