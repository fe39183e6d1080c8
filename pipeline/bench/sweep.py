"""Sweeps: ``python -m pipeline.bench --sweep KIND [--resolution WxH] [--plot DIR]``.

At each point of the sweep, ``frames`` views of the pad (a random yaw, the pad
anywhere in the image, the ``--degrade`` mix with the swept quantity fixed) are
rendered, and the same views of an ArUco marker (DICT_4X4_50) and of an AprilTag 3
marker (tag36h11) whose black squares are the pad's size, and the same views of the
floor without either (the empty twins: the scene's look-alikes stay). For each
detector and point: detection rate, position error (% of altitude) and rotation
error (degrees) against the truth, the share of frames posed over
``tally.WRONG_POSE_PCT`` off (something else taken for the pad, or the planar pose's
other solution) and of those not flagged ambiguous, the share of empty twins where
something was found, and milliseconds per frame (on the frames with the pad); the
frames go to each detector at their native resolution (60 degree HFOV).

- ``altitude``: 1 m to the altitude where the pad spans 12 px (for the 0.55 m pad:
  ~25 m at 640x480, ~51 m at 1280x720, ~76 m at 1920x1080; other pads scaled with
  their size), and
  ``range90_m`` per detector: the highest altitude up to which every point has
  >= 90 % detection;
- ``snr``: 5-40 dB at the bench's altitudes (1-6 m for the 0.55 m pad);
- ``tilt``: 0-45 degrees off nadir at the bench's altitudes;
- ``yaw``: hovering (tilt up to ``HOVER_TILT_DEG``) at the bench's altitudes, the
  camera turned 0-45 degrees about its axis from the pad's: at 0 the H's sides lie
  along the pixel rows and columns, as a vehicle facing the pad's heading sees them
  (the landing turns it so), and each side's points share one phase to the pixel
  grid, so an edge locator's error that depends on the phase does not average out
  along it.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.bench.frames import SCENE_EVERY, Scenes, make_scenes, make_view
from pipeline.bench.hint import NOISE_DEG, gravity_hint
from pipeline.bench.markers import AprilTagDetector, ArucoDetector, settings
from pipeline.bench.picture_design import PadDesign, design_of
from pipeline.bench.plot import line_panel, save
from pipeline.bench.tally import Tally
from pipeline.cores import use_one_core
from pipeline.preprocess import DEFAULT_METHOD
from pipeline.render import PAD_SIZE_M
from pipeline.render.view import render_view

DETECTORS = ("visland", "aruco", "apriltag")
SNR_POINTS_DB = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0)
TILT_POINTS_DEG = (0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0)
YAW_POINTS_DEG = (0.0, 1.0, 2.0, 5.0, 10.0, 20.0, 30.0, 45.0)
HOVER_TILT_DEG = 3.0  # a hovering multirotor's camera, off nadir
FAR_SPAN_PX = 12.0  # the altitude sweep ends where the pad spans this many pixels
RANGE_RATE = 0.9
_SCENE_POOL = 4  # scene sets shared by all points (a set takes ~1 s to build)
_X_KEY = {"altitude": "altitude_m", "snr": "snr_db", "tilt": "tilt_deg", "yaw": "yaw_deg"}
_POINTS = {"snr": SNR_POINTS_DB, "tilt": TILT_POINTS_DEG, "yaw": YAW_POINTS_DEG}


def altitude_points(design: PadDesign, camera: Camera) -> list[float]:
    """1-10 m by 1, then by 2 to 20, then by 4, up to where the pad spans 12 px (0.55 m
    pad; other pads scaled by their size), that last altitude included."""
    k = design.size_m / PAD_SIZE_M
    far = camera.fx * design.size_m / FAR_SPAN_PX
    base = [*range(1, 11), *range(12, 21, 2), *range(24, 400, 4)]
    pts = [b * k for b in base if b * k < far - 0.25 * k]
    return [round(p, 3) for p in [*pts, far]]


def range90(xs: list[float], rates: list[float]) -> float | None:
    """The highest x up to which every point's rate is >= 0.9 (None if the first fails).

    >>> range90([1, 2, 3, 4], [1.0, 0.95, 0.5, 1.0])
    2
    """
    best = None
    for x, r in zip(xs, rates, strict=True):
        if r < RANGE_RATE:
            break
        best = x
    return best


def run_sweep(
    kind: str,
    *,
    resolutions: list[tuple[int, int]],
    frames: int = 20,
    seed: int = 0,
    design: str | PadDesign = "default",
    degrade: str = "today",
    method: str = DEFAULT_METHOD,
    plot_dir: str | None = None,
    hint: bool = False,
) -> dict:
    """The sweep's JSON (see the module docstring); PNG plots into ``plot_dir``.
    ``hint``: Visland gets the camera's attitude as a vehicle would give it."""
    if kind not in _X_KEY:
        raise ValueError(f"sweep must be one of {tuple(_X_KEY)}, got {kind!r}")
    if frames <= 0:
        raise ValueError(f"frames must be positive, got {frames}")
    use_one_core()
    d = design_of(design)
    try:
        reference: Reference | None = Reference.from_image(d.draw().image, d.size_m)
        ref_error = None
    except ValueError as exc:
        reference, ref_error = None, str(exc)
    pool: dict[int, Scenes] = {}
    out: dict = {
        "sweep": kind,
        "design": d.name,
        "pad_size_m": d.size_m,
        "degrade": degrade,
        "frames_per_point": frames,
        "seed": seed,
        "hfov_deg": 60.0,
        "method": method,
        "attitude_hint_deg": NOISE_DEG if hint else None,
        "reference_error": ref_error,
        "markers": settings(),
        "resolutions": {},
    }
    for width, height in resolutions:
        camera = Camera.from_fov(width, height, 60.0)
        xs = altitude_points(d, camera) if kind == "altitude" else list(_POINTS[kind])
        points = []
        for p, x in enumerate(xs):
            tallies = {name: Tally() for name in DETECTORS}
            detectors = {"aruco": ArucoDetector(d.size_m), "apriltag": AprilTagDetector(d.size_m)}
            for j in range(frames):
                slot = ((p * frames + j) // SCENE_EVERY) % _SCENE_POOL
                if slot not in pool:
                    pool[slot] = make_scenes(d, [seed, 1000 + slot], degrade, ("aruco", "apriltag"))
                scenes = pool[slot]
                view, noise_seed = make_view([seed, p, j, 11], camera, d, degrade, **_fix(kind, x))
                frame = render_view(scenes.pad, camera, view, np.random.default_rng(noise_seed))
                empty = render_view(scenes.empty, camera, view, np.random.default_rng(noise_seed))
                g = gravity_hint(view.R_pad_cam, [seed, p, j, 12]) if hint else None
                _visland(tallies["visland"], frame, empty, reference, camera, view, d, method, g)
                for name, det in detectors.items():
                    img = render_view(
                        scenes.markers[name], camera, view, np.random.default_rng(noise_seed)
                    )
                    t0 = time.perf_counter()
                    pose = det.pose(img, camera)
                    tallies[name].time(time.perf_counter() - t0, {})
                    tallies[name].score(pose is not None, pose, view, False)
                    tallies[name].false_positive(det.pose(empty, camera) is not None)
            point = {_X_KEY[kind]: x}
            if kind == "altitude":
                point["pad_span_px"] = camera.fx * d.size_m / x
            point |= {name: _point_summary(t) for name, t in tallies.items()}
            points.append(point)
            if sys.stderr.isatty():
                print(f"\r{kind} {width}x{height} {p + 1}/{len(xs)}", end="", file=sys.stderr)
        res: dict = {"points": points}
        if kind == "altitude":
            res["range90_m"] = {
                name: range90(xs, [pt[name]["detection_rate"] for pt in points])
                for name in DETECTORS
            }
            res["altitude_where_pad_spans_22px_m"] = camera.fx * d.size_m / 22.0
            res["altitude_where_pad_spans_12px_m"] = camera.fx * d.size_m / FAR_SPAN_PX
        out["resolutions"][f"{width}x{height}"] = res
    if sys.stderr.isatty():
        print(file=sys.stderr)
    if plot_dir is not None:
        out["plots"] = plot_sweep(out, plot_dir)
    return out


def _fix(kind: str, x: float) -> dict:
    """`random_view` keywords that pin the swept quantity."""
    if kind == "altitude":
        return {"altitude": (x, x)}
    if kind == "snr":
        return {"snr_db": (x, x)}
    if kind == "yaw":
        return {"yaw_deg": x, "max_tilt_deg": HOVER_TILT_DEG}
    return {"min_tilt_deg": x, "max_tilt_deg": x}


def _visland(tally, frame, empty, reference, camera, view, design, method, hint=None) -> None:
    if reference is None:
        tally.score(False, None, view, design.symmetric)
        tally.false_positive(False)
        return
    t0 = time.perf_counter()
    res = process_frame(frame, reference, camera, method=method, gravity_hint=hint)
    tally.time(time.perf_counter() - t0, {})
    tally.score(res.detected and res.pose is not None, res.pose, view, design.symmetric)
    # (the same attitude: a vehicle knows it whether or not the pad is in view)
    seen = process_frame(empty, reference, camera, method=method, gravity_hint=hint)
    tally.false_positive(seen.detected)


_POINT_KEYS = (
    "detection_rate",
    "position_error_pct",
    "rotation_error_deg",
    "wrong_pose_rate",
    "silent_wrong_pose_rate",
    "false_positive_rate",
    "ms_per_frame",
)


def _point_summary(t: Tally) -> dict:
    s = t.summary()
    return {k: s[k] for k in _POINT_KEYS}


def plot_sweep(result: dict, plot_dir: str) -> list[str]:
    """One PNG per resolution: detection, position error and time against the sweep."""
    kind = result["sweep"]
    key = _X_KEY[kind]
    xlabel = {
        "altitude": "altitude (m)",
        "snr": "SNR (dB)",
        "tilt": "tilt (deg)",
        "yaw": "camera yaw from the pad's axes (deg)",
    }[kind]
    paths = []
    for res_name, res in result["resolutions"].items():
        pts = res["points"]
        xs = [p[key] for p in pts]

        def series(field: str, stat: str | None, pts=pts, xs=xs) -> dict:
            return {
                name: (xs, [p[name][field] if stat is None else p[name][field][stat] for p in pts])
                for name in DETECTORS
            }

        title = f"{result['design']} pad, {res_name}, {result['degrade']} mix"
        if kind == "altitude":
            r90 = ", ".join(
                f"{n} {v if v is None else round(v, 1)}" for n, v in res["range90_m"].items()
            )
            title += f" - range90 (m): {r90}"
        panels = [
            line_panel(
                series("detection_rate", None),
                title=title,
                xlabel=xlabel,
                ylabel="detection",
                ylim=(0.0, 1.0),
                hlines=[(0.9, "90 %")],
            ),
            line_panel(
                series("position_error_pct", "median"),
                title="position error, median (% of altitude)",
                xlabel=xlabel,
                ylabel="% of alt.",
                log_y=True,
            ),
            line_panel(
                series("rotation_error_deg", "median"),
                title="rotation error, median (degrees)",
                xlabel=xlabel,
                ylabel="degrees",
                log_y=True,
            ),
            line_panel(
                series("false_positive_rate", None),
                title="found on the empty twin views (false positives)",
                xlabel=xlabel,
                ylabel="share",
            ),
            line_panel(
                series("ms_per_frame", "median"),
                title="time per frame, median (ms, one core)",
                xlabel=xlabel,
                ylabel="ms",
            ),
        ]
        name = f"sweep_{kind}_{result['design']}_{res_name}.png"
        paths.append(save(Path(plot_dir) / name, panels))
    return paths
