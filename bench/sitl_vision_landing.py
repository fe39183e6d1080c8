"""GPS-denied landing on genuine ArduCopter SITL with a vision stand-in. Prints JSON.

The recipe phase 2 builds on, flown for real (notes/sitl-findings.md explains it):

1. parameters, then a reboot (VISO_TYPE is read at boot): VISO_TYPE = 1 (MAVLink),
   EK3_SRC2_POSXY = 6 (ExternalNav), EK3_SRC2_VELXY = 6 (ExternalNav, from
   VISION_SPEED_ESTIMATE; 0 with ``--no-speed``), EK3_SRC2_POSZ = 1 (baro),
   EK3_SRC2_YAW = 1 (compass); source set 1 stays GPS;
2. VISION_POSITION_ESTIMATE (and VISION_SPEED_ESTIMATE) at 25 Hz of simulated time,
   in the EKF origin's NED frame, stamped with the vehicle's clock, from the
   simulator's truth (SIM_STATE) plus ``--noise-m`` of Gaussian noise: a stand-in
   for the pad's pose. Arming needs it ("Arm: VisOdom: not healthy" otherwise);
3. take off on GPS in GUIDED, fly over the pad, hold;
4. MAV_CMD_SET_EKF_SOURCE_SET 2; SIM_GPS_DISABLE = 1; hold over the pad on vision;
5. LAND; touchdown measured from SIM_STATE against the pad's true position.

``python -m bench.sitl_vision_landing --runs 3 --speedup 5``
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from typing import Any

from backend.link import VehicleLink
from sim.sitl import Sitl, SitlError, SitlObserver, find_sitl_dir, wait_ready
from sim.vision_feed import VisionStandIn

MAV_CMD_SET_EKF_SOURCE_SET = 42007
PAD_NE = (3.0, 2.0)  # metres from the EKF origin
ALT_M = 5.0

VISION_PARAMS: dict[str, float] = {
    "VISO_TYPE": 1,
    "EK3_SRC2_POSXY": 6,
    "EK3_SRC2_VELXY": 6,
    "EK3_SRC2_POSZ": 1,
    "EK3_SRC2_YAW": 1,
}


def _wait_sim(obs: SitlObserver, seconds: float, timeout: float = 120.0) -> None:
    start = obs.boot_s or 0.0
    obs.wait(lambda: (obs.boot_s or 0.0) >= start + seconds, timeout)


def _xy_error(obs: SitlObserver, origin: tuple[float, float, float]) -> float:
    truth = obs.truth(origin)
    return math.inf if truth is None else math.dist(truth.position_ned[:2], PAD_NE)


def fly_once(speedup: float, noise_m: float, speed: bool, seed: int) -> dict[str, Any]:
    """One fresh SITL: set up, take off on GPS, lose GPS over the pad, land on vision."""
    out: dict[str, Any] = {"seed": seed}
    with Sitl(speedup=speedup) as sitl:
        link = VehicleLink(sitl.url)
        link.start()
        obs = SitlObserver(sitl.serial2_url).start()
        vision: VisionStandIn | None = None
        try:
            if not link.wait_until(lambda t: t.state.value == "up", 30):
                raise SitlError("the link did not come up")
            for name, value in VISION_PARAMS.items():
                value = value if (name != "EK3_SRC2_VELXY" or speed) else 0
                result = link.set_param(name, value)
                if not result.ok:
                    raise SitlError(f"{name}: {result.detail}")
            if not link.reboot().ok:
                raise SitlError("reboot refused")
            link.wait_until(lambda t: t.state.value != "up", 10)
            if not link.wait_until(lambda t: t.state.value == "up", 60):
                raise SitlError("the link did not come back after the reboot")
            wait_ready(obs, timeout=240.0 / speedup + 60)
            origin = obs.ekf_origin()
            assert origin is not None
            vision = VisionStandIn(obs, origin, noise_m=noise_m, speed=speed, seed=seed).start()
            _wait_sim(obs, 2.0)
            if not (
                link.set_mode("GUIDED").ok and link.wait_until(lambda t: t.mode == "GUIDED", 10)
            ):
                raise SitlError("GUIDED not confirmed")
            arm = link.arm()
            if not arm.ok:
                raise SitlError(f"arm: {arm.detail}")
            takeoff = link.takeoff(ALT_M)
            if not takeoff.ok:
                raise SitlError(f"takeoff: {takeoff.detail}")
            link.wait_until(lambda t: (t.relative_alt_m or 0.0) > ALT_M - 0.3, 60)
            link.goto_local_ned(PAD_NE[0], PAD_NE[1], -ALT_M)
            _wait_sim(obs, 10.0)
            out["hold_on_gps_error_m"] = round(_xy_error(obs, origin), 3)
            texts_from = obs.text_count
            before = link.telemetry.position_ned
            out["source_set_2"] = obs.command(MAV_CMD_SET_EKF_SOURCE_SET, (2,), 5.0)
            _wait_sim(obs, 3.0)
            after = link.telemetry.position_ned
            if before is not None and after is not None:
                out["estimate_step_at_switch_m"] = round(
                    math.dist((before.x, before.y), (after.x, after.y)), 3
                )
            gps = link.set_param("SIM_GPS_DISABLE", 1)
            out["gps_disabled"] = gps.ok
            errors = []
            end = (obs.boot_s or 0.0) + 20.0
            while (obs.boot_s or 0.0) < end:
                errors.append(_xy_error(obs, origin))
                _wait_sim(obs, 0.5)
            out["hold_on_vision_error_m"] = {
                "median": round(statistics.median(errors), 3),
                "max": round(max(errors), 3),
            }
            out["gps_fix_type"] = (
                None if link.telemetry.gps is None else link.telemetry.gps.fix_type
            )
            out["mode_before_land"] = link.telemetry.mode
            land = link.land()
            out["land"] = land.result_name
            link.wait_until(lambda t: not t.armed, 180)
            out["touchdown_error_m"] = round(_xy_error(obs, origin), 3)
            out["texts_after_switch"] = [t.text for t in obs.texts(texts_from)]
            out["vision_messages"] = vision.sent
        except SitlError as exc:
            out["error"] = str(exc)
        finally:
            if vision is not None:
                vision.close()
            link.close()
            obs.close()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.sitl_vision_landing", description=__doc__
    )
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--speedup", type=float, default=5.0)
    parser.add_argument("--noise-m", type=float, default=0.02, help="vision noise (std, m)")
    parser.add_argument("--no-speed", action="store_true", help="no VISION_SPEED_ESTIMATE")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error("--runs must be >= 1")
    if find_sitl_dir() is None:
        print(json.dumps({"error": "no SITL found"}))
        return 2
    runs = [
        fly_once(args.speedup, args.noise_m, not args.no_speed, seed) for seed in range(args.runs)
    ]
    errors = [r["touchdown_error_m"] for r in runs if "touchdown_error_m" in r]
    summary = {
        "runs": len(runs),
        "landed": len(errors),
        "touchdown_error_m": None
        if not errors
        else {"median": round(statistics.median(errors), 3), "max": round(max(errors), 3)},
    }
    print(
        json.dumps(
            {
                "speedup": args.speedup,
                "noise_m": args.noise_m,
                "vision_speed": not args.no_speed,
                "pad_ne_m": PAD_NE,
                "summary": summary,
                "runs": runs,
            }
        )
    )
    return 0 if len(errors) == len(runs) else 1


if __name__ == "__main__":
    sys.exit(main())
