"""``python -m pipeline.bench [--design NAME|all | --picture FILE --size M] [--sweep KIND] ...``."""

from __future__ import annotations

import argparse
import json
import sys

from pipeline.bench import accuracy
from pipeline.bench.frames import DEGRADE_LEVELS
from pipeline.bench.picture_design import PictureDesign, picture_design
from pipeline.preprocess import DEFAULT_METHOD, METHODS

SWEEPS = ("altitude", "snr", "tilt", "yaw")
RESOLUTIONS = ("640x480", "1280x720", "1920x1080")
SWEPT_RESOLUTIONS = RESOLUTIONS[:2]  # the altitude sweep's without --resolution


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m pipeline.bench", description=sys.modules["pipeline.bench"].__doc__
    )
    parser.add_argument("--frames", type=int, help="frames (per sweep point); 200 or 20")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--methods", default=",".join(METHODS), help="thresholdings to compare")
    parser.add_argument("--design", help="a design name, comma-separated names, or 'all'")
    parser.add_argument(
        "--picture",
        metavar="FILE",
        help="your own pad instead of a design: its top-down picture (as the station's "
        "reference), laid on the bench's floors; with --size (--sweep, --vector take it too)",
    )
    parser.add_argument(
        "--size", type=float, metavar="M", help="--picture: its width, m (the pad's, cropped)"
    )
    parser.add_argument("--degrade", choices=DEGRADE_LEVELS, default="today")
    parser.add_argument("--sweep", choices=SWEEPS)
    parser.add_argument(
        "--resolution",
        choices=RESOLUTIONS,
        help="sweep resolution (altitude: 640x480 and 1280x720 by default)",
    )
    parser.add_argument("--plot", metavar="DIR", help="write the sweep's PNG plots here")
    parser.add_argument("--report", metavar="DIR", help="the dissertation's experiments")
    parser.add_argument("--quick", action="store_true", help="report: fewer frames (a smoke run)")
    parser.add_argument(
        "--hint",
        action="store_true",
        help="give the pipeline the camera's attitude (a little off), as a vehicle would",
    )
    parser.add_argument(
        "--track", action="store_true", help="a descent over the pad, tracked frame to frame"
    )
    parser.add_argument(
        "--vector",
        action="store_true",
        help="the pose on frames drawn another way (1-6 m): the default pad as vector "
        "polygons, another --design's picture warped by OpenCV",
    )
    parser.add_argument(
        "--photos",
        metavar="DIR",
        help="real photos of H pads with a manifest.json (as ../shared/photos): found in "
        "their boxes, false positives on the negatives",
    )
    parser.add_argument(
        "--augment",
        type=int,
        default=0,
        metavar="K",
        help="photos: K more views of each through real-world degradations",
    )
    args = parser.parse_args(argv)
    if args.frames is not None and args.frames <= 0:
        parser.error("--frames must be positive")
    if args.augment < 0:
        parser.error("--augment must be 0 or more")
    methods = [m for m in args.methods.split(",") if m]
    if not methods or any(m not in METHODS for m in methods):
        parser.error(f"--methods must name some of {METHODS}")
    if DEFAULT_METHOD not in methods and not (args.sweep or args.report):
        parser.error(f"--methods must include {DEFAULT_METHOD}")
    if args.sweep and args.report:
        parser.error("--sweep and --report are separate runs")
    if args.picture is not None:
        if args.size is None:
            parser.error("--picture needs --size: the pad's width in metres")
        if args.design is not None:
            parser.error("--picture and --design are separate runs")
        if args.photos or args.track or args.report:
            parser.error("--picture goes with the design bench, --sweep or --vector")
    elif args.size is not None:
        parser.error("--size goes with --picture")
    try:
        out = _dispatch(args, methods)
    except ValueError as exc:
        parser.error(str(exc))
    print(json.dumps(out, indent=2))
    return 0


def _dispatch(args: argparse.Namespace, methods: list[str]) -> dict:
    if args.photos:
        from pipeline.bench.photos import run_photos

        return run_photos(args.photos, augment=args.augment, seed=args.seed)
    design = picture_design(args.picture, args.size) if args.picture else args.design
    if args.vector:
        from pipeline.bench.vector import run_vector

        frames = args.frames or 150
        if isinstance(design, PictureDesign):
            return {"designs": {design.name: run_vector(frames, args.seed, design=design)}}
        if args.design is None:
            return run_vector(frames=frames, seed=args.seed)
        return {
            "designs": {
                name: run_vector(frames=frames, seed=args.seed, design=name)
                for name in accuracy.design_names(args.design)
            }
        }
    if args.track:
        from pipeline.bench.track import run_track

        return run_track(frames=args.frames or 60, seed=args.seed, design=args.design or "default")
    if args.report:
        from pipeline.bench.report import write_report

        return write_report(args.report, seed=args.seed, frames=args.frames, quick=args.quick)
    if args.sweep:
        from pipeline.bench.sweep import run_sweep

        if args.resolution:
            resolutions = [args.resolution]
        else:
            resolutions = list(SWEPT_RESOLUTIONS) if args.sweep == "altitude" else [RESOLUTIONS[0]]
        return run_sweep(
            args.sweep,
            resolutions=[tuple(int(v) for v in r.split("x")) for r in resolutions],
            frames=args.frames or 20,
            seed=args.seed,
            design=design or "default",
            degrade=args.degrade,
            method=DEFAULT_METHOD if DEFAULT_METHOD in methods else methods[0],
            plot_dir=args.plot,
            hint=args.hint,
        )
    frames = args.frames or 200
    if isinstance(design, PictureDesign):
        return accuracy.run_designs(
            [design], frames, args.seed, methods, degrade=args.degrade, hint=args.hint
        )
    if design is None:
        return accuracy.run(frames, args.seed, methods, degrade=args.degrade, hint=args.hint)
    names = accuracy.design_names(design)
    return accuracy.run_designs(
        names, frames, args.seed, methods, degrade=args.degrade, hint=args.hint
    )


if __name__ == "__main__":
    sys.exit(main())
