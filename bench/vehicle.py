"""Benchmark of the stand-in: speed of the simulation and precision-landing accuracy.

``python -m bench.vehicle [--seed N] [--json]`` prints one JSON object:
physics steps per second, how much faster than real time the bare sim and a lockstep
MAVLink server with typical telemetry run, and the touchdown error of a precision
landing (truth-fed LANDING_TARGET at 10 Hz over real TCP) in calm air and in wind.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim.vehicle.autopilot import SimVehicle
from sim.vehicle.config import SimConfig
from sim.vehicle.mavlink_server import VehicleServer
from sim.vehicle.physics import ned_to_body


def bare_speed(seed: int, sim_seconds: float = 20.0) -> dict[str, float]:
    """Hovering flight without I/O: steps per wall second and real-time factor."""
    v = SimVehicle(SimConfig(seed=seed, ready_after_scale=0.01, wind_mps=3, gust_mps=1))
    v.step(1.0)
    v.set_mode(4)
    v.arm()
    v.takeoff(5.0)
    t0 = time.perf_counter()
    v.step(sim_seconds)
    wall = time.perf_counter() - t0
    return {
        "steps_per_s": sim_seconds * v.config.physics_hz / wall,
        "realtime_factor": sim_seconds / wall,
    }


def precision_landing(seed: int, wind: float, gusts: float) -> dict[str, float]:
    """LAND from 6 m, 3.6 m off the pad, LANDING_TARGET at 10 Hz over TCP (lockstep)."""
    pad = (3.0, -2.0)
    sim = SimVehicle(
        SimConfig(
            seed=seed,
            ready_after_scale=0.01,
            wind_mps=wind,
            gust_mps=gusts,
            pad_north=pad[0],
            pad_east=pad[1],
        )
    )
    server = VehicleServer(sim, "tcp:127.0.0.1:0", lockstep=True)
    server.start()
    m = mavutil.mavlink_connection(server.address, source_system=255, autoreconnect=False)
    sent = 0

    def send(method: str, *args: object) -> None:
        nonlocal sent
        getattr(m.mav, method)(*args)
        sent += 1
        if not server.wait_inbound(sent, timeout=5.0):
            raise RuntimeError("the stand-in did not read a message")

    def run(seconds: float) -> None:
        for _ in range(round(seconds / 0.05)):
            server.advance(0.05)
            while m.recv_msg() is not None:
                pass

    try:
        send("request_data_stream_send", 1, 1, mavlink.MAV_DATA_STREAM_ALL, 10, 1)
        for name in ("PLND_ENABLED", "PLND_TYPE"):
            send("param_set_send", 1, 1, name.encode(), 1, mavlink.MAV_PARAM_TYPE_INT8)
        send(
            "command_long_send",
            1,
            1,
            mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
            0,
            1,
            0,
            0,
            0,
            0,
            0,
            0,
        )
        run(1.0)
        send("command_long_send", 1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)
        send(
            "command_long_send", 1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0
        )
        run(0.1)
        send("command_long_send", 1, 1, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 6)
        run(12.0)
        send("command_long_send", 1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, 1, 9, 0, 0, 0, 0, 0)
        t0 = time.perf_counter()
        sim_t0 = sim.time_s
        while sim.armed and sim.time_s < sim_t0 + 120:
            t = sim.truth
            if t.position_ned[2] < -0.3:
                rel = (pad[0] - t.position_ned[0], pad[1] - t.position_ned[1], -t.position_ned[2])
                x, y, z = ned_to_body(sim.body.quat, rel)
                send(
                    "landing_target_send",
                    round(sim.time_s * 1e6),
                    0,
                    12,
                    0,
                    0,
                    math.sqrt(x * x + y * y + z * z),
                    0,
                    0,
                    x,
                    y,
                    z,
                    (1, 0, 0, 0),
                    0,
                    1,
                )
            run(0.1)
        wall = time.perf_counter() - t0
        landed = sim.truth.landed_at
        return {
            "wind_mps": wind,
            "gust_mps": gusts,
            "touchdown_error_m": math.dist(landed, pad) if landed else float("nan"),
            "landing_sim_s": sim.time_s - sim_t0,
            "lockstep_realtime_factor": (sim.time_s - sim_t0) / wall,
            "disarmed": not sim.armed,
        }
    finally:
        m.close()
        server.stop()


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print JSON."""
    p = argparse.ArgumentParser(prog="python -m bench.vehicle")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="(the output is always JSON)")
    args = p.parse_args(argv)
    result = {
        "bare": bare_speed(args.seed),
        "precision_landing": [
            precision_landing(args.seed, 0.0, 0.0),
            precision_landing(args.seed, 4.0, 1.5),
            precision_landing(args.seed, 8.0, 3.0),
        ],
    }
    json.dump(result, sys.stdout, indent=2)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
