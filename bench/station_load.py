"""The whole station under load: 50 dashboard viewers while the stand-in hovers and lands.

``python -m bench.station_load [--viewers 50] [--hover-s 20] [--json]`` prints one JSON
object. The station runs in this process on a real uvicorn server on a loopback port
(stand-in vehicle, simulated camera, the 3D view, verifier training off); the viewers
are WebSocket clients in a second process that read every message (frames, JPEGs,
telemetry, status, events); the HTTP probes run in a third. While the stand-in
hovers over the pad (hover mission), it measures:

- ``pipeline_fps``: results per second over the window (from ``/api/status``);
- ``command_rtt_ms``: ``POST /api/vehicle/mode`` (HTTP -> COMMAND_LONG -> COMMAND_ACK
  -> response) as the probe sees it;
- ``status_ms``: ``GET /api/status`` as the probe sees it;

then lands by precision landing (PLND set up on the stand-in first) and measures
``result_to_landing_target_ms``: from the vision result being published to the
LANDING_TARGET built from it being sent (a probe wrapped around the link's
``send_landing_target`` in this process). Bars (issue 13): pipeline >= 14.5 fps,
command p99 <= 100 ms, status p99 <= 50 ms, result -> LANDING_TARGET p95 <= 10 ms.
Loopback only.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import multiprocessing as mp
import os
import platform
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

TOKEN = "station-load-bench-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


def percentiles(values: list[float]) -> dict[str, float | int | None]:
    """n, p50, p95, p99 and max of ``values`` (ms), rounded.

    >>> percentiles([1.0, 2.0, 3.0, 4.0])["p50"]
    2.5
    """
    if not values:
        return {"n": 0, "p50": None, "p95": None, "p99": None, "max": None}
    ordered = sorted(values)

    def pct(q: float) -> float:
        i = (len(ordered) - 1) * q
        lo, hi = math.floor(i), math.ceil(i)
        return ordered[lo] + (ordered[hi] - ordered[lo]) * (i - lo)

    return {
        "n": len(ordered),
        "p50": round(pct(0.50), 2),
        "p95": round(pct(0.95), 2),
        "p99": round(pct(0.99), 2),
        "max": round(ordered[-1], 2),
    }


# --- the viewers (their own process) ---------------------------------------------------
def viewers_main(url: str, n: int, stop: Any, out: Any) -> None:
    asyncio.run(_viewers(url, n, stop, out))


async def _viewers(url: str, n: int, stop: Any, out: Any) -> None:
    from websockets.asyncio.client import connect

    counts: dict[str, float] = {"text": 0, "binary": 0, "bytes": 0, "frames": 0, "errors": 0}
    t0 = time.monotonic()

    async def one() -> None:
        try:
            async with connect(url, max_size=None, open_timeout=20) as ws:
                while not stop.is_set():
                    try:
                        msg = await asyncio.wait_for(ws.recv(), 0.5)
                    except TimeoutError:
                        continue
                    if isinstance(msg, bytes):
                        counts["binary"] += 1
                        counts["bytes"] += len(msg)
                    else:
                        counts["text"] += 1
                        counts["bytes"] += len(msg)
                        if msg.startswith('{"type":"frame"'):
                            counts["frames"] += 1
        except Exception:
            counts["errors"] += 1

    await asyncio.gather(*(one() for _ in range(n)))
    counts["seconds"] = time.monotonic() - t0
    out.put(counts)


# --- the HTTP probes (their own process) -----------------------------------------------
def probes_main(base: str, stop: Any, out: Any) -> None:
    import httpx

    status_ms: list[float] = []
    command_ms: list[float] = []
    failures: list[str] = []

    def status_loop() -> None:
        with httpx.Client(base_url=base, timeout=10) as client:
            while not stop.is_set():
                t0 = time.perf_counter()
                r = client.get("/api/status")
                status_ms.append((time.perf_counter() - t0) * 1e3)
                if r.status_code != 200:
                    failures.append(f"status {r.status_code}")
                stop.wait(0.1)

    def command_loop() -> None:
        with httpx.Client(base_url=base, timeout=10, headers=AUTH) as client:
            while not stop.is_set():
                t0 = time.perf_counter()
                r = client.post("/api/vehicle/mode", json={"mode": "GUIDED"})
                command_ms.append((time.perf_counter() - t0) * 1e3)
                if r.status_code != 200:
                    failures.append(f"mode {r.status_code}: {r.text[:80]}")
                stop.wait(0.5)

    threads = [threading.Thread(target=status_loop), threading.Thread(target=command_loop)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    out.put({"status_ms": status_ms, "command_ms": command_ms, "failures": failures[:5]})


# --- the station (this process) ----------------------------------------------------------
class LandingTargetProbe:
    """Times each LANDING_TARGET from the vision result it was built from.

    Keeps the publication time of recent results by capture time; wraps the link's
    ``send_landing_target`` and, for a target built from the mission's current fix
    (not a predicted one), notes send time minus that result's publication time.
    """

    def __init__(self, station: Any) -> None:
        self.station = station
        self.published: dict[float, float] = {}
        self.latencies_ms: list[float] = []
        self.predicted = 0
        self._attach_results()
        link = station.link
        original = link.send_landing_target

        def probe(*args: Any, **kwargs: Any) -> Any:
            result = original(*args, **kwargs)
            sent = time.monotonic()
            mission = getattr(station.missions, "_mission", None)
            fix = getattr(mission, "fix", None)
            t_done = None
            if fix is not None and kwargs.get("time_usec") == fix.time_usec:
                t_done = self.published.get(fix.t_capture)
            if t_done is None:
                self.predicted += 1
            elif result.ok:
                self.latencies_ms.append((sent - t_done) * 1e3)
            return result

        link.send_landing_target = probe

    def _note(self, processed: Any) -> None:
        # The worker stamps t_done just before publishing the result.
        self.published[processed.frame.t_capture] = processed.t_done
        if len(self.published) > 500:
            for key in list(self.published)[:250]:
                del self.published[key]

    def _attach_results(self) -> None:
        station = self.station
        bus = getattr(station, "results", None)
        if bus is not None:  # one frame bus

            def take() -> None:
                item = slot.take(0.0)
                if item is not None:
                    self._note(item)

            slot = bus.subscribe("bench", on_put=take)
        else:  # before issue 13: the worker's sinks
            station.worker.add_sink(self._note)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait(predicate: Any, timeout: float, what: str, step: float = 0.2, show: Any = None) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(step)
    raise RuntimeError(f"{what}: not within {timeout:g} s" + (f" ({show()})" if show else ""))


def run(viewers: int, hover_s: float, land_timeout_s: float) -> dict[str, Any]:
    import httpx
    import uvicorn

    from backend import app as app_module
    from backend.app import create_app
    from backend.settings import Settings

    data = Path(tempfile.mkdtemp(prefix="visland-load-"))
    settings = Settings(
        data_dir=data,
        token=TOKEN,
        viser_port=_free_port(),
        sim_ready_after=0.1,
        verifier_views=0,
    )
    app = create_app(settings)
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    server = uvicorn.Server(
        uvicorn.Config(
            app,
            host="127.0.0.1",
            port=port,
            log_level="warning",
            lifespan="on",
            **getattr(app_module, "SERVER_OPTIONS", {}),
        )
    )
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    base = f"http://127.0.0.1:{port}"
    ctx = mp.get_context("spawn")
    stop = ctx.Event()  # the viewers: through the landing
    stop_probes = ctx.Event()  # the probes: the hover window only (they set GUIDED)
    out = ctx.Queue()
    procs: list[Any] = []
    try:
        _wait(lambda: server.started, 60, "server start")
        http = httpx.Client(base_url=base, timeout=10, headers=AUTH)
        station = app.state.station
        probe = LandingTargetProbe(station)

        def tel() -> dict[str, Any]:
            return dict(http.get("/api/telemetry").json())

        _wait(lambda: tel()["state"] == "up", 30, "link up")
        link = station.link
        # Precision landing on the stand-in: PLND_TYPE is read at boot.
        for name in ("PLND_ENABLED", "PLND_TYPE"):
            if not link.set_param(name, 1).ok:
                raise RuntimeError(f"could not set {name}")
        if not link.reboot().ok:
            raise RuntimeError("reboot refused")
        time.sleep(1.0)
        _wait(
            lambda: (
                (t := tel())["state"] == "up"
                and t["prearm_ok"]
                and (t["ekf"] or {}).get("pos_horiz_ok")
            ),
            60,
            "vehicle ready",
        )
        r = http.post("/api/missions/hover", json={"altitude_m": 3.0, "hold_s": 600})
        if r.status_code != 200:
            raise RuntimeError(f"hover refused: {r.text}")
        _wait(
            lambda: (http.get("/api/missions/current").json() or {}).get("state") == "hold",
            60,
            "hover over the pad",
        )
        procs = [
            ctx.Process(
                target=viewers_main, args=(f"ws://127.0.0.1:{port}/ws", viewers, stop, out)
            ),
            ctx.Process(target=probes_main, args=(base, stop_probes, out)),
        ]
        for p in procs:
            p.start()
        time.sleep(3.0)  # the viewers connect
        s0 = http.get("/api/status").json()
        t0 = time.monotonic()
        time.sleep(hover_s)
        s1 = http.get("/api/status").json()
        t1 = time.monotonic()
        fps = (s1["pipeline"]["processed"] - s0["pipeline"]["processed"]) / (t1 - t0)
        stop_probes.set()
        probes_out = out.get(timeout=60)
        # Land on the pad by precision landing, the viewers still reading.
        http.post("/api/missions/abort")
        r = http.post("/api/missions/land", json={"strategy": "plnd", "approach_alt_m": 3.0})
        if r.status_code != 200:
            raise RuntimeError(f"land refused: {r.text}")
        final = _wait(
            lambda: (
                (m := http.get("/api/missions/current").json())
                and m["state"] in ("landed", "failed", "aborted", "link_lost")
                and m
            ),
            land_timeout_s,
            "landing",
            step=0.5,
            show=lambda: http.get("/api/missions/current").json(),
        )
        stop.set()
        viewers_out = out.get(timeout=60)
        return {
            "bench": "station_load",
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "viewers": viewers,
            "hover_window_s": round(t1 - t0, 2),
            "pipeline_fps": round(fps, 2),
            "camera_fps": s1["camera"]["fps"],
            "dropped_frames": s1["pipeline"]["dropped"] - s0["pipeline"]["dropped"],
            "command_rtt_ms": percentiles(probes_out["command_ms"]),
            "status_ms": percentiles(probes_out["status_ms"]),
            "result_to_landing_target_ms": percentiles(probe.latencies_ms),
            "landing_targets_predicted": probe.predicted,
            "landing": {"state": final["state"], "message": final["message"]},
            "viewer_traffic": {
                "frames_per_viewer_per_s": round(
                    viewers_out["frames"] / max(1, viewers) / viewers_out["seconds"], 2
                ),
                "megabytes": round(viewers_out["bytes"] / 1e6, 1),
                "errors": viewers_out["errors"],
            },
            "probe_failures": probes_out["failures"],
            "bars": {
                "pipeline_fps >= 14.5": fps >= 14.5,
                "command_rtt p99 <= 100 ms": _le(probes_out["command_ms"], 0.99, 100.0),
                "status p99 <= 50 ms": _le(probes_out["status_ms"], 0.99, 50.0),
                "result_to_landing_target p95 <= 10 ms": _le(probe.latencies_ms, 0.95, 10.0),
            },
        }
    finally:
        stop.set()
        stop_probes.set()
        for p in procs:
            p.join(30)
            if p.is_alive():
                p.terminate()
        server.should_exit = True
        thread.join(30)
        sock.close()


def _le(values: list[float], q: float, bar: float) -> bool:
    if not values:
        return False
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, math.ceil(q * len(ordered)) - 1)] <= bar


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.station_load", description=__doc__)
    parser.add_argument("--viewers", type=int, default=50)
    parser.add_argument("--hover-s", type=float, default=20.0, help="measuring window")
    parser.add_argument("--land-timeout-s", type=float, default=120.0)
    parser.add_argument("--json", action="store_true", help="(the output is always JSON)")
    args = parser.parse_args(argv)
    if args.viewers < 0 or args.hover_s <= 0:
        parser.error("--viewers must be >= 0 and --hover-s > 0")
    with contextlib.redirect_stderr(sys.stderr):
        report = run(args.viewers, args.hover_s, args.land_timeout_s)
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
