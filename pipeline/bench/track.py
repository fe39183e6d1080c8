"""Tracking: a descent over the pad, each frame looked for where the last one found it.

The camera descends from the top of the design's altitude range to its bottom,
drifting and turning, at 640x480 and at 1920x1080 (60 degree HFOV); each frame
is processed twice, with the last detection as ``prior`` (tracking) and without
it (a cold start), so the JSON compares the two on the same frames.
"""

from __future__ import annotations

import time

import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.bench.frames import altitude_for
from pipeline.bench.hint import gravity_hint
from pipeline.bench.tally import Tally
from pipeline.cores import use_one_core
from pipeline.render import Design, Scene, camera_rotation, get_design, render

RESOLUTIONS = ((640, 480), (1920, 1080))


def run_track(*, frames: int = 60, seed: int = 0, design: str = "default") -> dict:
    """The tracking run's JSON: per resolution, ms per frame tracking and cold, how
    each frame was found, and the tracked poses' errors (with the attitude hint); and
    the same descent facing the pad (``facing_the_pad``: the camera's yaw held square
    to the pad's axes, as a landing turns the vehicle, where the pose is taken from
    the homography refitted off the edge locator's lock, `pipeline.measure._unlocked`)."""
    if frames < 2:
        raise ValueError(f"frames must be at least 2, got {frames}")
    use_one_core()
    d = get_design(design)
    reference = Reference.from_image(d.draw().image, d.size_m)
    scene = d.scene(np.random.default_rng(seed), floor="textured", lookalikes=2)
    lo, hi = altitude_for(d)
    out: dict = {"design": d.name, "frames": frames, "seed": seed, "altitude_m": [lo, hi]}
    out["facing_the_pad"] = {}
    for width, height in RESOLUTIONS:
        camera = Camera.from_fov(width, height, 60.0)
        for turning, into in ((True, out), (False, out["facing_the_pad"])):
            into[f"{width}x{height}"] = _descent(
                d, reference, scene, camera, frames, seed, (lo, hi), turning
            )
    return out


def _descent(
    d: Design,
    reference: Reference,
    scene: Scene,
    camera: Camera,
    frames: int,
    seed: int,
    altitudes: tuple[float, float],
    turning: bool,
) -> dict:
    """One descent's figures (see `run_track`); ``turning``: the camera turns from 20
    to 60 degrees on the way down, else it faces the pad (0)."""
    lo, hi = altitudes
    tally = Tally()
    tracked, cold, ways = [], [], []
    prior = None
    for k in range(frames):
        f = k / (frames - 1)
        position = np.array(
            [0.1 * hi * np.sin(3 * f), 0.08 * hi * np.cos(2 * f), hi + (lo - hi) * f]
        )
        yaw = 20.0 + 40.0 * f if turning else 0.0
        R = camera_rotation(yaw, tilt_deg=4.0, tilt_dir_deg=360.0 * f)
        frame = render(
            scene, camera, position, R, snr_db=25.0, blur_sigma_px=0.6,
            rng=np.random.default_rng([seed, k]),
        )  # fmt: skip
        g = gravity_hint(R, [seed, k, 13])
        t0 = time.perf_counter()
        res = process_frame(frame, reference, camera, gravity_hint=g, prior=prior)
        dt = (time.perf_counter() - t0) * 1e3
        t0 = time.perf_counter()
        process_frame(frame, reference, camera, gravity_hint=g)
        cold.append((time.perf_counter() - t0) * 1e3)
        ways.append(res.found_by or "missed")
        if res.found_by in ("follow", "track"):
            tracked.append(dt)
        view = _View(position, R)
        tally.score(res.detected and res.pose is not None, res.pose, view, d.symmetric)
        prior = res if res.detected else None
    s = tally.summary()
    return {
        "detection_rate": s["detection_rate"],
        "found_by": {w: ways.count(w) for w in sorted(set(ways))},
        "ms_tracking": _stats(tracked),
        "ms_cold": _stats(cold),
        "position_error_pct": s["position_error_pct"],
        "rotation_error_deg": s["rotation_error_deg"],
    }


class _View:
    """What `Tally.score` reads of a view: the true pose."""

    def __init__(self, position_m: np.ndarray, R_pad_cam: np.ndarray) -> None:
        self.position_m = position_m
        self.R_pad_cam = R_pad_cam


def _stats(values: list[float]) -> dict:
    if not values:
        return {"median": None, "p95": None}
    a = np.asarray(values)
    return {"median": float(np.median(a)), "p95": float(np.percentile(a, 95))}
