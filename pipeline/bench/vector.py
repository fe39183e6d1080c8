"""The pose measured on frames drawn another way: the pad as vector polygons.

The bench's renderer ray-traces a texture: the same picture the reference is
cut from, sampled the same way, so a convention both share (where a pixel's
centre lies, how many pixels a metre of the picture holds) would cancel out.
Here the default pad is drawn from its geometry in metres alone: board, side
bars and H projected through the pinhole camera as polygons, filled 8 times
finer than the frame and averaged down (each pixel the area it covers), then
blurred and noised. ``python -m pipeline.bench --vector`` prints the pose's
errors with and without the attitude hint, and how many poses without it were
wrong (over 3 degrees) without being flagged ambiguous.
"""

from __future__ import annotations

import time

import cv2
import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.bench.hint import NOISE_DEG, gravity_hint
from pipeline.bench.tally import Tally
from pipeline.cores import use_one_core
from pipeline.render import BOARD_BGR, PAINT_BGR, PadGeometry, make_pad_image
from pipeline.render.view import random_view

SUPERSAMPLE = 8
FLOOR_BGR = (110, 120, 125)
NOISE_LEVELS = {"clean": (45.0, 0.0), "noisy": (20.0, 0.8)}  # SNR dB, blur sigma px
RENDERER = (
    "the default pad's board, side bars and H as polygons through the pinhole camera,"
    f" filled {SUPERSAMPLE}x finer and averaged down, on a plain floor"
)
WRONG_DEG = 3.0  # a pose this far off, not flagged ambiguous, is silently wrong
_SUB_BITS = 4  # fillPoly's sub-pixel bits


def draw_pad(
    camera: Camera,
    position_m: np.ndarray,
    R_pad_cam: np.ndarray,
    *,
    snr_db: float | None,
    blur_px: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """The default pad on a plain floor seen from ``position_m`` (pad frame) by a
    camera turned by ``R_pad_cam`` (camera -> pad), as a BGR uint8 frame. Every
    corner must lie in front of the camera."""
    geometry = PadGeometry()
    R_cam_pad = np.asarray(R_pad_cam, np.float64).T
    t = -R_cam_pad @ np.asarray(position_m, np.float64)
    K = camera.K
    s = SUPERSAMPLE
    big = np.empty((camera.height * s, camera.width * s, 3), np.uint8)
    big[:] = FLOOR_BGR

    def fill(corners_m: np.ndarray, bgr: tuple[int, int, int]) -> None:
        p = np.column_stack([corners_m, np.zeros(len(corners_m))]) @ R_cam_pad.T + t
        if np.any(p[:, 2] <= 0):
            raise ValueError("the pad must lie in front of the camera")
        x = K[0, 0] * p[:, 0] / p[:, 2] + K[0, 2]
        y = K[1, 1] * p[:, 1] / p[:, 2] + K[1, 2]
        # Frame pixel x (centre at x) covers fine pixels s x .. s x + s - 1.
        fine = np.column_stack([(x + 0.5) * s - 0.5, (y + 0.5) * s - 0.5])
        pts = np.round(fine * (1 << _SUB_BITS)).astype(np.int32)
        cv2.fillPoly(big, [pts], bgr, lineType=cv2.LINE_8, shift=_SUB_BITS)

    fill(geometry.board_corners_m, BOARD_BGR)
    for bar in geometry.side_bars_m:
        fill(bar, PAINT_BGR)
    fill(geometry.h_corners_m, PAINT_BGR)
    size = (camera.width, camera.height)
    img = cv2.resize(big, size, interpolation=cv2.INTER_AREA).astype(np.float32)
    if blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur_px)
    if snr_db is not None:
        sigma = np.sqrt(float(np.mean(img**2)) / 10 ** (snr_db / 10))
        img = img + rng.normal(0.0, sigma, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def run_vector(frames: int, seed: int) -> dict:
    """The default pad's pose, 1-6 m at 640 x 480, on vector-drawn frames."""
    use_one_core()
    camera = Camera.from_fov(640, 480, 60.0)
    reference = Reference.from_image(make_pad_image(1100), PadGeometry().size_m)
    out: dict = {"renderer": RENDERER}
    for level, (snr_db, blur_px) in NOISE_LEVELS.items():
        hinted, unhinted = Tally(), Tally()
        ambiguous = silent_wrong = 0
        for i in range(frames):
            rng = np.random.default_rng([seed, i])
            view = random_view(rng, camera, snr_db=None, max_blur_px=0.0, lighting=False)
            frame = draw_pad(
                camera, view.position_m, view.R_pad_cam, snr_db=snr_db, blur_px=blur_px, rng=rng
            )
            g = gravity_hint(view.R_pad_cam, [seed, i, 11])
            t0 = time.perf_counter()
            res = process_frame(frame, reference, camera, gravity_hint=g)
            hinted.time(time.perf_counter() - t0, res.timings_ms)
            hinted.score(res.detected and res.pose is not None, res.pose, view, True)
            res = process_frame(frame, reference, camera)
            unhinted.score(res.detected and res.pose is not None, res.pose, view, True)
            if res.detected and res.pose is not None:
                ambiguous += int(res.pose.ambiguous)
                silent_wrong += int(not res.pose.ambiguous and unhinted.rot_deg[-1] > WRONG_DEG)
        with_hint = _pose_figures(hinted.summary())
        with_hint["ms_per_frame"] = hinted.summary()["ms_per_frame"]
        out[level] = {
            "snr_db": snr_db,
            "blur_sigma_px": blur_px,
            "with_hint": with_hint,
            "without_hint": _pose_figures(unhinted.summary())
            | {
                "ambiguous": ambiguous,
                f"silently_wrong_over_{WRONG_DEG:g}_deg": silent_wrong,
            },
        }
    out.update(frames=frames, seed=seed, altitude_m=[1.0, 6.0], attitude_hint_deg=NOISE_DEG)
    return out


def _pose_figures(summary: dict) -> dict:
    """A tally's detection and pose figures (these frames hold no empty twin)."""
    keys = ("detection_rate", "position_error_pct", "rotation_error_deg")
    return {k: summary[k] for k in keys}
