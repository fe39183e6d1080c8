"""GPS lost over the pad on genuine ArduCopter SITL, landed by the station's ``extnav``
mission with vision in the loop. Prints JSON.

Each run is a fresh SITL (fresh eeprom): the station's own external-navigation set-up
(:meth:`backend.services.params.ParamService.setup_extnav`: parameters, reboot), take-off
on GPS, then :class:`backend.missions.extnav.ExtNavLandMission`. The camera is rendered from
the simulator's true state (SIM_STATE, via the observer on SERIAL2) and every frame goes
through the real pipeline (``pipeline.process_frame``); the mission runs on the vehicle's
clock (a frame every 1/15 s of vehicle time, however long the frame takes on this
machine). GPS goes (SIM_GPS_DISABLE = 1) when the mission holds over the pad on vision
(``settle``), before LAND. Touchdown is measured against SIM_STATE.

The boots run at ``--boot-speedup`` (readiness is the vehicle's business); the flight at
``--speedup`` (<= 1.5 keeps the camera's rate in vehicle time; notes/sitl-findings.md).

``python -m bench.sitl_gpsdenied --runs 10``; ``--pad-lost`` hides the pad at 2.5 m
(the pad-lost-without-GPS behaviour instead of a landing on it); ``--camera-mount`` the
camera's mount the station is told, ``--sim-camera-mount`` where the camera truly sits
when not there (what the station's mount check then says is reported).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from backend.frames import mount_rotation, vision_hints
from backend.link import VehicleLink
from backend.missions import LandConfig, Mount, TouchdownTruth, VisionSample
from backend.missions.extnav import ExtNavLandMission
from backend.missions.geometry import heading_error_deg
from backend.services.events import EventLog
from backend.services.mount_check import MountCheck
from backend.services.params import ParamService
from pipeline import Reference, process_frame
from pipeline.render import make_pad_image
from sim.camera import PadRenderer, SimCameraConfig, VehiclePose
from sim.sitl import Sitl, SitlError, SitlObserver, find_sitl_dir, wait_ready

PAD_NE = (3.0, 2.0)  # metres from the EKF origin (SITL boots at it)
PAD_SIZE_M = 0.55
PAD_HEADING_DEG = 30.0
TAKEOFF_M = 4.0
CAMERA_HZ = 15.0
HIDE_BELOW_M = 2.5
#: bars (issue 12): 10/10, true touchdown median <= 10 cm, max <= 20 cm
BAR_MEDIAN_M, BAR_MAX_M = 0.10, 0.20

Angles = tuple[float, float, float]  # degrees: roll, pitch, yaw


class RunError(RuntimeError):
    """A set-up step failed (the run did not get to land)."""


def _wall(sim_s: float, speedup: float) -> float:
    return sim_s / speedup * 3.0 + 20.0


def _wait_link(link: VehicleLink, up: bool, timeout: float) -> bool:
    return link.wait_until(lambda t: (t.state.value == "up") == up, timeout)


def _reboot_and_wait(link: VehicleLink, obs: SitlObserver, speedup: float) -> None:
    """After the set-up's reboot: the link back, readiness since this boot."""
    if not _wait_link(link, True, _wall(30, speedup)):
        raise RunError("the link did not come back after the reboot")
    wait_ready(obs, timeout=_wall(90, speedup))
    gps = obs.wait_text(r"^EKF3 IMU0 is using GPS$", 0, since=obs.epoch_texts)
    if gps is None or not link.wait_until(
        lambda t: (t.local_position_rx_monotonic or 0.0) > gps.rx - 0.5, _wall(10, speedup)
    ):
        raise RunError("no position estimate after the reboot")


def _reached(obs: SitlObserver, boot_s: float) -> Callable[[], bool]:
    return lambda: (obs.boot_s or 0.0) >= boot_s


def _camera_config(
    seed: int, snr_db: float, ground_d: float = 0.0, mount_deg: Angles = (0.0, 0.0, 0.0)
) -> SimCameraConfig:
    return SimCameraConfig(
        mount_rotation=mount_rotation(*mount_deg),
        pad_north_m=PAD_NE[0],
        pad_east_m=PAD_NE[1],
        pad_down_m=ground_d,
        pad_heading_deg=PAD_HEADING_DEG,
        pad_size_m=PAD_SIZE_M,
        snr_db=snr_db,
        seed=seed,
    )


def _pipeline_latency_ms(seed: int, snr_db: float, frames: int = 15) -> float:
    """Render and process a few frames over the pad: the capture -> result time the
    station's set-up would have measured (its VISO_DELAY_MS), median, on this machine."""
    cfg = _camera_config(seed, snr_db)
    renderer = PadRenderer(cfg)
    reference = Reference.from_image(make_pad_image(800), PAD_SIZE_M)
    times = []
    for i in range(frames):
        pose = VehiclePose((PAD_NE[0] + 0.02 * i, PAD_NE[1], -3.0), 0.0, 0.0, 0.5, 0.0)
        w0 = time.perf_counter()
        image, _ = renderer.render(pose)
        process_frame(image, reference, cfg.camera)
        times.append((time.perf_counter() - w0) * 1000.0)
    return statistics.median(times)


def fly_once(
    *,
    seed: int,
    boot_speedup: float = 10.0,
    speedup: float = 1.0,
    pad_lost: bool = False,
    snr_db: float = 25.0,
    mount_deg: Angles = (0.0, 0.0, 0.0),
    true_mount_deg: Angles | None = None,
) -> dict[str, Any]:
    """One fresh SITL: set up, take off on GPS, land with the extnav mission, GPS off over
    the pad; returns the run's figures (``error`` when a set-up step failed).
    ``mount_deg``: the camera's mount, as ``--camera-mount`` takes it (the station is
    told it, as the mission); ``true_mount_deg``: where the camera truly sits, when not
    there."""
    true_mount = mount_deg if true_mount_deg is None else true_mount_deg
    out: dict[str, Any] = {
        "seed": seed,
        "pad_lost": pad_lost,
        "camera_mount_deg": mount_deg,
        "true_camera_mount_deg": true_mount,
    }
    wall0 = time.monotonic()
    with Sitl(speedup=boot_speedup) as sitl:
        link = VehicleLink(sitl.url)
        obs = SitlObserver(sitl.serial2_url)
        link.start()
        obs.start()
        try:
            out.update(
                _fly(
                    link,
                    obs,
                    seed,
                    (boot_speedup, speedup),
                    pad_lost,
                    snr_db,
                    (mount_deg, true_mount),
                )
            )
        except (RunError, SitlError) as exc:
            out["error"] = str(exc)
        finally:
            link.close()
            obs.close()
    out["wall_s"] = round(time.monotonic() - wall0, 1)
    return out


def _fly(
    link: VehicleLink,
    obs: SitlObserver,
    seed: int,
    speedups: tuple[float, float],
    pad_lost: bool,
    snr_db: float,
    mounts: tuple[Angles, Angles],
) -> dict[str, Any]:
    boot_speedup, speedup = speedups
    mount_deg, true_mount_deg = mounts  # (told; where the camera truly sits)
    out: dict[str, Any] = {}
    if not _wait_link(link, True, 30):
        raise RunError("the link did not come up")
    wait_ready(obs, timeout=_wall(90, boot_speedup))
    # the station's own set-up: parameters, then a reboot (VISO_TYPE is read at boot)
    latency_ms = _pipeline_latency_ms(seed, snr_db)
    out["pipeline_latency_ms"] = round(latency_ms, 1)
    params = ParamService(link, EventLog(None), latency_ms=lambda: latency_ms)
    epoch = obs.epoch_texts
    setup = params.setup_extnav()
    out["setup"] = setup["detail"]
    if not setup["ok"]:
        raise RunError(f"set-up: {setup['detail']}")
    if not obs.wait(lambda: obs.epoch_texts != epoch, _wall(20, boot_speedup)):
        raise RunError("the vehicle did not reboot")
    _reboot_and_wait(link, obs, boot_speedup)
    origin = obs.ekf_origin()
    start = obs.truth(origin)
    if origin is None or start is None:
        raise RunError("no EKF origin or SIM_STATE")
    ground_d = start.position_ned[2]
    ekf_ground = link.telemetry.position_ned
    pad_down = ekf_ground.z if ekf_ground is not None else 0.0
    if not link.set_param("SIM_SPEEDUP", speedup).ok:
        raise RunError("SIM_SPEEDUP refused")
    for _ in range(5):
        if link.set_mode("GUIDED").ok and link.wait_until(lambda t: t.mode == "GUIDED", 3):
            break
    arm = link.arm()
    if not arm.ok:
        raise RunError(f"arm: {arm.detail}")
    takeoff = link.takeoff(TAKEOFF_M)
    if not takeoff.ok:
        raise RunError(f"takeoff: {takeoff.detail}")

    def true_height() -> float:
        t = obs.truth(origin)
        return math.nan if t is None else ground_d - t.position_ned[2]

    if not obs.wait(lambda: true_height() > TAKEOFF_M - 0.5, _wall(30, speedup)):
        raise RunError("never climbed")

    config = LandConfig(
        strategy="extnav",
        pad_north_m=PAD_NE[0],
        pad_east_m=PAD_NE[1],
        pad_down_m=pad_down,
        pad_heading_deg=PAD_HEADING_DEG,
        approach_alt_m=TAKEOFF_M,
        mount=Mount(rotation=mount_rotation(*mount_deg)),
    )

    def touchdown() -> TouchdownTruth | None:
        t = obs.truth(origin)
        if t is None:
            return None
        return TouchdownTruth(t.position_ned[0], t.position_ned[1], math.degrees(t.yaw))

    cam_cfg = _camera_config(seed, snr_db, ground_d, true_mount_deg)
    renderer = PadRenderer(cam_cfg)
    blank = PadRenderer(replace(cam_cfg, pad_north_m=cam_cfg.pad_north_m + 1e4))
    camera = cam_cfg.camera
    reference = Reference.from_image(make_pad_image(800), PAD_SIZE_M)
    boot = obs.boot_s or 0.0
    mission = ExtNavLandMission(link, config, now=boot, touchdown_truth=touchdown)
    mark = obs.text_count
    gps_off_at: float | None = None
    hidden_at: tuple[float, float, float] | None = None
    next_frame = boot
    frame_times: list[float] = []
    mount = mount_rotation(*mount_deg)
    told: list[dict[str, Any]] = []  # what the station's mount check says
    mount_check = MountCheck(
        lambda _kind, text, data: told.append({"text": text, **(data or {})}), mount_deg
    )
    limit = time.monotonic() + _wall(config.timeout_s, speedup)
    while not mission.done:
        if time.monotonic() > limit:
            raise RunError(f"the mission did not end (state {mission.state})")
        if not obs.wait(_reached(obs, next_frame), 5.0):
            raise RunError("the vehicle's clock stopped")
        truth, t_capture = obs.truth(origin), obs.boot_s or 0.0
        next_frame = max(next_frame + 1.0 / CAMERA_HZ, t_capture)
        if truth is None:
            continue
        hide = pad_lost and mission.state == "descend" and true_height() < HIDE_BELOW_M
        if hide and hidden_at is None:
            hidden_at = (t_capture, truth.position_ned[0], truth.position_ned[1])
        pose = VehiclePose(truth.position_ned, truth.roll, truth.pitch, truth.yaw, t_capture)
        w0 = time.perf_counter()
        image, _ = (blank if hidden_at is not None else renderer).render(pose)
        att = link.telemetry.attitude
        hints = (
            {}
            if att is None
            else vision_hints(PAD_HEADING_DEG, att.roll, att.pitch, att.yaw, mount)
        )
        result = process_frame(image, reference, camera, **hints)
        frame_times.append(time.perf_counter() - w0)
        mount_check.observe(result)
        sample = VisionSample(result, camera, t_capture, max(1, round(t_capture * 1e6)))
        mission.step(max(mission.now, obs.boot_s or 0.0), sample)
        if gps_off_at is None and mission.state in ("settle", "descend"):
            if not link.set_param("SIM_GPS_DISABLE", 1).ok:
                raise RunError("SIM_GPS_DISABLE refused")
            gps_off_at = obs.boot_s
    rec = mission.record
    td = rec.touchdown
    gps = link.telemetry.gps
    out.update(
        {
            "outcome": rec.outcome,
            "message": rec.message,
            "states": [s["state"] for s in rec.states],
            "touchdown_error_m": None if td is None else round(td.error_m, 4),
            "heading_error_deg": None
            if td is None
            else round(abs(heading_error_deg(td.yaw_deg, PAD_HEADING_DEG)), 2),
            "time_s": round((rec.ended or mission.now) - rec.started, 2),
            "frames": rec.frames,
            "detections": rec.detections,
            "vision_positions_sent": link.vision_positions_sent,
            "vision_speeds_sent": link.vision_speeds_sent,
            "gps_off_at_boot_s": gps_off_at,
            "gps_fix_type_at_end": None if gps is None else gps.fix_type,
            "frame_s_median": round(statistics.median(frame_times), 4) if frame_times else None,
            "texts": [t.text for t in obs.texts(mark)],
            "mount_check": told,
        }
    )
    if hidden_at is not None and td is not None:
        out["pad_hidden_at_height_m"] = HIDE_BELOW_M
        out["drift_after_pad_lost_m"] = round(
            math.hypot(td.north_m - hidden_at[1], td.east_m - hidden_at[2]), 3
        )
    return out


def summarize(runs: list[dict[str, Any]], pad_lost: bool) -> dict[str, Any]:
    """Counts, touchdown statistics and the bars (for landings on the pad)."""
    wanted = "landed_in_place" if pad_lost else "landed"
    landed = [r for r in runs if r.get("outcome") == wanted and r["touchdown_error_m"] is not None]
    errors = [r["touchdown_error_m"] for r in landed]
    summary: dict[str, Any] = {
        "runs": len(runs),
        wanted: len(landed),
        "touchdown_error_m": None
        if not errors
        else {"median": round(statistics.median(errors), 4), "max": round(max(errors), 4)},
        "ekf_failsafe_runs": sum(
            any("EKF Failsafe" in t for t in r.get("texts", [])) for r in runs
        ),
    }
    if not pad_lost:
        summary["bars"] = {
            "all_landed": len(landed) == len(runs),
            "median_le_0.10_m": bool(errors) and statistics.median(errors) <= BAR_MEDIAN_M,
            "max_le_0.20_m": bool(errors) and max(errors) <= BAR_MAX_M,
        }
    else:
        drifts = [r["drift_after_pad_lost_m"] for r in runs if "drift_after_pad_lost_m" in r]
        summary["drift_after_pad_lost_m"] = (
            None
            if not drifts
            else {"median": round(statistics.median(drifts), 3), "max": max(drifts)}
        )
    return summary


def _angles(text: str) -> Angles:
    try:
        roll, pitch, yaw = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected ROLL,PITCH,YAW in degrees, got {text!r}"
        ) from None
    return (roll, pitch, yaw)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.sitl_gpsdenied", description=__doc__)
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--speedup", type=float, default=1.0, help="flight speed-up (<= 1.5)")
    parser.add_argument("--boot-speedup", type=float, default=10.0)
    parser.add_argument("--pad-lost", action="store_true", help="hide the pad at 2.5 m")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--camera-mount",
        type=_angles,
        default=(0.0, 0.0, 0.0),
        metavar="ROLL,PITCH,YAW",
        help="the camera's mount in degrees, as the station's --camera-mount",
    )
    parser.add_argument(
        "--sim-camera-mount",
        type=_angles,
        default=None,
        metavar="ROLL,PITCH,YAW",
        help="where the camera truly sits, when not on --camera-mount",
    )
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error("--runs must be >= 1")
    if not 0 < args.speedup <= 1.5:
        parser.error("--speedup must be in (0, 1.5]: the camera's rate is in vehicle time")
    if find_sitl_dir() is None:
        print(json.dumps({"error": "no SITL found"}))
        return 2
    runs = []
    for i in range(args.runs):
        run = fly_once(
            seed=args.seed + i,
            boot_speedup=args.boot_speedup,
            speedup=args.speedup,
            pad_lost=args.pad_lost,
            mount_deg=args.camera_mount,
            true_mount_deg=args.sim_camera_mount,
        )
        runs.append(run)
        print(
            json.dumps(
                {
                    "progress": i + 1,
                    **{k: run.get(k) for k in ("outcome", "touchdown_error_m", "error")},
                }
            ),
            file=sys.stderr,
        )
    summary = summarize(runs, args.pad_lost)
    print(
        json.dumps(
            {
                "bench": "sitl_gpsdenied",
                "firmware": "ArduCopter 4.5.6 SITL",
                "speedup": args.speedup,
                "boot_speedup": args.boot_speedup,
                "camera_hz_vehicle_time": CAMERA_HZ,
                "pad_ne_m": PAD_NE,
                "pad_heading_deg": PAD_HEADING_DEG,
                "takeoff_m": TAKEOFF_M,
                "pad_lost": args.pad_lost,
                "summary": summary,
                "runs": runs,
            }
        )
    )
    ok = summary.get("landed_in_place" if args.pad_lost else "landed") == len(runs)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
