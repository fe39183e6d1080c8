"""Write one random rendered view to look at, or time the renderer.

python -m pipeline.render --out /tmp/x.png --seed 3
python -m pipeline.render --out /tmp/x.png --design orange_ring --realistic --floor any
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
from pipeline.render.designs import DESIGNS, get_design
from pipeline.render.pad import PAD_SIZE_M
from pipeline.render.raster import render_clean
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
    ap.add_argument("--design", default="default", choices=sorted(DESIGNS), help="pad design")
    ap.add_argument("--realistic", action="store_true", help="tilt to 35 deg, real degradations")
    args = ap.parse_args(argv)
    if not args.out and not args.bench:
        ap.error("give --out FILE and/or --bench N")
    design = get_design(args.design)
    scale = design.size_m / PAD_SIZE_M
    view_opts = {"pad_size_m": design.size_m, "altitude": (1.0 * scale, 6.0 * scale)}
    if args.realistic:
        view_opts |= {"max_tilt_deg": 35.0, "realistic": True}

    rng = np.random.default_rng(args.seed)
    camera = Camera.from_fov(args.width, args.height, args.hfov)
    t0 = time.perf_counter()
    scene = design.scene(
        rng, floor=args.floor, lookalikes=args.lookalikes, pad_visible=not args.no_pad
    )
    scene_ms = (time.perf_counter() - t0) * 1e3
    if args.out:
        view = random_view(rng, camera, **view_opts)
        image = render_view(scene, camera, view, rng)
        if not cv2.imwrite(args.out, image):
            print(f"could not write {args.out}", file=sys.stderr)
            return 1
        info = {"out": args.out, "design": design.name, "floor": scene.floor_kind}
        print(json.dumps(info | {"view": view.to_dict()}))
    if args.bench:
        timed = _bench(scene, camera, rng, args.bench, view_opts)
        print(json.dumps(timed | {"scene_ms": scene_ms, "design": design.name}))
    return 0


def _bench(scene, camera: Camera, rng: np.random.Generator, n: int, view_opts: dict) -> dict:
    """Median and 95th percentile of full renders (with degradations) and clean ones."""
    cv2.setNumThreads(1)
    views = [random_view(rng, camera, **view_opts) for _ in range(n)]
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
