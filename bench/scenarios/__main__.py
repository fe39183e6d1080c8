"""``python -m bench.scenarios land --runs 20 --seed 1 [--strategy plnd|guided] [--wind 3]
[--json] [--mavlink URL]``: land many times, print one JSON summary.

Without ``--mavlink`` each run is the in-process stand-in in lockstep (deterministic for
a seed, faster than real time); with it, the same mission flies the named vehicle in
real time (e.g. ArduCopter SITL; the pad and camera are simulated, the touchdown error
comes from telemetry).
"""

from __future__ import annotations

import argparse
import json
import sys

from backend.missions import STRATEGIES
from bench.scenarios.land import RunSpec, run_one, summarize


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
    results = []
    for i in range(args.runs):
        spec = RunSpec.draw(args.seed, i, args.strategy, args.wind)
        try:
            result = run_one(spec, url=args.mavlink, camera_hz=args.camera_hz)
        except RuntimeError as exc:
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
    summary = summarize(args.strategy, results)
    print(json.dumps(summary, indent=None if args.json else 2))
    return 0 if all(r.success for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
