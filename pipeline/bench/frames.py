"""What every benchmark renders: a design's scenes, the marker twins, the views.

One scene seed gives the pad's scene, the same floor and look-alikes without the
pad (the negatives), and the same floor with a marker of the pad's size in its
place (ArUco, AprilTag); one view seed gives the pose and the degradations that
all of them are rendered with.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from pipeline.bench.markers import marker_texture
from pipeline.bench.picture_design import PadDesign
from pipeline.camera import Camera
from pipeline.render import PAD_SIZE_M, Scene, View, make_scene, random_view

DEGRADE_LEVELS = ("clean", "today", "real")
"""``clean``: no noise, blur or lighting; ``today``: the bench's mix since the start
(SNR 15-30 dB, blur up to 1.2 px, lighting, tilt up to 12 degrees, four floors);
``real``: today's plus the real world's (tilt up to 35 degrees, motion blur, shadows,
glare, exposure, JPEG, every floor)."""

BASE_ALTITUDE_M = (1.0, 6.0)
"""The 0.55 m pad's altitudes; other pads' scale with their size (same pixel spans)."""

SCENE_EVERY = 10  # a new floor and new look-alikes every this many frames


def view_options(level: str) -> dict:
    """`random_view` keywords of a degradation level."""
    if level == "clean":
        return {"snr_db": None, "max_blur_px": 0.0, "lighting": False}
    if level == "today":
        return {}
    if level == "real":
        return {"max_tilt_deg": 35.0, "realistic": True}
    raise ValueError(f"degrade must be one of {DEGRADE_LEVELS}, got {level!r}")


def floor_for(level: str) -> str:
    return "any" if level == "real" else "textured"


def altitude_for(
    design: PadDesign, base: tuple[float, float] = BASE_ALTITUDE_M
) -> tuple[float, float]:
    """Altitudes at which ``design`` spans the pixels the 0.55 m pad spans at ``base``."""
    k = design.size_m / PAD_SIZE_M
    return (base[0] * k, base[1] * k)


@dataclass(frozen=True, eq=False)
class Scenes:
    pad: Scene
    empty: Scene
    markers: dict[str, Scene]


@functools.lru_cache(maxsize=8)
def _marker(kind: str, size_m: float) -> tuple[np.ndarray, float]:
    return marker_texture(kind, size_m)


def make_scenes(
    design: PadDesign, seed: list[int] | int, level: str, markers: tuple[str, ...]
) -> Scenes:
    """The pad's scene, its empty twin and one scene per marker kind, from one seed."""
    scene_rng = np.random.default_rng(seed)
    k = int(scene_rng.integers(0, 4))
    scene_seed = int(scene_rng.integers(1 << 31))
    floor = floor_for(level)
    pad = design.scene(np.random.default_rng(scene_seed), floor=floor, lookalikes=k)
    empty = dataclasses.replace(pad, pad=None)
    marked = {}
    for kind in markers:
        tex, size = _marker(kind, design.size_m)
        marked[kind] = make_scene(
            tex,
            size,
            rng=np.random.default_rng(scene_seed),
            floor=design.floors if design.floors is not None else floor,
            lookalikes=k,
            lookalike_bgr=design.h_bgr,
            h_size_m=design.h_size_m,
        )
    return Scenes(pad, empty, marked)


def make_view(
    seed: list[int], camera: Camera, design: PadDesign, level: str, **overrides
) -> tuple[View, int]:
    """A random view of ``design`` (see `view_options`) and the seed of its noise."""
    rng = np.random.default_rng(seed)
    opts = {"altitude": altitude_for(design)} | view_options(level) | overrides
    view = random_view(rng, camera, pad_size_m=design.size_m, **opts)
    return view, int(rng.integers(1 << 31))
