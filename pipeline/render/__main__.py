"""Write one random rendered view to look at, or time the renderer.

python -m pipeline.render --out /tmp/x.png --seed 3
python -m pipeline.render --bench 50      # prints JSON timings (one thread)
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.render.pad import PAD_SIZE_M, make_pad_image
from pipeline.render.raster import render_clean
from pipeline.render.scene import make_scene
from pipeline.render.view import random_view, render_view


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pipeline.render", description=__doc__)
    ap.add_argument("--out", help="PNG file to write one random view to")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--hfov", type=float, default=60.0, help="horizontal field of view, deg")
    ap.add_argument("--floor", default="textured")
    ap.add_argument("--lookalikes", type=int, default=2)
    ap.add_argument("--no-pad", action="store_true", help="leave the pad out")
    ap.add_argument("--bench", type=int, default=0, help="time this many renders, print JSON")
    args = ap.parse_args(argv)
    if not args.out and not args.bench:
        ap.error("give --out FILE and/or --bench N")

    rng = np.random.default_rng(args.seed)
    camera = Camera.from_fov(args.width, args.height, args.hfov)
    t0 = time.perf_counter()
    scene = make_scene(
        make_pad_image(),
        PAD_SIZE_M,
        rng=rng,
        floor=args.floor,
        lookalikes=args.lookalikes,
        pad_visible=not args.no_pad,
    )
    scene_ms = (time.perf_counter() - t0) * 1e3
    if args.out:
        view = random_view(rng, camera)
        image = render_view(scene, camera, view, rng)
        if not cv2.imwrite(args.out, image):
            print(f"could not write {args.out}", file=sys.stderr)
            return 1
        print(json.dumps({"out": args.out, "floor": scene.floor_kind, "view": view.to_dict()}))
    if args.bench:
        print(json.dumps(_bench(scene, camera, rng, args.bench) | {"scene_ms": scene_ms}))
    return 0


def _bench(scene, camera: Camera, rng: np.random.Generator, n: int) -> dict:
    """Median and 95th percentile of full renders (with degradations) and clean ones."""
    cv2.setNumThreads(1)
    views = [random_view(rng, camera) for _ in range(n)]
    render_view(scene, camera, views[0], rng)  # warm the per-camera caches
    full, clean = [], []
    for view in views:
        t0 = time.perf_counter()
        render_view(scene, camera, view, rng)
        t1 = time.perf_counter()
        render_clean(scene, camera, view.position_m, view.R_pad_cam)
        t2 = time.perf_counter()
        full.append((t1 - t0) * 1e3)
        clean.append((t2 - t1) * 1e3)
    return {
        "renders": n,
        "size": [camera.width, camera.height],
        "threads": 1,
        "floor": scene.floor_kind,
        "render_ms_median": float(np.median(full)),
        "render_ms_p95": float(np.percentile(full, 95)),
        "clean_ms_median": float(np.median(clean)),
    }


if __name__ == "__main__":
    sys.exit(main())
