"""``python -m sim.vehicle``: run the ArduCopter stand-in until SIGINT/SIGTERM."""

from __future__ import annotations

import argparse
import signal
import sys
import threading

from sim.vehicle.autopilot import SimVehicle
from sim.vehicle.config import SimConfig
from sim.vehicle.mavlink_server import VehicleServer


def _floats(text: str, count: int, name: str) -> list[float]:
    parts = text.split(",")
    if len(parts) != count:
        raise argparse.ArgumentTypeError(f"{name} needs {count} comma-separated numbers")
    try:
        return [float(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name} needs numbers, got {text!r}") from None


def build_parser() -> argparse.ArgumentParser:
    """The command-line interface."""
    p = argparse.ArgumentParser(
        prog="python -m sim.vehicle",
        description="Simulated ArduCopter speaking MAVLink 2 (a stand-in for ArduPilot SITL).",
    )
    p.add_argument(
        "--mavlink",
        default="tcp:127.0.0.1:5760",
        help="tcp:HOST:PORT (listen), udp:HOST:PORT (send to) or /dev/PATH[,BAUD]",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (wind, sensor noise)")
    p.add_argument("--speedup", type=float, default=1.0, help="sim seconds per wall second")
    p.add_argument(
        "--ready-after",
        type=float,
        default=1.0,
        dest="ready_after",
        help="scale of the readiness timeline (1 = SITL: pre-arm ok ~24 s)",
    )
    p.add_argument(
        "--home",
        type=lambda s: _floats(s, 3, "--home"),
        help="LAT,LON,ALT of home (default: SITL's CMAC)",
    )
    p.add_argument(
        "--pad",
        type=lambda s: _floats(s, 3, "--pad"),
        help="N,E,HEADING_DEG of the helipad relative to home",
    )
    p.add_argument("--wind", type=float, default=0.0, help="mean wind speed, m/s")
    p.add_argument("--wind-dir", type=float, default=0.0, help="wind from, degrees")
    p.add_argument("--gusts", type=float, default=0.0, help="gust standard deviation, m/s")
    p.add_argument("--signing-key", help="MAVLink 2 signing key, 64 hex digits")
    return p


def config_from_args(args: argparse.Namespace) -> SimConfig:
    """A SimConfig from parsed arguments (ValueError on bad values)."""
    kw: dict[str, object] = {
        "seed": args.seed,
        "ready_after_scale": args.ready_after,
        "wind_mps": args.wind,
        "wind_dir_deg": args.wind_dir,
        "gust_mps": args.gusts,
    }
    if args.home:
        kw.update(home_lat=args.home[0], home_lon=args.home[1], home_alt=args.home[2])
    if args.pad:
        kw.update(pad_north=args.pad[0], pad_east=args.pad[1], pad_heading_deg=args.pad[2])
    if args.signing_key:
        try:
            key = bytes.fromhex(args.signing_key)
        except ValueError:
            raise ValueError("--signing-key must be hexadecimal") from None
        kw["signing_key"] = key
    return SimConfig(**kw)  # type: ignore[arg-type]


def main(argv: list[str] | None = None) -> int:
    """Run until SIGINT/SIGTERM; 0 on a clean exit, 2 on bad arguments."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        config = config_from_args(args)
        server = VehicleServer(SimVehicle(config), args.mavlink, speedup=args.speedup)
        server.start()
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    done = threading.Event()

    def _stop(signum: int, _frame: object) -> None:
        done.set()

    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    print(f"stand-in ArduCopter listening on {server.address}", flush=True)
    try:
        while not done.wait(0.5):
            if not server.running:
                print("error: the simulation stopped", file=sys.stderr)
                return 1
    finally:
        server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
