"""process_frame: from one camera frame to the H, its invariants and the pose."""

from __future__ import annotations

import math
import time
from typing import Protocol

import numpy as np

from pipeline.camera import Camera
from pipeline.candidates import (
    MIN_BLOB_SEPARATION,
    MIN_EVIDENCE,
    MIN_H_AREA_PX,
    blob_separation,
    locate_all,
)
from pipeline.edgefit import EdgeFit, edge_support, fit_edges
from pipeline.moments import shape_moments
from pipeline.pose import (
    ippe_candidates,
    pick_by_yaw,
    pose_to_vectors,
    project,
    tilt_deg,
    to_pose,
)
from pipeline.preprocess import (
    DEFAULT_METHOD,
    METHODS,
    binarize_channel,
    check_image,
    subsample,
    to_channel,
)
from pipeline.reference import Reference
from pipeline.result import FrameResult
from pipeline.shapes import regions
from pipeline.strokes import MAX_DIP, deepest_dip, stroke_samples
from pipeline.template import template_ncc

MIN_EDGE_SUPPORT = 0.45  # the H's edges found where the pose puts them
MIN_TEMPLATE_NCC = 0.4  # with the reference picture around the H
AMBIGUOUS_FIT = 0.8  # two poses whose RMS errors are within this ratio are a tie


class CandidateVerifier(Protocol):
    """Checks a candidate's corner pattern (``pipeline.learn.Verifier`` is one)."""

    def accepts(self, corners_px: np.ndarray, contour_px: np.ndarray, camera: Camera) -> bool: ...


def process_frame(
    image_bgr: np.ndarray,
    reference: Reference,
    camera: Camera,
    *,
    yaw_hint: float | None = None,
    method: str = DEFAULT_METHOD,
    verifier: CandidateVerifier | None = None,
) -> FrameResult:
    """Find the reference's H in a frame and estimate the camera's pose over the pad.

    Parameters
    ----------
    image_bgr : H x W x 3 uint8 frame (or H x W gray). Frames wider than 640 px are
        subsampled to 640 (the seed's working size); ``camera`` may describe the
        frame at any resolution of the same aspect ratio.
    reference : the pad, from :meth:`Reference.from_image`.
    camera : the camera's intrinsics.
    yaw_hint : the camera's yaw in the pad frame (degrees, see
        ``pipeline.result.yaw_of``), e.g. from the vehicle's heading: picks
        which of the two poses of a 180-degree-symmetric pad to report.
    method : thresholding of the reference's channel, one of
        ``pipeline.preprocess.METHODS`` ("seed" is the dissertation's chain).
    verifier : an optional check of each H-shaped candidate's corner pattern
        (the RBM/DBN of ``pipeline.learn``, trained for this reference),
        consulted before the pose.

    Returns
    -------
    FrameResult; ``detected`` False (no exception) when no H is in view.

    Examples
    --------
    >>> from pipeline.render import make_pad_image, make_scene, render, camera_rotation
    >>> pad = make_pad_image(800)
    >>> ref = Reference.from_image(pad, 0.55)
    >>> cam = Camera.from_fov(640, 480, 60)
    >>> scene = make_scene(pad, 0.55, rng=np.random.default_rng(0))
    >>> frame = render(scene, cam, np.array([0.1, -0.2, 3.0]), camera_rotation(30.0))
    >>> res = process_frame(frame, ref, cam, yaw_hint=30.0)
    >>> res.detected, np.round(res.pose.position_m, 1).tolist()
    (True, [0.1, -0.2, 3.0])
    """
    t_start = time.perf_counter()
    image = check_image(image_bgr, "image_bgr")
    if not isinstance(reference, Reference):
        raise ValueError(f"reference must be a pipeline.Reference, got {type(reference).__name__}")
    if not isinstance(camera, Camera):
        raise ValueError(f"camera must be a pipeline.Camera, got {type(camera).__name__}")
    if yaw_hint is not None and not math.isfinite(float(yaw_hint)):
        raise ValueError(f"yaw_hint must be a finite number of degrees or None, got {yaw_hint}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    cam = _camera_for(camera, image.shape[1], image.shape[0])

    timings: dict[str, float] = {}
    clock = _Clock(timings)
    work, scale = subsample(image)
    if scale != 1.0:
        cam = cam.scaled(work.shape[1], work.shape[0])
    binary = binarize_channel(to_channel(work, reference.projection), method)
    clock.lap("preprocess")

    area = float(work.shape[0] * work.shape[1])
    found = regions(binary.mask, min_area=MIN_H_AREA_PX, max_area=0.5 * area)
    clock.lap("contours")

    located = rejected = unclear = unlike = broken = 0
    for hit in locate_all(found, binary, reference):
        located += 1
        clock.lap("corners")
        stroke = reference.leg_fraction * float(np.ptp(hit.corners, axis=0).max())
        blob = blob_separation(binary.smooth, hit.candidate.region, stroke)
        if hit.evidence < MIN_EVIDENCE or not blob >= MIN_BLOB_SEPARATION:
            unclear += 1
            clock.lap("check")
            continue
        ncc = template_ncc(
            binary.smooth,
            reference.template_pyramid,
            reference.channel_px_per_m,
            reference.corners_m,
            hit.fit.H,
        )
        if ncc < MIN_TEMPLATE_NCC:  # nan (a patch too small to compare) passes
            unlike += 1
            clock.lap("check")
            continue
        samples = stroke_samples(reference.corners_m, hit.fit.H, reference.bars_m)
        if deepest_dip(work, reference.projection.weights, samples) > MAX_DIP:
            broken += 1
            clock.lap("check")
            continue
        clock.lap("check")
        if verifier is not None:
            # Fitted corners: what the verifier sees does not depend on the threshold.
            accepted = verifier.accepts(hit.corners, hit.candidate.region.contour, cam)
            clock.lap("verify")
            if not accepted:
                rejected += 1
                continue
        fitted = _fit_pose(reference, binary.smooth, cam, hit.corners)
        clock.lap("pose")
        if fitted is None:
            continue
        fit, support = fitted
        pose = pick_by_yaw(to_pose(fit.rvec, fit.tvec, fit.rms_px, reference.symmetric), yaw_hint)
        # Corner i is where reference corner i lies under the reported pose
        # (for a symmetric pad the twin pose numbers the corners 6 apart).
        corners = project(reference.corners_m, *pose_to_vectors(pose), cam)
        region = hit.candidate.region
        mom = shape_moments(region.contour)
        timings["total"] = (time.perf_counter() - t_start) * 1e3
        back = 1.0 / scale
        return FrameResult(
            detected=True,
            corners_px=(corners + 0.5) * back - 0.5,
            hu=tuple(float(v) for v in hit.candidate.hu),
            orientation_deg=float(mom.orientation_deg),
            eccentricity=float(mom.eccentricity),
            pose=pose,
            timings_ms=timings,
            contour_px=(region.contour.astype(np.float64) + 0.5) * back - 0.5,
            score=support,
        )
    clock.lap("corners")
    if not found:
        reason = "no H-like shape in view"
    elif not located:
        reason = f"no H among {len(found)} bright shape(s)"
    elif rejected:
        reason = f"the verifier rejected {rejected} H-shaped mark(s)"
    elif unclear:
        reason = f"{unclear} H-shaped mark(s), none clearly an H on a plain board"
    elif unlike:
        reason = f"{unlike} H-shaped mark(s) that do not look like the reference picture"
    elif broken:
        reason = f"{broken} H-shaped mark(s) with a stroke cut through"
    else:
        reason = f"{located} H-shaped mark(s), but no pad's edges around them"
    return _nothing(timings, t_start, reason)


def _fit_pose(reference: Reference, smooth: np.ndarray, cam: Camera, corners: np.ndarray):
    """The camera's pose over the pad from the H's located corners, or None.

    IPPE on the corners gives two candidate poses (a small pad seen nearly
    head-on can be tilted either way). Each takes one step on the edges of the
    H, the other marks and the board outline (``pipeline.edgefit``), and the
    one whose edges fit better goes on to converge. When the two fit equally
    well both go on, and if they still tie the one nearer to looking straight
    down wins, as a hovering multirotor's camera does. The edge-refined pose
    is kept when it still puts the H where the frame shows it; otherwise (the
    rest of the pad is off the frame, hidden, or differs from the reference
    picture; the H is too small for the pose's edge samples) the corners
    alone decide. Returns the fit and the share of the whole pad's edges found.
    """
    model = reference.edge_model
    img = smooth.astype(np.float32)
    starts = ippe_candidates(reference.corners_m, corners, cam)
    if not starts:
        return None
    tolerance = max(1.0, 0.03 * float(np.ptp(corners, axis=0).max()))
    fits = []
    for rvec0, tvec0 in starts:
        fit = fit_edges(img, model, cam, rvec0, tvec0, iterations=1)
        if fit is not None:
            fits.append(fit)
    fits.sort(key=lambda f: f.rms_px)
    if len(fits) > 1 and fits[0].rms_px < AMBIGUOUS_FIT * fits[1].rms_px:
        fits = fits[:1]
    best = None
    for start in fits:
        fit = fit_edges(img, model, cam, start.rvec, start.tvec, iterations=2, search_px=1.5)
        if fit is None:
            continue
        moved = project(reference.corners_m, fit.rvec, fit.tvec, cam) - corners
        if np.max(np.hypot(moved[:, 0], moved[:, 1])) > tolerance:
            continue
        cand = (fit.rms_px, tilt_deg(fit.rvec), fit)
        if best is None or _better(cand, best):
            best = cand
    if best is None:
        best = min(
            (_corner_fit(reference.corners_m, corners, cam, r, t) for r, t in starts),
            key=_corner_rank,
        )
    fit = best[2]
    return fit, edge_support(img, model, cam, fit.rvec, fit.tvec)


def _corner_fit(corners_m: np.ndarray, corners: np.ndarray, cam: Camera, rvec, tvec):
    rms = float(np.sqrt(np.mean(np.sum((project(corners_m, rvec, tvec, cam) - corners) ** 2, 1))))
    return (rms, tilt_deg(rvec), EdgeFit(rvec, tvec, rms, len(corners_m), len(corners_m)))


def _corner_rank(cand) -> tuple[float, float]:
    # Both of IPPE's poses usually fit 12 corners to a fraction of a pixel:
    # within that, the camera nearer to looking straight down.
    return (round(cand[0] / 0.25), cand[1])


def _better(a, b) -> bool:
    if min(a[0], b[0]) > AMBIGUOUS_FIT * max(a[0], b[0]):
        return a[1] < b[1]
    return a[0] < b[0]


def _camera_for(camera: Camera, width: int, height: int) -> Camera:
    if (camera.width, camera.height) == (width, height):
        return camera
    if abs(camera.width / camera.height - width / height) > 0.01:
        raise ValueError(
            f"camera is {camera.width}x{camera.height} but image_bgr is {width}x{height}: "
            "the aspect ratios differ"
        )
    return camera.scaled(width, height)


def _nothing(timings: dict[str, float], t_start: float, reason: str) -> FrameResult:
    timings["total"] = (time.perf_counter() - t_start) * 1e3
    nan = float("nan")
    return FrameResult(
        detected=False,
        corners_px=np.zeros((0, 2)),
        hu=(nan,) * 7,
        orientation_deg=nan,
        eccentricity=nan,
        pose=None,
        timings_ms=timings,
        reason=reason,
    )


class _Clock:
    def __init__(self, timings: dict[str, float]) -> None:
        self.timings = timings
        self.t = time.perf_counter()

    def lap(self, name: str) -> None:
        """Add the time since the last lap to stage ``name``."""
        now = time.perf_counter()
        self.timings[name] = self.timings.get(name, 0.0) + (now - self.t) * 1e3
        self.t = now
