"""Command line: ``python -m pipeline analyze FRAME --reference REF --pad-size M``.

``analyze`` prints the FrameResult JSON and writes the annotated frame;
``demo`` renders a frame of the default pad, analyses it and writes the picture.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.draw import annotate
from pipeline.picture import read_picture
from pipeline.preprocess import DEFAULT_METHOD, METHODS


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    an = sub.add_parser("analyze", help="run the pipeline on one picture")
    an.add_argument("frame", type=Path)
    an.add_argument("--reference", type=Path, required=True, help="top-down picture of the pad")
    an.add_argument("--pad-size", type=float, required=True, help="the pad's width, metres")
    an.add_argument("--out", type=Path, help="where to write the annotated frame (PNG)")
    _camera_args(an)
    demo = sub.add_parser("demo", help="render a frame of the default pad and analyse it")
    demo.add_argument("--out", type=Path, default=Path("out/demo.png"))
    demo.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    try:
        return _analyze(args) if args.command == "analyze" else _demo(args)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _camera_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--hfov", type=float, default=60.0, help="horizontal field of view, degrees")
    p.add_argument("--calibration", type=Path, help="OpenCV calibration YAML/JSON")
    p.add_argument("--yaw-hint", type=float, help="camera yaw in the pad frame, degrees")
    p.add_argument("--method", choices=METHODS, default=DEFAULT_METHOD, help="thresholding")


def _analyze(args: argparse.Namespace) -> int:
    frame = read_picture(args.frame)
    reference = Reference.from_image(read_picture(args.reference), args.pad_size)
    h, w = frame.shape[:2]
    camera = (
        Camera.from_file(args.calibration) if args.calibration else Camera.from_fov(w, h, args.hfov)
    )
    result = process_frame(frame, reference, camera, yaw_hint=args.yaw_hint, method=args.method)
    print(json.dumps(result.to_dict(), indent=2))
    if args.out:
        _write(args.out, frame, result, camera)
    return 0


def _write(path: Path, frame, result, camera) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    # The mask the pipeline searched with, on the reference's channel.
    if not cv2.imwrite(str(path), annotate(frame, result, camera, mask=result.mask)):
        raise ValueError(f"cannot write {path}")
    print(f"annotated frame written to {path}", file=sys.stderr)


def _demo(args: argparse.Namespace) -> int:
    from pipeline.render import make_pad_image, make_scene, random_view, render_view

    rng = np.random.default_rng(args.seed)
    pad = make_pad_image()
    reference = Reference.from_image(pad, 0.55)
    camera = Camera.from_fov(640, 480, 60.0)
    scene = make_scene(pad, 0.55, rng=rng, lookalikes=2)
    view = random_view(rng, camera)
    frame = render_view(scene, camera, view, rng)
    result = process_frame(frame, reference, camera)
    print(json.dumps(result.to_dict(), indent=2))
    truth = np.round(view.position_m, 3).tolist()
    print(f"true camera position (pad frame, m): {truth}", file=sys.stderr)
    _write(args.out, frame, result, camera)
    return 0


if __name__ == "__main__":
    sys.exit(main())
