"""The pose measured on frames drawn another way: the pad as vector polygons.

The bench's renderer ray-traces a texture: the same picture the reference is
cut from, sampled the same way, so a convention both share (where a pixel's
centre lies, how many pixels a metre of the picture holds) would cancel out.
Here the default pad is drawn from its geometry in metres alone: board, side
bars and H projected through the pinhole camera as polygons, filled 8 times
finer than the frame and averaged down (each pixel the area it covers), then
blurred and noised. Another design has no such geometry: its picture is warped
through the camera by OpenCV (its pixel centres mapped to the pad's metres here,
not by the renderer), 4 times finer than the frame and averaged down.
``python -m pipeline.bench --vector [--design NAME|all]`` prints the pose's errors
with the attitude hint (a little off, as the bench gives it, and exact) and
without it, and how many poses without it were wrong (over 3 degrees) without
being flagged ambiguous.
"""

from __future__ import annotations

import functools
import time

import cv2
import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.bench.frames import altitude_for
from pipeline.bench.hint import NOISE_DEG, gravity_hint
from pipeline.bench.picture_design import PadDesign, design_of
from pipeline.bench.tally import Tally
from pipeline.cores import use_one_core
from pipeline.render import BOARD_BGR, PAINT_BGR, PadGeometry, make_pad_image
from pipeline.render.designs import DesignPicture
from pipeline.render.view import random_view

SUPERSAMPLE = 8
WARP_SUPERSAMPLE = 4  # a design's picture is warped this much finer than the frame
FLOOR_BGR = (110, 120, 125)
NOISE_LEVELS = {"clean": (45.0, 0.0), "noisy": (20.0, 0.8)}  # SNR dB, blur sigma px
RENDERER = (
    "the default pad's board, side bars and H as polygons through the pinhole camera,"
    f" filled {SUPERSAMPLE}x finer and averaged down, on a plain floor"
)
WARPED = (
    "the design's picture warped through the pinhole camera by OpenCV,"
    f" {WARP_SUPERSAMPLE}x finer and averaged down, on a plain floor"
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
    return _finished(big, camera, snr_db=snr_db, blur_px=blur_px, rng=rng)


def warp_picture(
    camera: Camera,
    design: PadDesign,
    position_m: np.ndarray,
    R_pad_cam: np.ndarray,
    *,
    snr_db: float | None,
    blur_px: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """``design``'s picture on a plain floor seen from ``position_m`` by a camera turned
    by ``R_pad_cam`` (as `draw_pad`), warped by OpenCV: a picture pixel's centre (u, v)
    lies at ((u + 0.5) / w - 0.5, (h / 2 - v - 0.5) / w) times the pad's size (its width,
    w pixels; h high), metres."""
    drawn = _drawn(design)
    h, w = drawn.image.shape[:2]
    size = design.size_m  # (the picture's width; its height follows its aspect)
    to_m = np.array(
        [
            [size / w, 0.0, size * (0.5 / w - 0.5)],
            [0.0, -size / w, size * (0.5 * h / w - 0.5 / w)],
            [0.0, 0.0, 1.0],
        ]
    )
    R_cam_pad = np.asarray(R_pad_cam, np.float64).T
    t = -R_cam_pad @ np.asarray(position_m, np.float64)
    s = WARP_SUPERSAMPLE
    finer = np.array([[s, 0.0, 0.5 * s - 0.5], [0.0, s, 0.5 * s - 0.5], [0.0, 0.0, 1.0]])
    H = finer @ camera.K @ np.column_stack([R_cam_pad[:, 0], R_cam_pad[:, 1], t]) @ to_m
    fine = (camera.width * s, camera.height * s)
    alpha = drawn.alpha if drawn.alpha is not None else np.full((h, w), 255, np.uint8)
    paint = cv2.warpPerspective(drawn.image, H, fine, flags=cv2.INTER_LINEAR)
    cover = cv2.warpPerspective(alpha, H, fine, flags=cv2.INTER_LINEAR)[..., None] / 255.0
    big = paint * cover + np.array(FLOOR_BGR, np.float64) * (1.0 - cover)
    return _finished(big, camera, snr_db=snr_db, blur_px=blur_px, rng=rng)


@functools.lru_cache(maxsize=4)
def _drawn(design: PadDesign) -> DesignPicture:
    return design.draw()  # (half a second a picture: once per run)


def _finished(
    big: np.ndarray,
    camera: Camera,
    *,
    snr_db: float | None,
    blur_px: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """A frame drawn finer, averaged down to ``camera``'s size, blurred and noised."""
    size = (camera.width, camera.height)
    img = cv2.resize(big.astype(np.float32), size, interpolation=cv2.INTER_AREA)
    if blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur_px)
    if snr_db is not None:
        sigma = np.sqrt(float(np.mean(img**2)) / 10 ** (snr_db / 10))
        img = img + rng.normal(0.0, sigma, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def run_vector(frames: int, seed: int, design: str | PadDesign = "default") -> dict:
    """A design's pose at 640 x 480, on frames drawn another way: the default pad as
    polygons, another design's picture (or a picture's, `picture_design`) warped (at
    the altitudes where it spans what the default pad does at 1-6 m)."""
    use_one_core()
    camera = Camera.from_fov(640, 480, 60.0)
    pad = design_of(design)
    polygons = design == "default"
    if polygons:
        reference = Reference.from_image(make_pad_image(1100), PadGeometry().size_m)
    else:
        reference = Reference.from_image(pad.draw().image, pad.size_m)
    altitude = altitude_for(pad)
    out: dict = {"design": pad.name, "renderer": RENDERER if polygons else WARPED}
    draw = draw_pad if polygons else functools.partial(warp_picture, design=pad)
    for level, (snr_db, blur_px) in NOISE_LEVELS.items():
        hinted, exact, unhinted = Tally(), Tally(), Tally()
        ambiguous = silent_wrong = 0
        for i in range(frames):
            rng = np.random.default_rng([seed, i])
            view = random_view(
                rng, camera, altitude=altitude, pad_size_m=pad.size_m, snr_db=None,
                max_blur_px=0.0, lighting=False,
            )  # fmt: skip
            frame = draw(
                camera, position_m=view.position_m, R_pad_cam=view.R_pad_cam, snr_db=snr_db,
                blur_px=blur_px, rng=rng,
            )  # fmt: skip
            g = gravity_hint(view.R_pad_cam, [seed, i, 11])
            t0 = time.perf_counter()
            res = process_frame(frame, reference, camera, gravity_hint=g)
            hinted.time(time.perf_counter() - t0, res.timings_ms)
            hinted.score(res.detected and res.pose is not None, res.pose, view, True)
            res = process_frame(
                frame,
                reference,
                camera,
                gravity_hint=gravity_hint(view.R_pad_cam, [seed, i, 11], noise_deg=0.0),
            )
            exact.score(res.detected and res.pose is not None, res.pose, view, True)
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
            "with_exact_hint": _pose_figures(exact.summary()),
            "without_hint": _pose_figures(unhinted.summary())
            | {
                "ambiguous": ambiguous,
                f"silently_wrong_over_{WRONG_DEG:g}_deg": silent_wrong,
            },
        }
    out.update(frames=frames, seed=seed, altitude_m=list(altitude), attitude_hint_deg=NOISE_DEG)
    return out


def _pose_figures(summary: dict) -> dict:
    """A tally's detection and pose figures (these frames hold no empty twin)."""
    keys = ("detection_rate", "position_error_pct", "rotation_error_deg")
    return {k: summary[k] for k in keys}
