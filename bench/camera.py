"""Camera benchmarks; prints one JSON object.

``python -m bench.camera --json [--quick]``

- ``sf``: ``SF`` snapshots from the CMUcam4 stand-in at real timing (time scale 1) over a
  pty, against the link's limit (25,000 bytes/s at 250,000 baud) and the spec's expected
  duration (one column per 30 Hz camera frame); plus the driver alone with pacing off
  (what the host side could take).
- ``opencv``: frames/s of the OpenCV source reading a 640x480 MJPG file as fast as it can.
- ``sim``: frames/s of the simulated camera at 640x480 (render only, and through the
  source's capture thread with noise and blur).
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from backend.camera.cmucam4 import CMUcam4, sf_seconds
from backend.camera.opencv_source import OpenCVSource
from sim.camera import PadRenderer, SimCamera, SimCameraConfig, VehiclePose

LINK_BYTES_PER_S = 250000 / 10


def bench_sf(sizes: list[tuple[int, int]], time_scale: float) -> list[dict]:
    from sim.cmucam4 import CMUcam4Board  # the bench, like tests, uses the stand-in

    img = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    out = []
    with CMUcam4Board(time_scale=time_scale, image=img) as board:
        cam = CMUcam4(board.path, timeout=2.0, reset_timeout=max(0.2, 1.5 * time_scale))
        try:
            t0 = time.monotonic()
            cam.connect()
            connect_s = time.monotonic() - t0
            for w, h in sizes:
                t0 = time.monotonic()
                snap = cam.snapshot(w, h)
                total = time.monotonic() - t0
                entry: dict = {
                    "resolution": f"{w}x{h}",
                    "time_scale": time_scale,
                    "connect_s": round(connect_s, 3),
                    "wall_s": round(total, 3),
                    "bytes": snap.nbytes,
                    "expected_s_at_real_time": round(sf_seconds(w, h), 2),
                }
                if time_scale > 0:
                    emulated = total / time_scale  # what it would take on the real link
                    entry["emulated_s"] = round(emulated, 2)
                    entry["bytes_per_s"] = round(snap.nbytes / emulated)
                    entry["link_limit_bytes_per_s"] = LINK_BYTES_PER_S
                    entry["fraction_of_link"] = round(snap.nbytes / emulated / LINK_BYTES_PER_S, 3)
                else:
                    # No pacing: how fast the host side (pty, driver, decoding) can go.
                    entry["host_bytes_per_s"] = round(snap.nbytes / total)
                out.append(entry)
        finally:
            cam.close()
    return out


def bench_opencv(frames: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.avi"
        fourcc = cv2.VideoWriter.fourcc(*"MJPG")
        writer = cv2.VideoWriter(str(path), fourcc, 30.0, (640, 480))
        rng = np.random.default_rng(1)
        base = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
        base = np.asarray(cv2.GaussianBlur(base, (0, 0), 3), np.uint8)
        for i in range(frames):
            writer.write(np.roll(base, i * 4, axis=1))
        writer.release()
        src = OpenCVSource(str(path), fps=0)
        seq = -1
        t0 = t_last = time.monotonic()
        with src:
            while (f := src.wait_frame(seq, timeout=2.0)) is not None:
                seq, t_last = f.seq, time.monotonic()
            decoded = src.status.frames  # every decoded frame, consumed or not
        elapsed = t_last - t0
        return {
            "file": "640x480 MJPG",
            "frames": decoded,
            "frames_per_s": round(decoded / max(elapsed, 1e-9), 1),
        }


def bench_sim(frames: int) -> dict:
    pose = VehiclePose((0.3, -0.2, -4.0), 0.05, -0.03, 0.4, time.monotonic())
    result: dict = {"resolution": "640x480"}
    for label, cfg in (
        ("render_clean", SimCameraConfig(floor="textured")),
        ("render_noise_blur", SimCameraConfig(floor="textured", snr_db=20.0, blur_sigma_px=1.0)),
    ):
        r = PadRenderer(cfg)
        r.render(pose)
        t0 = time.perf_counter()
        for _ in range(frames):
            r.render(VehiclePose(pose.position_ned, pose.roll, pose.pitch, pose.yaw, pose.t))
        result[f"{label}_fps"] = round(frames / (time.perf_counter() - t0), 1)
    # Through the source: asked for 200 Hz, so the delivered rate is what it can do.
    cfg = SimCameraConfig(floor="textured", snr_db=20.0, blur_sigma_px=1.0, rate_hz=200.0)
    src = SimCamera(
        lambda: VehiclePose(pose.position_ned, pose.roll, pose.pitch, pose.yaw, time.monotonic()),
        cfg,
    )
    with src:
        first = src.wait_frame(-1, timeout=10.0)
        if first is None:
            raise RuntimeError("the simulated camera gave no frame")
        t0 = time.monotonic()
        time.sleep(2.0)
        last = src.latest()
        n = (last.seq if last is not None else first.seq) - first.seq
        result["source_fps_asked_200hz"] = round(n / (time.monotonic() - t0), 1)
    result["meets_15hz"] = result["render_noise_blur_fps"] >= 15
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.camera")
    parser.add_argument("--json", action="store_true", help="print JSON (the only output)")
    parser.add_argument("--quick", action="store_true", help="skip the paced SF runs (about 15 s)")
    parser.add_argument("--frames", type=int, default=100)
    ns = parser.parse_args(argv)
    report: dict = {"python": platform.python_version(), "opencv_version": cv2.__version__}
    if not ns.quick:
        report["sf_real_time"] = bench_sf([(80, 60), (160, 120)], time_scale=1.0)
        # 640x480 takes ~43 s in real time; at scale 0.1 the emulated pacing is checked.
        report["sf_640x480_scaled"] = bench_sf([(640, 480)], time_scale=0.1)
    report["sf_unpaced"] = bench_sf([(640, 480)], time_scale=0.0)
    report["opencv"] = bench_opencv(ns.frames)
    report["sim"] = bench_sim(ns.frames)
    json.dump(report, sys.stdout, indent=None if ns.json else 2)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
