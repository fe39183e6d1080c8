"""``python -m bench.scenarios land --runs 20 --seed 1 [--strategy plnd|guided] [--wind 3]
[--json] [--mavlink URL | --vehicle sitl]``: land many times, print one JSON summary.

By default each run is the in-process stand-in in lockstep (deterministic for a seed,
faster than real time). ``--vehicle sitl``: each run starts genuine ArduCopter SITL of
its own (fresh eeprom), sets it up at ``--setup-speedup`` (waiting for its real
readiness; for plnd the PLND parameters and a reboot), then lands with the camera in the
loop at ``--flight-speedup`` on the vehicle's clock; the camera is rendered from, and
the touchdown measured against, the simulator's true state (SIM_STATE); the JSON adds
every run. There is no wind on SITL (its own defaults). ``--mavlink URL``: fly that
vehicle in real time (camera from telemetry, touchdown from telemetry).
"""

from __future__ import annotations

import argparse
import json
import sys

from backend.missions import STRATEGIES
from bench.scenarios.land import RunSpec, run_one, summarize
from bench.scenarios.observed import SitlDriver
from sim.sitl import SitlError, find_sitl_dir


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m bench.scenarios")
    sub = p.add_subparsers(dest="scenario", required=True)
    land = sub.add_parser("land", help="land on the pad by vision, many times")
    land.add_argument("--runs", type=int, default=20, help="how many runs (default 20)")
    land.add_argument("--seed", type=int, default=1, help="seed of the random starts")
    land.add_argument("--strategy", choices=STRATEGIES, default="plnd")
    land.add_argument("--wind", type=float, default=3.0, help="largest mean wind, m/s")
    land.add_argument("--camera-hz", type=float, default=20.0, help="camera and control rate")
    land.add_argument("--json", action="store_true", help="print only the JSON summary")
    land.add_argument("--mavlink", default=None, help="fly this vehicle instead (real time)")
    land.add_argument(
        "--vehicle", choices=("standin", "sitl"), default="standin", help="default: standin"
    )
    land.add_argument("--setup-speedup", type=float, default=10.0, help="SITL, before landing")
    land.add_argument(
        "--flight-speedup", type=float, default=1.0, help="SITL, with the camera in the loop"
    )
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the scenario; exit status 0 when every run landed on the pad."""
    args = _parser().parse_args(argv)
    if not 1 <= args.runs <= 10000:
        print("--runs must be within 1..10000", file=sys.stderr)
        return 2
    if not 0.0 <= args.wind <= 15.0:
        print("--wind must be within 0..15 m/s", file=sys.stderr)
        return 2
    if not 1.0 <= args.camera_hz <= 100.0:
        print("--camera-hz must be within 1..100", file=sys.stderr)
        return 2
    sitl = args.vehicle == "sitl"
    if sitl and args.mavlink:
        print("--vehicle sitl starts its own vehicle: no --mavlink", file=sys.stderr)
        return 2
    for name in ("setup_speedup", "flight_speedup"):
        if not 0.1 <= getattr(args, name) <= 50.0:
            print(f"--{name.replace('_', '-')} must be within 0.1..50", file=sys.stderr)
            return 2
    if sitl and find_sitl_dir() is None:
        print("no ArduCopter SITL (../shared/sitl or $VISLAND_SITL_DIR)", file=sys.stderr)
        return 2
    results = []
    for i in range(args.runs):
        # SITL has no wind of the runner's: draw without it (the same starts otherwise)
        spec = RunSpec.draw(args.seed, i, args.strategy, 0.0 if sitl else args.wind)
        try:
            driver = (
                SitlDriver(setup_speedup=args.setup_speedup, flight_speedup=args.flight_speedup)
                if sitl
                else None
            )
            result = run_one(spec, url=args.mavlink, camera_hz=args.camera_hz, driver=driver)
        except (RuntimeError, SitlError) as exc:
            print(f"run {i}: could not fly: {exc}", file=sys.stderr)
            return 1
        results.append(result)
        if not args.json:
            err = result.touchdown_error_m
            print(
                f"run {i:3d}: {result.outcome:9s} "
                f"{'-' if err is None else f'{err * 100:5.1f} cm'}  "
                f"wind {spec.wind_mps:.1f} m/s  snr {spec.snr_db:.0f} dB  "
                f"({result.wall_s:.1f} s)  {result.message}",
                file=sys.stderr,
                flush=True,
            )
    summary: dict[str, object] = summarize(args.strategy, results)
    if sitl:
        summary = {
            **summary,
            "vehicle": "ArduCopter SITL (fresh eeprom per run)",
            "touchdown_measured_from": "SIM_STATE (simulator truth, EKF origin frame)",
            "setup_speedup": args.setup_speedup,
            "flight_speedup": args.flight_speedup,
            "camera_hz": args.camera_hz,
            "precland_accepted": sum(r.precland == "accepted" for r in results),
            "per_run": [r.to_dict() for r in results],
        }
    print(json.dumps(summary, indent=None if args.json else 2))
    return 0 if all(r.success for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
