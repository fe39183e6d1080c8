"""``python -m pipeline.warmup``: compile the vision's compiled loops (``pipeline.jit``)
before a frame needs them.

Compiling them takes some seconds the first time on a machine (then they load from
numba's cache in well under one): ``make install`` and the container's build run this,
so that the station's first frame and the tests do not wait for it.
"""

from __future__ import annotations

import sys
import time

import numpy as np


def warm_up() -> float:
    """Process two rendered frames of the default pad (with and without the attitude,
    which take different paths), the second again as tracked, and one without the pad,
    so that every compiled loop is compiled and cached. Returns the seconds it took."""
    from pipeline import Camera, Reference, process_frame
    from pipeline.render import camera_rotation, make_pad_image, make_scene, render

    start = time.perf_counter()
    pad = make_pad_image(400)
    reference = Reference.from_image(pad, 0.55)
    camera = Camera.from_fov(320, 240, 60.0)
    scene = make_scene(pad, 0.55, rng=np.random.default_rng(0), floor="plain")
    frame = render(scene, camera, np.array([0.05, -0.05, 2.0]), camera_rotation(20.0))
    for gravity in (None, np.array([0.0, 0.0, 1.0])):
        found = process_frame(frame, reference, camera, gravity_hint=gravity)
        if not found.detected:
            raise RuntimeError("the warm-up frame's pad was not found: the vision is broken")
    # ... and followed into the next frame (tracking's own steps).
    followed = process_frame(frame, reference, camera, gravity_hint=gravity, prior=found)
    if followed.found_by != "follow":
        raise RuntimeError("the warm-up frame's pad was not followed: the vision is broken")
    # A frame without the pad takes every search, and a dark square holding a bright
    # mark, the board search's loops.
    empty = np.full((camera.height, camera.width, 3), 120, np.uint8)
    empty[100:116, 150:166] = 30
    empty[105:111, 155:161] = 230
    if process_frame(empty, reference, camera).detected:
        raise RuntimeError("the warm-up's empty frame gave a pad: the vision is broken")
    return time.perf_counter() - start


if __name__ == "__main__":
    print(f"vision compiled and cached in {warm_up():.1f} s", file=sys.stderr)
