"""How fast can genuine ArduCopter SITL run and stay faithful? Prints JSON.

For each ``--speedup``, from a fresh eeprom: the readiness timeline (wall and boot
seconds), then a GUIDED flight through the project's VehicleLink (arm, take off to
5 m, hold 10 s, LAND) measured against the simulator's truth (SIM_STATE). Reported
per speed-up: the speed actually achieved (vehicle clock / wall clock), SITL's CPU
share, the telemetry the link received per simulated second against what it asked
for, link losses, command round trips, climb time, hold error and touchdown offset
(all in simulated seconds and metres, so they should not change with the speed-up
while the simulation stays faithful).

``python -m bench.sitl_speedup --speedups 1,5,10,20``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from typing import Any

from backend.link import VehicleLink
from sim.sitl import Sitl, SitlError, SitlObserver, find_sitl_dir, wait_ready

_TICKS = os.sysconf("SC_CLK_TCK")


def _cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICKS


def _wait_boot(obs: SitlObserver, seconds: float, timeout: float) -> None:
    start = obs.boot_s or 0.0
    obs.wait(lambda: (obs.boot_s or 0.0) >= start + seconds, timeout)


def run_one(speedup: float, hold_s: float = 10.0) -> dict[str, Any]:
    """One fresh SITL at ``speedup``: readiness and a GUIDED flight; the figures."""
    out: dict[str, Any] = {"speedup": speedup}
    timeout = 120.0 / min(speedup, 1.0) + 60.0
    with Sitl(speedup=speedup) as sitl:
        assert sitl.pid is not None
        t0 = time.monotonic()
        link = VehicleLink(sitl.url)
        link.start()
        losses: list[str] = []
        link.subscribe(lambda e: losses.append(e.kind) if e.kind == "link_lost" else None)
        obs = SitlObserver(sitl.serial2_url).start()
        try:
            ready = wait_ready(obs, timeout=timeout, since=t0)
            out["readiness"] = ready.to_dict()
            b0 = obs.boot_s
            cpu0, w0 = _cpu_s(sitl.pid), time.monotonic()
            if link.set_mode("GUIDED").ok and not link.wait_until(lambda t: t.mode == "GUIDED", 10):
                out["error"] = "GUIDED not confirmed"
                return out
            arm = link.arm()
            takeoff = link.takeoff(5.0)
            out["arm"] = arm.result_name
            out["takeoff"] = takeoff.result_name
            out["command_round_trip_ms"] = [
                round(arm.elapsed_s * 1000, 2),
                round(takeoff.elapsed_s * 1000, 2),
            ]
            if not (arm.ok and takeoff.ok):
                out["error"] = f"arm {arm.detail}; takeoff {takeoff.detail}"
                return out
            origin = obs.ekf_origin()
            start = obs.truth(origin)
            tb = obs.boot_s or 0.0
            obs.wait(lambda: _true_alt(obs, origin) >= 4.5, 60.0 / min(speedup, 1.0) + 30)
            out["climb_to_4_5_m_sim_s"] = round((obs.boot_s or 0.0) - tb, 2)
            _wait_boot(obs, 3.0, 30.0)
            points, rates, lags = [], [], []
            hold_end = (obs.boot_s or 0.0) + hold_s
            while (obs.boot_s or 0.0) < hold_end:
                truth = obs.truth(origin)
                if truth is not None:
                    points.append(truth.position_ned)
                rates.append(link.telemetry.msgs_per_s)
                tel = link.telemetry
                if tel.local_position_time_boot_ms is not None and obs.boot_s is not None:
                    lags.append(obs.boot_s - tel.local_position_time_boot_ms / 1000.0)
                obs.wait_message("SIM_STATE", 5.0)
            mean = [statistics.fmean(p[i] for p in points) for i in range(3)]
            spread = [math.dist(p, mean) for p in points]
            drift = None if start is None else math.dist(mean[:2], start.position_ned[:2])
            out["hold"] = {
                "true_alt_m": round(-mean[2], 3),
                "xy_from_takeoff_m": None if drift is None else round(drift, 3),
                "spread_median_m": round(statistics.median(spread), 4),
                "spread_max_m": round(max(spread), 4),
            }
            sim_s = (obs.boot_s or 0.0) - (b0 or 0.0)
            wall_s = time.monotonic() - w0
            land = link.land()
            out["land"] = land.result_name
            link.wait_until(lambda t: not t.armed, 120.0 / min(speedup, 1.0) + 60)
            end = obs.truth(origin)
            out["touchdown_offset_m"] = (
                None
                if end is None or start is None
                else round(math.dist(end.position_ned[:2], start.position_ned[:2]), 3)
            )
            cpu1, w1 = _cpu_s(sitl.pid), time.monotonic()
            out["achieved_speedup"] = round(sim_s / wall_s, 2) if wall_s > 0 else None
            out["sitl_cpu_share"] = round((cpu1 - cpu0) / (w1 - w0), 2)
            # What the link received per simulated second while holding (a 2 s wall-clock
            # window: coarse at high speed-ups, where the hold lasts a fraction of it).
            speed = sim_s / wall_s if wall_s > 0 else math.nan
            out["link_msgs_per_sim_s"] = round(statistics.median(rates) / speed, 1)
            # How far the link's LOCAL_POSITION_NED trails the vehicle's clock (as the
            # observer sees it), in simulated seconds: grows when the link falls behind.
            out["link_position_lag_sim_s"] = {
                "median": round(statistics.median(lags), 3),
                "max": round(max(lags), 3),
            }
            out["link_losses"] = len(losses)
            out["link_handler_errors"] = link.telemetry.handler_errors
            out["total_wall_s"] = round(time.monotonic() - t0, 1)
        except SitlError as exc:
            out["error"] = str(exc)
        finally:
            link.close()
            obs.close()
    return out


def _true_alt(obs: SitlObserver, origin: tuple[float, float, float] | None) -> float:
    truth = obs.truth(origin)
    return -math.inf if truth is None else -truth.position_ned[2]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.sitl_speedup", description=__doc__)
    parser.add_argument("--speedups", default="1,5,10,20,40")
    parser.add_argument("--hold-s", type=float, default=10.0)
    args = parser.parse_args(argv)
    if find_sitl_dir() is None:
        print(json.dumps({"error": "no SITL found"}))
        return 2
    results = [run_one(float(s), args.hold_s) for s in args.speedups.split(",")]
    print(json.dumps({"cpus": os.cpu_count(), "load_avg": os.getloadavg(), "runs": results}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
