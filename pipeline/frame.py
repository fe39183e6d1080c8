"""process_frame: from one camera frame to the H, its invariants and the pose."""

from __future__ import annotations

import math
import time
from typing import Protocol

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.edgefit import edge_support, fit_edges
from pipeline.edges import refine_polygon, surround_ratio
from pipeline.moments import hu_distance, shape_moments
from pipeline.pose import (
    ippe_candidates,
    pick_by_yaw,
    pose_to_vectors,
    project,
    tilt_deg,
    to_pose,
)
from pipeline.preprocess import DEFAULT_METHOD, METHODS, binarize, check_image, subsample
from pipeline.reference import H_CORNERS, Reference
from pipeline.result import FrameResult
from pipeline.shapes import Region, douglas_peucker, polygon_corners, regions, upsampled_contour

MIN_H_AREA_PX = 80.0  # smaller H's carry too few pixels for 12 corners
MAX_HU_DISTANCE = 0.7  # log10 distance of Hu 1-2 (3-7 are noise for a symmetric H)
MAX_SHAPE_RESIDUAL = 0.1  # homography fit RMS / sqrt(area): real H < 0.05, others > 0.25
SOLIDITY_TOLERANCE = 0.12
FINE_TRACE_BELOW_PX = 4000.0  # H's smaller than this are traced on a finer grid
FINE_FACTOR = 4
MIN_EDGE_SUPPORT = 0.45  # pad edges found where the pose puts them (look-alikes: < 0.3)
# Around a real H the board is dark; a look-alike on a floor is framed by floor.
SURROUND_MARGIN = 0.3  # frame's surround ratio may exceed the reference's by this
SURROUND_OFFSET_PX = 2.5  # sampled this far either side of the H's edges
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
    method : thresholding, one of ``pipeline.preprocess.METHODS``.
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
    binary = binarize(work, method)
    clock.lap("preprocess")

    area = float(work.shape[0] * work.shape[1])
    found = regions(binary.mask, min_area=MIN_H_AREA_PX, max_area=0.5 * area)
    ranked = rank_candidates(found, reference)
    clock.lap("contours")

    shapes = rejected = unframed = 0
    for region, hu in ranked:
        poly = None
        for reading in corner_readings(region, binary):
            ordered, residual = match_corners(reading, reference.corners_m, region.area)
            if residual <= MAX_SHAPE_RESIDUAL:
                poly = ordered
                break
        clock.lap("corners")
        if poly is None:
            continue
        shapes += 1
        refined = refine_polygon(binary.smooth, poly)
        corners = refined[0] if refined is not None else poly
        clock.lap("refine")
        if verifier is not None:
            # Refined corners: what the verifier sees does not depend on the threshold.
            accepted = verifier.accepts(corners, region.contour, cam)
            clock.lap("verify")
            if not accepted:
                rejected += 1
                continue
        fitted = _fit_pose(reference, binary.smooth, cam, corners)
        clock.lap("pose")
        if fitted is None:
            continue
        fit, support = fitted
        h_px = project(reference.corners_m, fit.rvec, fit.tvec, cam)
        surround = surround_ratio(binary.smooth, h_px, SURROUND_OFFSET_PX)
        if surround > reference.surround_ratio + SURROUND_MARGIN:
            unframed += 1
            clock.lap("pose")
            continue
        pose = pick_by_yaw(to_pose(fit.rvec, fit.tvec, fit.rms_px, reference.symmetric), yaw_hint)
        # Corner i is where reference corner i lies under the reported pose
        # (for a symmetric pad the twin pose numbers the corners 6 apart).
        corners = project(reference.corners_m, *pose_to_vectors(pose), cam)
        mom = shape_moments(region.contour)
        timings["total"] = (time.perf_counter() - t_start) * 1e3
        back = 1.0 / scale
        return FrameResult(
            detected=True,
            corners_px=(corners + 0.5) * back - 0.5,
            hu=tuple(float(v) for v in hu),
            orientation_deg=float(mom.orientation_deg),
            eccentricity=float(mom.eccentricity),
            pose=pose,
            timings_ms=timings,
            contour_px=(region.contour.astype(np.float64) + 0.5) * back - 0.5,
            score=support,
            mask=binary.mask,
        )
    if not ranked:
        reason = "no H-like shape in view"
    elif not shapes:
        reason = f"no H among {len(ranked)} H-like shape(s)"
    elif rejected == shapes:
        reason = f"the verifier rejected {shapes} H-shaped mark(s)"
    elif unframed:
        reason = f"{unframed} H-shaped mark(s) without the pad's dark board around them"
    else:
        reason = f"{shapes} H-shaped mark(s), but no pad's edges around them"
    return _nothing(timings, t_start, reason, binary.mask)


def rank_candidates(found: list[Region], reference: Reference) -> list[tuple[Region, tuple]]:
    """Regions shaped roughly like the reference's H, most alike first.

    Solidity and the first two Hu invariants are cheap and change little under
    the tilts a hovering camera sees; Hu 3-7 of a symmetric H are noise.
    """
    out = []
    for r in found:
        if abs(r.solidity - reference.solidity) > SOLIDITY_TOLERANCE:
            continue
        # OpenCV's moments here: the same numbers as pipeline.moments, faster.
        hu = tuple(cv2.HuMoments(cv2.moments(r.contour.reshape(-1, 1, 2))).ravel())
        d = hu_distance(hu, reference.hu, count=2)
        if d <= MAX_HU_DISTANCE:
            out.append((d, r, hu))
    out.sort(key=lambda item: item[0])
    return [(r, hu) for _, r, hu in out]


def corner_readings(region: Region, binary):
    """Ways to read the 12 corners of a candidate, best first.

    Curvature-scale-space corners on the boundary (traced on a 4x finer grid
    for small candidates), then Douglas-Peucker polygons of the same boundary
    and of the pixel boundary: blur can round a corner off or add a ripple
    that CSS takes for one, and the cheaper readings are tried only then.
    """
    fine = None
    if region.area <= FINE_TRACE_BELOW_PX:
        fine = upsampled_contour(binary.smooth, binary.mask, region, FINE_FACTOR)
    if fine is not None:
        pts, offset = fine
        for poly in (polygon_corners(pts, H_CORNERS), douglas_peucker(pts, H_CORNERS)):
            if poly is not None:
                yield (poly + 0.5) / FINE_FACTOR - 0.5 + offset
    else:
        poly = polygon_corners(region.contour, H_CORNERS)
        if poly is not None:
            yield poly
    poly = douglas_peucker(region.contour, H_CORNERS)
    if poly is not None:
        yield poly


def match_corners(poly: np.ndarray, ref_m: np.ndarray, area: float) -> tuple[np.ndarray, float]:
    """Rotate the corner list onto the reference's order; return it and the fit residual.

    All 12 cyclic shifts are scored at once by an affine fit (a few microseconds);
    the best is checked with a full homography, whose residual relative to the
    shape's size says whether this is the reference's H at all.
    """
    n = len(ref_m)
    X = np.column_stack([ref_m, np.ones(n)])
    P = np.linalg.pinv(X)  # (3, n)
    shifts = np.stack([np.roll(poly, -s, axis=0) for s in range(n)])  # (n, n, 2)
    fitted = np.einsum("ij,sjk->sik", X @ P, shifts)
    err = np.sum((shifts - fitted) ** 2, axis=(1, 2))
    s = int(np.argmin(err))
    ordered = shifts[s]
    H, _ = cv2.findHomography(ref_m, ordered, 0)
    if H is None:
        return ordered, math.inf
    proj = cv2.perspectiveTransform(ref_m.reshape(-1, 1, 2), H).reshape(-1, 2)
    rms = float(np.sqrt(np.mean(np.sum((proj - ordered) ** 2, axis=1))))
    return ordered, rms / math.sqrt(area)


def _fit_pose(reference: Reference, smooth: np.ndarray, cam: Camera, corners: np.ndarray):
    """The pose that best explains the edges of the whole pad, or None.

    IPPE on the H's corners gives two candidate poses (a small pad seen nearly
    head-on can be tilted either way); each takes one step on the edges of the
    H, the side bars and the board outline (pipeline.edgefit), and the one whose
    edges fit better goes on to converge. When the two fit equally well both
    go on, and if they still tie the one nearer to looking straight down wins,
    as a hovering multirotor's camera does. The winner must find most of the
    pad's edges where it puts them, or the H was a look-alike.
    """
    model = reference.edge_model
    img = smooth.astype(np.float32)
    fits = []
    for rvec0, tvec0 in ippe_candidates(reference.corners_m, corners, cam):
        fit = fit_edges(img, model, cam, rvec0, tvec0, iterations=1)
        if fit is not None:
            fits.append(fit)
    if not fits:
        return None
    fits.sort(key=lambda f: f.rms_px)
    if len(fits) > 1 and fits[0].rms_px < AMBIGUOUS_FIT * fits[1].rms_px:
        fits = fits[:1]
    best = None
    for start in fits:
        fit = fit_edges(img, model, cam, start.rvec, start.tvec, iterations=2, search_px=1.5)
        if fit is None:
            continue
        cand = (fit.rms_px, tilt_deg(fit.rvec), fit)
        if best is None or _better(cand, best):
            best = cand
    if best is None:
        return None
    fit = best[2]
    support = edge_support(img, model, cam, fit.rvec, fit.tvec)
    return (fit, support) if support >= MIN_EDGE_SUPPORT else None


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


def _nothing(
    timings: dict[str, float], t_start: float, reason: str, mask: np.ndarray | None = None
) -> FrameResult:
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
        mask=mask,
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
