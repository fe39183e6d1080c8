"""Accuracy and speed benchmark: ``python -m pipeline.bench --frames 200 --seed 0``.

Renders frames of the pad (640x480, 60 degree HFOV, altitude 1-6 m, tilt up to
12 degrees, any yaw, SNR 15-30 dB, blur up to 1.2 px, lighting gradients,
textured floor, 0-3 look-alike shapes beside the pad) plus as many frames with
the look-alikes but no pad, runs the pipeline with each thresholding method,
and the same poses with an ArUco marker of the pad's size through OpenCV's
ArUco detector + solvePnP. Prints one JSON object. One core
(cv2.setNumThreads(1)); times are wall-clock per frame.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import cv2
import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.pose import TURN
from pipeline.preprocess import DEFAULT_METHOD, METHODS
from pipeline.render import make_pad_image, make_scene, random_view, render_view

PAD_SIZE_M = 0.55
_SCENE_EVERY = 10  # a new floor and new look-alikes every this many frames
_ARUCO_DICT = cv2.aruco.DICT_4X4_50


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline.bench", description=__doc__)
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--methods", default=",".join(METHODS), help="thresholdings to compare")
    args = parser.parse_args(argv)
    if args.frames <= 0:
        parser.error("--frames must be positive")
    methods = [m for m in args.methods.split(",") if m]
    if DEFAULT_METHOD not in methods or any(m not in METHODS for m in methods):
        parser.error(f"--methods must include {DEFAULT_METHOD} and only {METHODS}")
    print(json.dumps(run(args.frames, args.seed, methods), indent=2))
    return 0


def run(frames: int, seed: int, methods: list[str]) -> dict:
    cv2.setNumThreads(1)
    camera = Camera.from_fov(640, 480, 60.0)
    pad = make_pad_image()
    reference = Reference.from_image(pad, PAD_SIZE_M)
    marker, marker_size = _aruco_texture()
    ours = {m: _Tally() for m in methods}
    aruco = _Tally()
    detector = _aruco_detector()
    marker_obj = _marker_corners_m(PAD_SIZE_M)
    for i in range(frames):
        scene_rng = np.random.default_rng([seed, i // _SCENE_EVERY])
        k = int(scene_rng.integers(0, 4))
        scene_seed = int(scene_rng.integers(1 << 31))
        scenes = {
            "pad": make_scene(pad, PAD_SIZE_M, rng=np.random.default_rng(scene_seed), lookalikes=k),
            "empty": make_scene(
                pad,
                PAD_SIZE_M,
                rng=np.random.default_rng(scene_seed),
                lookalikes=k,
                pad_visible=False,
            ),
            "aruco": make_scene(
                marker, marker_size, rng=np.random.default_rng(scene_seed), lookalikes=k
            ),
        }
        rng = np.random.default_rng([seed, i, 7])
        view = random_view(rng, camera, pad_size_m=PAD_SIZE_M)
        noise_seed = int(rng.integers(1 << 31))
        frame = render_view(scenes["pad"], camera, view, np.random.default_rng(noise_seed))
        empty = render_view(scenes["empty"], camera, view, np.random.default_rng(noise_seed))
        marked = render_view(scenes["aruco"], camera, view, np.random.default_rng(noise_seed))
        yaw_truth = None  # the pad is symmetric: the bench scores either twin as right
        for method, tally in ours.items():
            t0 = time.perf_counter()
            res = process_frame(frame, reference, camera, yaw_hint=yaw_truth, method=method)
            tally.time(time.perf_counter() - t0, res.timings_ms)
            tally.score(res.detected and res.pose is not None, res.pose, view, reference.symmetric)
            fp = process_frame(empty, reference, camera, method=method)
            tally.false_positive(fp.detected)
        t0 = time.perf_counter()
        pose = _aruco_pose(detector, marked, camera, marker_obj)
        aruco.time(time.perf_counter() - t0, {})
        aruco.score(pose is not None, pose, view, False)
        aruco.false_positive(_aruco_pose(detector, empty, camera, marker_obj) is not None)
        if sys.stderr.isatty():
            print(f"\r{i + 1}/{frames}", end="", file=sys.stderr)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    out = ours[DEFAULT_METHOD].summary()
    out["aruco"] = aruco.summary()
    out["speed_ratio_vs_aruco"] = _ratio(
        out["aruco"]["ms_per_frame"]["median"], out["ms_per_frame"]["median"]
    )
    out["method"] = DEFAULT_METHOD
    out["threshold_methods"] = {m: t.summary() for m, t in ours.items()}
    out["frames"] = frames
    out["seed"] = seed
    return out


class _Tally:
    """Running figures of one detector over the benchmark."""

    def __init__(self) -> None:
        self.n = 0
        self.detected = 0
        self.fp_frames = 0
        self.fp = 0
        self.pos_pct: list[float] = []
        self.rot_deg: list[float] = []
        self.ms: list[float] = []
        self.stages: dict[str, list[float]] = {}

    def time(self, seconds: float, stages: dict[str, float]) -> None:
        self.ms.append(seconds * 1e3)
        for k, v in stages.items():
            self.stages.setdefault(k, []).append(v)

    def score(self, detected: bool, pose, view, symmetric: bool) -> None:
        self.n += 1
        if not detected:
            return
        self.detected += 1
        truths = [(view.position_m, view.R_pad_cam)]
        if symmetric:
            truths.append((TURN @ view.position_m, TURN @ view.R_pad_cam))
        pos, rot = math.inf, math.inf
        for p, R in truths:
            pos = min(pos, 100 * float(np.linalg.norm(pose.position_m - p)) / float(p[2]))
            rot = min(rot, _rotation_angle_deg(pose.R_pad_cam, R))
        self.pos_pct.append(pos)
        self.rot_deg.append(rot)

    def false_positive(self, detected: bool) -> None:
        self.fp_frames += 1
        self.fp += int(detected)

    def summary(self) -> dict:
        return {
            "detection_rate": self.detected / max(self.n, 1),
            "false_positive_rate": self.fp / max(self.fp_frames, 1),
            "position_error_pct": _stats(self.pos_pct),
            "rotation_error_deg": _stats(self.rot_deg),
            "ms_per_frame": _stats(self.ms),
            "stages_ms": {k: float(np.median(v)) for k, v in self.stages.items()},
        }


def _stats(values: list[float]) -> dict:
    if not values:
        return {"median": None, "p95": None}
    a = np.asarray(values)
    return {"median": float(np.median(a)), "p95": float(np.percentile(a, 95))}


def _ratio(a: float | None, b: float | None) -> float | None:
    return None if not a or not b else float(a / b)


def _rotation_angle_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return math.degrees(math.acos(float(np.clip(c, -1.0, 1.0))))


def _aruco_texture() -> tuple[np.ndarray, float]:
    """Marker 0 whose black square is the pad's size, with a white quiet zone."""
    cells = 6  # 4x4 bits + the black border
    px = 600
    marker = cv2.aruco.generateImageMarker(cv2.aruco.getPredefinedDictionary(_ARUCO_DICT), 0, px)
    margin = px // cells
    tex = cv2.copyMakeBorder(marker, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255)
    return cv2.cvtColor(tex, cv2.COLOR_GRAY2BGR), PAD_SIZE_M * tex.shape[1] / px


def _marker_corners_m(size: float) -> np.ndarray:
    h = size / 2
    return np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], np.float64)


def _aruco_detector():
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    return cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(_ARUCO_DICT), params)


def _aruco_pose(detector, frame: np.ndarray, camera: Camera, obj: np.ndarray):
    from pipeline.pose import to_pose

    corners, ids, _ = detector.detectMarkers(frame)
    if ids is None:
        return None
    hits = [c for c, i in zip(corners, ids.ravel(), strict=True) if i == 0]
    if not hits:
        return None
    img = hits[0].reshape(4, 2).astype(np.float64)
    ok, rvec, tvec = cv2.solvePnP(obj, img, camera.K, camera.dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:
        return None
    return to_pose(rvec, tvec, 0.0, False)


if __name__ == "__main__":
    sys.exit(main())
