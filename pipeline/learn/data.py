"""Synthetic training and test candidates, taken the way process_frame sees them.

Every frame is rendered by `pipeline.render` (random altitude, tilt, yaw, noise,
blur, lighting, textured floors) and goes through process_frame's candidate
path: Otsu binarisation, white regions, the solidity and Hu gate, 12 corners,
the corners put in the reference's order with their homography residual.

Frame kinds
-----------
``pad``
    the reference's own pad (with 0-2 look-alikes beside it). The candidate at
    the pad's projected centre that passes the corner check is a positive; any
    other candidate in the frame is a negative ("clutter").
``lookalike``
    no pad, 3-6 white look-alikes (rectangles, letters, 'II', broken H's, wide
    H's, crosses, legs without a bar) on the floor.
``stretched``
    the reference's pad stretched by 1.35-1.8 along a random direction: an H
    with other proportions whose corners are still an affine image of the
    reference's, so the homography gate passes it. (Below ~1.3 a stretch is
    within what perspective and corner noise do to small views of the right H.)
``proportions``
    a pad drawn with other leg, crossbar, width and height proportions, kept
    only when its corner layout differs from the reference's by at least
    ``MIN_LAYOUT_DISTANCE`` (similarity-aligned RMS in units of sqrt(area);
    rendered views of the right H themselves spread up to ~0.11).

Candidates of the negative kinds are all negatives. Floors and look-alikes
change every ``SCENE_EVERY`` frames (a floor is slow to build); the
mis-proportioned pads change every frame, on the same floor.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.candidates import MIN_H_AREA_PX, MIN_H_SUPPORT, locate_all
from pipeline.learn.encoding import Encoder, kabsch_rotation, normalise
from pipeline.preprocess import DEFAULT_METHOD, subsample, to_channel
from pipeline.reference import Reference
from pipeline.render import (
    LOOKALIKE_KINDS,
    PadGeometry,
    make_pad_image,
    make_scene,
    random_view,
    render_view,
)
from pipeline.render.raster import project_points
from pipeline.render.scene import _make_decal
from pipeline.shapes import regions

MAX_SHAPE_RESIDUAL = 1.0 - MIN_H_SUPPORT  # the pipeline's gate: located H's it checks
TRAIN_GATE = MAX_SHAPE_RESIDUAL  # candidates up to this residual are learned from
FRAME_KINDS = ("pad", "lookalike", "stretched", "proportions")
NEGATIVE_KINDS = FRAME_KINDS[1:]
SCENE_EVERY = 10  # views per floor/look-alike layout (a scene takes ~0.2 s to build)
MAX_TILT_DEG = 20.0  # wider than the accuracy bench's 12: a landing approach leans more
ALTITUDE_M = (1.0, 6.0)
STRETCH = (1.35, 1.8)  # 1.25 overlaps what perspective and corner noise do to a real H
# Normalised corner RMS; rendered views of the right H reach ~0.11 (perspective, noise).
MIN_LAYOUT_DISTANCE = 0.12
PAD_PICTURE_PX = 600  # mis-proportioned pads' pictures (enough for 1 m altitude)
POSITIVE_RADIUS = 0.25  # of the H's projected span: how near the pad's centre a positive lies

Progress = Callable[[float], None]


@dataclass(frozen=True, eq=False)
class Candidate:
    """One shape that reached the corner check: ordered corners, contour, fit residual."""

    corners: np.ndarray  # (12, 2) pixels, in the reference's corner order
    contour: np.ndarray  # (M, 2) pixels
    residual: float  # homography RMS / sqrt(area), as process_frame gates it
    area: float
    hu: tuple[float, ...]


@dataclass(frozen=True, eq=False)
class Frame:
    """A rendered frame, its kind, and where the reference's H is (pad frames only)."""

    image: np.ndarray
    kind: str
    h_centre_px: np.ndarray | None
    h_span_px: float


@dataclass(frozen=True, eq=False)
class CandidateSet:
    """Labelled candidates (1: the reference's H) from ``frames`` rendered frames."""

    candidates: tuple[Candidate, ...]
    labels: np.ndarray  # (n,) int64
    kinds: tuple[str, ...]  # frame kind of each candidate ("clutter" for pad frames' others)
    frames: int
    pad_frames: int

    def codes(self, encoder: Encoder) -> np.ndarray:
        """(n, encoder.size) binary codes."""
        return encoder.encode_many([(c.corners, c.contour) for c in self.candidates])

    def hu(self) -> np.ndarray:
        """(n, 7) signed log10 Hu invariants of the contours."""
        hu = np.array([c.hu for c in self.candidates], np.float64).reshape(-1, 7)
        return -np.sign(hu) * np.log10(np.abs(hu) + 1e-30)

    @property
    def positives(self) -> int:
        return int(self.labels.sum())


def frame_candidates(
    image: np.ndarray,
    reference: Reference,
    *,
    max_residual: float = TRAIN_GATE,
    method: str = DEFAULT_METHOD,
) -> list[Candidate]:
    """The located H's process_frame would check in ``image`` (``pipeline.candidates``).

    The same steps as ``pipeline.process_frame`` up to its checks (subsample,
    the reference's channel, threshold, regions, shape match, the H's sides
    fitted on the edges); ``residual`` is the share of the H's sides not found
    (``1 - support``), kept up to ``max_residual``. Coordinates are in the
    (subsampled) working image; the corners the verifier sees are the fitted
    ones, as in process_frame.
    """
    work, _ = subsample(image)
    binary = reference.binarize(to_channel(work, reference.projection), method)
    area = float(work.shape[0] * work.shape[1])
    found = regions(binary.mask, min_area=MIN_H_AREA_PX, max_area=0.5 * area)
    out = []
    for hit in locate_all(found, binary, reference):
        residual = 1.0 - hit.fit.support
        if residual <= max_residual:
            region = hit.candidate.region
            contour = region.contour.astype(np.float64)
            out.append(
                Candidate(hit.corners, contour, residual, float(region.area), hit.candidate.hu)
            )
    return out


def stretched_texture(image: np.ndarray, factor: float, angle_deg: float) -> np.ndarray:
    """``image`` stretched by ``factor`` along direction ``angle_deg`` (whole, re-framed)."""
    h, w = image.shape[:2]
    a = math.radians(angle_deg)
    u = np.array([math.cos(a), math.sin(a)])
    A = np.eye(2) + (factor - 1.0) * np.outer(u, u)
    box = np.array([[0, 0], [w, 0], [w, h], [0, h]], np.float64) @ A.T
    lo, hi = box.min(axis=0), box.max(axis=0)
    M = np.column_stack([A, -lo])
    size = tuple(math.ceil(v) for v in hi - lo)
    return cv2.warpAffine(image, M, size, flags=cv2.INTER_AREA, borderMode=cv2.BORDER_REPLICATE)


def layout_distance(corners_a: np.ndarray, corners_b: np.ndarray) -> float:
    """RMS distance of two 12-corner layouts after similarity alignment (best start)."""
    a, _, _ = normalise(np.asarray(corners_a, np.float64))
    b, _, _ = normalise(np.asarray(corners_b, np.float64))
    best = math.inf
    for s in range(len(a)):
        rolled = np.roll(a, -s, axis=0)
        R = kabsch_rotation(rolled, b)
        best = min(best, float(np.sqrt(np.mean(np.sum((rolled @ R.T - b) ** 2, axis=1)))))
    return best


def iter_frames(
    reference: Reference,
    camera: Camera,
    *,
    views: int,
    seed: int,
    kinds: tuple[str, ...] = FRAME_KINDS,
) -> Iterator[Frame]:
    """``views`` frames of the pad and ``views`` frames of negatives (spread over ``kinds``)."""
    negatives = [k for k in kinds if k != "pad"]
    plan = ["pad"] * views if "pad" in kinds else []
    # Negative kinds take turns a scene at a time (a floor takes ~0.3 s to build);
    # the mis-proportioned pads change every frame (a new pad picture is cheap).
    if negatives:
        plan += [negatives[(i // SCENE_EVERY) % len(negatives)] for i in range(views)]
    scene = None
    for i, kind in enumerate(plan):
        block = i // SCENE_EVERY
        if scene is None or scene[0] != (kind, block):
            rng = np.random.default_rng([seed, block, FRAME_KINDS.index(kind)])
            sc = make_scene(
                reference.image,
                reference.pad_size_m,
                rng=rng,
                lookalikes=int(rng.integers(3, 7)) if kind == "lookalike" else int(rng.integers(3)),
                lookalike_kinds=LOOKALIKE_KINDS,
                pad_visible=kind != "lookalike",
                # Look-alikes painted like this pad's H and as big: the hard negatives.
                lookalike_bgr=reference.paint_bgr,
                h_size_m=reference.h_size_m,
            )
            scene = ((kind, block), sc)
        current = scene[1]
        if kind in ("stretched", "proportions"):
            texture, size_m = _texture(reference, kind, np.random.default_rng([seed, i, 98]))
            current = dataclasses.replace(
                current,
                pad=_make_decal("pad", texture, None, (0.0, 0.0), 0.0, size_m),
                pad_width_m=size_m,
                pad_height_m=size_m * texture.shape[0] / texture.shape[1],
            )
        rng = np.random.default_rng([seed, i, 99])
        view = random_view(
            rng,
            camera,
            altitude=ALTITUDE_M,
            max_tilt_deg=MAX_TILT_DEG,
            pad_size_m=reference.pad_size_m,
        )
        image = render_view(current, camera, view, rng)
        centre, span = None, 0.0
        if kind == "pad":
            px = project_points(camera, view.position_m, view.R_pad_cam, reference.corners_m)
            centre = px.mean(axis=0)
            span = float(np.max(np.ptp(px, axis=0)))
        yield Frame(image, kind, centre, span)


def collect(
    reference: Reference,
    *,
    views: int,
    seed: int,
    camera: Camera | None = None,
    kinds: tuple[str, ...] = FRAME_KINDS,
    max_residual: float = TRAIN_GATE,
    progress: Progress | None = None,
) -> CandidateSet:
    """Render ``2 * views`` frames and label their candidates (see module docstring)."""
    if isinstance(views, bool) or not isinstance(views, int) or views <= 0:
        raise ValueError(f"views must be a positive integer, got {views!r}")
    camera = camera or Camera.from_fov(640, 480, 60.0)
    cands: list[Candidate] = []
    labels: list[int] = []
    tags: list[str] = []
    frames = pad_frames = 0
    total = views * (2 if "pad" in kinds and len(kinds) > 1 else 1)
    for frame in iter_frames(reference, camera, views=views, seed=seed, kinds=kinds):
        frames += 1
        pad_frames += frame.kind == "pad"
        for cand, label in label_candidates(frame, reference, max_residual=max_residual):
            cands.append(cand)
            labels.append(label)
            tags.append(frame.kind if frame.kind != "pad" or label else "clutter")
        if progress is not None:
            progress(frames / total)
    return CandidateSet(tuple(cands), np.array(labels, np.int64), tuple(tags), frames, pad_frames)


def label_candidates(
    frame: Frame, reference: Reference, *, max_residual: float = TRAIN_GATE
) -> list[tuple[Candidate, int]]:
    """The frame's candidates with labels; the pad's H when poorly traced is left out."""
    out = []
    for cand in frame_candidates(frame.image, reference, max_residual=max_residual):
        if frame.kind != "pad":
            out.append((cand, 0))
            continue
        if is_pad_h(cand, frame):
            if cand.residual <= MAX_SHAPE_RESIDUAL:
                out.append((cand, 1))
            continue  # the H, but the pipeline would not check it: neither class
        out.append((cand, 0))
    return out


def is_pad_h(cand: Candidate, frame: Frame) -> bool:
    """Whether a candidate of a pad frame is the reference's H (by where it lies)."""
    if frame.h_centre_px is None:
        return False
    offset = np.linalg.norm(cand.corners.mean(axis=0) - frame.h_centre_px)
    return bool(offset <= POSITIVE_RADIUS * max(frame.h_span_px, 1.0))


def _texture(reference: Reference, kind: str, rng: np.random.Generator):
    """A mis-proportioned pad's picture for a negative frame kind, and its width in metres."""
    for _ in range(50 if kind == "proportions" else 0):
        width, height = rng.uniform(0.3, 0.62), rng.uniform(0.3, 0.8)
        leg, bar = rng.uniform(0.12, 0.35) * width, rng.uniform(0.08, 0.4) * height
        try:
            geom = PadGeometry(reference.pad_size_m, width, height, leg, bar)
        except ValueError:  # the H would touch the side bars
            continue
        if layout_distance(geom.h_corners_m, reference.corners_m) >= MIN_LAYOUT_DISTANCE:
            img = make_pad_image(
                PAD_PICTURE_PX,
                h_width=width,
                h_height=height,
                leg_width=leg,
                crossbar_height=bar,
                board_bgr=_bgr(reference.board_bgr),
                paint_bgr=_bgr(reference.paint_bgr),
            )
            return img, reference.pad_size_m
    # A stretched pad (also when no drawn H differed enough from an unusual reference).
    factor = float(rng.uniform(*STRETCH))
    if rng.random() < 0.5:
        factor = 1.0 / factor  # squeezed: widen the other way
    img = stretched_texture(reference.image, factor, float(rng.uniform(0.0, 180.0)))
    return img, reference.pad_size_m * img.shape[1] / reference.image.shape[1]


def _bgr(colour: tuple[float, float, float]) -> tuple[int, int, int]:
    b, g, r = (round(float(v)) for v in colour)
    return b, g, r
