"""The bench's own frames in tests: a design's frames as `pipeline.bench --design NAME
--hint [--degrade LEVEL]` renders and scores them (seed 0, 640 x 480 at 60 degrees),
and the altitude sweep's (`pipeline.bench --sweep altitude`, seed 0); and where the
photos bench's real photos lie (``../shared/photos``, beside the checkout)."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.bench.frames import SCENE_EVERY, make_scenes, make_view
from pipeline.bench.hint import gravity_hint
from pipeline.bench.photos import FOV_DEG, degraded_view, load_manifest
from pipeline.bench.sweep import HOVER_TILT_DEG
from pipeline.bench.tally import Tally
from pipeline.render import get_design
from pipeline.render.designs import Design, Disc, HShape, Rects, Ring
from pipeline.render.view import render_view

CAM = Camera.from_fov(640, 480, 60.0)
PHOTOS = Path(__file__).resolve().parents[2].parent / "shared" / "photos"
needs_photos = pytest.mark.skipif(
    not (PHOTOS / "manifest.json").exists(), reason="../shared/photos is not beside the checkout"
)


@functools.cache
def photo_reference(file: str) -> Reference:
    """The shared photos' reference picture ``file`` (as the manifest names it)."""
    manifest = load_manifest(PHOTOS)
    entries = [r for d in manifest["designs"].values() for r in d["references"]]
    entry = next(e for e in [*entries, manifest["default_reference"]] if e["file"] == file)
    return Reference.from_image(cv2.imread(str(PHOTOS / file)), entry["pad_size_m"])


def photo_view(name: str, seed: int, k: int) -> np.ndarray:
    """View ``k`` of the shared photo whose file holds ``name``, in the photos bench's
    run of seed ``seed``."""
    items = load_manifest(PHOTOS)["items"]
    index = next(i for i, item in enumerate(items) if name in item["file"])
    return degraded_view(cv2.imread(str(PHOTOS / items[index]["file"])), seed, index, k)[0]


def photo_detected(image: np.ndarray, reference_file: str) -> bool:
    """Whether a pad is found in a photo (the photos bench's camera) with a reference."""
    h, w = image.shape[:2]
    camera = Camera.from_fov(w, h, FOV_DEG)
    return process_frame(image, photo_reference(reference_file), camera).detected


def score_bench_frames(design_name: str, frames: tuple[int, ...], level: str = "today") -> Tally:
    """The bench's frames ``frames`` of ``design_name`` at degradation ``level``, run
    with the attitude hint and scored as the bench scores them."""
    symmetric = get_design(design_name).symmetric
    tally = Tally()
    for i in frames:
        frame, _, g, view, reference = bench_frames(design_name, 0, i, level)
        res = process_frame(frame, reference, CAM, gravity_hint=g)
        tally.score(res.detected and res.pose is not None, res.pose, view, symmetric)
    return tally


def bench_frames(design_name: str, seed: int, i: int, level: str, **changes):
    """Frame ``i`` of the bench's views at ``level`` (seed ``seed``), with ``changes``
    to the view (`pipeline.render.view.View` fields): its pad, its empty twin, the
    attitude hint, the view and the design's reference."""
    pad, empty, hint, view = _views(get_design(design_name), seed, i, level, **changes)
    return pad, empty, hint, view, design_reference(design_name)


def _views(design: Design, seed: int, i: int, level: str, **changes):
    """`bench_frames`' pad, empty twin, attitude hint and view for any design."""
    scenes = make_scenes(design, [seed, i // SCENE_EVERY], level, ())
    view, noise_seed = make_view([seed, i, 7], CAM, design, level)
    view = dataclasses.replace(view, **changes)
    pad = render_view(scenes.pad, CAM, view, np.random.default_rng(noise_seed))
    empty = render_view(scenes.empty, CAM, view, np.random.default_rng(noise_seed))
    return pad, empty, gravity_hint(view.R_pad_cam, [seed, i, 11]), view


def sweep_frames(
    design: str, camera: Camera, point: int, altitude: float, j: int, per_point: int = 40
):
    """Frame ``j`` of point ``point`` of ``pipeline.bench --sweep altitude --frames
    per_point`` (its seeds): the pad's frame, its empty twin, the view, the attitude
    hint and the reference."""
    d = get_design(design)
    scenes = make_scenes(d, [0, 1000 + (point * per_point + j) // SCENE_EVERY % 4], "today", ())
    view, noise_seed = make_view([0, point, j, 11], camera, d, "today", altitude=(altitude,) * 2)
    pad = render_view(scenes.pad, camera, view, np.random.default_rng(noise_seed))
    empty = render_view(scenes.empty, camera, view, np.random.default_rng(noise_seed))
    reference = design_reference(design)
    return pad, empty, view, gravity_hint(view.R_pad_cam, [0, point, j, 12]), reference


def yaw_frames(design: str, yaw_deg: float, j: int):
    """Frame ``j`` of the first point of ``pipeline.bench --sweep yaw`` (its seeds) with
    the camera turned ``yaw_deg``: the pad's frame, the view, the attitude hint and the
    reference."""
    d = get_design(design)
    scenes = make_scenes(d, [0, 1000 + j // SCENE_EVERY % 4], "today", ())
    view, noise_seed = make_view(
        [0, 0, j, 11], CAM, d, "today", yaw_deg=yaw_deg, max_tilt_deg=HOVER_TILT_DEG
    )
    pad = render_view(scenes.pad, CAM, view, np.random.default_rng(noise_seed))
    return pad, view, gravity_hint(view.R_pad_cam, [0, 0, j, 12]), design_reference(design)


@functools.lru_cache(maxsize=4)
def design_reference(design_name: str) -> Reference:
    """The reference the bench makes of a design's picture."""
    design = get_design(design_name)
    return Reference.from_image(design.draw().image, design.size_m)


def assert_found_and_empty_twin_not(pad, empty, hint, view, reference) -> None:
    """The pad is found in ``pad`` within 5 % of the altitude (modulo a symmetric pad's
    half turn: its twin pose puts the camera at (-x, -y, z)), and nothing in ``empty``;
    the arguments as `bench_frames` returns them."""
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected, res.reason
    assert res.pose is not None
    found = np.asarray(res.pose.position_m)
    err = min(
        np.linalg.norm(found - view.position_m),
        np.linalg.norm(found * [-1, -1, 1] - view.position_m),
    )
    assert err < 0.05 * float(view.position_m[2]), err
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected


def true_homography(
    position: np.ndarray, R_pad_cam: np.ndarray, camera: Camera = CAM
) -> np.ndarray:
    """Pad metres -> pixels for the camera at ``position`` (pad frame)."""
    R = R_pad_cam.T
    t = -R @ position
    return camera.K @ np.column_stack([R[:, 0], R[:, 1], t])


# Not one of the bench's designs: a black H on a yellow disc printed on a white sheet,
# whose disc steps to the sheet a third as far as its H steps to the disc (a faint rim).
BLACK_ON_YELLOW = Design(
    name="black_on_yellow",
    description="black H on a yellow disc printed on a white sheet",
    size_m=0.8,
    background=(235, 235, 235),
    below=((Disc(0.45), (30, 205, 240)),),
    h=HShape(0.4, 0.5, 0.1, 0.09),
    h_bgr=(30, 30, 32),
    grain=1.5,
)


# Not one of the bench's designs either: a white H in a thin ring above a row of
# letters, on a dark grey board.
TEXT_BELOW = Design(
    name="text_below",
    description="white H in a ring above a row of letters, on a dark grey board",
    size_m=1.0,
    background=(60, 60, 62),
    below=(
        (Ring(0.44, 0.47), (232, 235, 235)),
        (
            Rects(tuple((x, -0.36, x + 0.05, -0.28) for x in np.arange(-0.3, 0.3, 0.08))),
            (232, 235, 235),
        ),
    ),
    h=HShape(0.34, 0.4, 0.08, 0.07),
    h_bgr=(232, 235, 235),
    symmetric=False,
    grain=2.0,
)


def design_frame(design: Design, i: int, level: str):
    """Frame ``i`` of the bench's views of ``design`` (seed 0; any design, registered
    or not): its pad, the attitude hint and the view."""
    pad, _, hint, view = design_frames(design, i, level)
    return pad, hint, view


def design_frames(design: Design, i: int, level: str):
    """`design_frame`'s pad with its empty twin: the pad, the empty twin, the attitude
    hint and the view."""
    return _views(design, 0, i, level)
