"""process_frame: from one camera frame to the H, its invariants and the pose."""

from __future__ import annotations

import math
import time
from typing import Protocol

import cv2
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
from pipeline.homography_fit import apply_h, fit_homography
from pipeline.homography_fit import support as edge_share
from pipeline.moments import shape_moments
from pipeline.pose import (
    ippe_candidates,
    pick_by_yaw,
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
from pipeline.template import compare

MIN_EDGE_SUPPORT = 0.45  # the H's edges found where the pose puts them
MIN_TEMPLATE_NCC = 0.4  # with the reference picture around the H
BOARD_TOLERANCE = 0.2  # the board's brightness relative to the H's, against the reference's
MAX_HUE = 0.3  # the board's chromaticity, L1 distance to the reference's
AMBIGUOUS_FIT = 0.8  # two poses whose RMS errors are within this ratio are a tie
WIDE_SEARCH_PX = 6.0  # how far the whole pad's edges are first looked for
SELF_SUFFICIENT_PX = 100.0  # an H this large pins the pose by itself
MIN_MARKS_FOUND = 0.5  # of the marks' resolvable sides, for the whole pad to count
MARK_SIDE_PX = 4.0  # a mark's straight side shorter than this (a star's point) is not told
_HALF_TURN = np.diag([-1.0, -1.0, 1.0])  # pad metres turned about the centre


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

    located = rejected = unclear = unlike = unframed = broken = 0
    for hit in locate_all(found, binary, reference):
        located += 1
        clock.lap("corners")
        stroke = reference.leg_fraction * float(np.ptp(hit.corners, axis=0).max())
        H_inv = np.linalg.inv(hit.fit.H)
        blob = blob_separation(
            binary.smooth,
            hit.candidate.region,
            stroke,
            lambda px, Hi=H_inv: ~reference.is_paint(apply_h(Hi, px)),
        )
        if hit.evidence < MIN_EVIDENCE or not blob >= MIN_BLOB_SEPARATION:
            unclear += 1
            clock.lap("check")
            continue
        seen = compare(
            work,
            binary.smooth,
            reference.template_pyramid,
            reference.channel_px_per_m,
            reference.corners_m,
            hit.fit.H,
        )
        # nan (a patch too small to compare, a board too dark for a hue) passes.
        if seen.ncc < MIN_TEMPLATE_NCC:
            unlike += 1
            clock.lap("check")
            continue
        if abs(seen.board - seen.reference_board) > BOARD_TOLERANCE or seen.hue > MAX_HUE:
            unframed += 1
            clock.lap("check")
            continue
        samples = stroke_samples(reference.corners_m, hit.fit.H, reference.is_paint)
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
        H = _whole_pad(hit.fit.H, reference, binary.smooth)
        # With the pad's other marks found, or a lens whose distortion the
        # homography cannot follow, the pose is refined on the edges.
        polish = H is not hit.fit.H or cam.has_distortion
        H = _heading(H, reference, binary.smooth)
        fitted = _fit_pose(reference, binary.smooth, cam, H, polish=polish)
        clock.lap("pose")
        if fitted is None:
            continue
        fit, support = fitted
        found_pose = to_pose(fit.rvec, fit.tvec, fit.rms_px, reference.symmetric)
        pose = pick_by_yaw(found_pose, yaw_hint)
        # The corners as found on the frame (they do not depend on the camera
        # model), numbered for the reported pose: corner i is where reference
        # corner i lies; the twin of a symmetric pad numbers them 6 apart.
        corners = apply_h(H, reference.corners_m)
        if pose is not found_pose:
            corners = np.roll(corners, -6, axis=0)
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
            mask=binary.mask,
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
    elif unframed:
        reason = f"{unframed} H-shaped mark(s) without the pad's board around them"
    elif broken:
        reason = f"{broken} H-shaped mark(s) with a stroke cut through"
    else:
        reason = f"{located} H-shaped mark(s), but no pad's edges around them"
    return _nothing(timings, t_start, reason, binary.mask)


def _whole_pad(H: np.ndarray, reference: Reference, smooth: np.ndarray) -> np.ndarray:
    """The homography refitted on the edges of the whole pad, when they are found.

    The H alone pins the plane's tilt poorly: its corners, a few tens of pixels
    apart, leave a degree of tilt to a tenth of a pixel. The pad's other marks
    (a ring, a rim, bars) lie farther out; seen from the H's homography they may
    be several pixels off, so they are searched for widely first. Kept when
    most of the marks' edges are found and it still puts the H where it was.
    An H over ``SELF_SUFFICIENT_PX`` pins the pose by itself.
    """
    model = reference.marks_model
    span = float(np.ptp(apply_h(H, reference.corners_m), axis=0).max())
    if model is None or span > SELF_SUFFICIENT_PX:
        return H
    img = smooth.astype(np.float32)
    fit = fit_homography(
        img, reference.edge_model, H, iterations=3, search_px=WIDE_SEARCH_PX, sides_alike=False
    )
    if fit is None or edge_share(img, model, fit.H, MARK_SIDE_PX) < MIN_MARKS_FOUND:
        return H
    moved = apply_h(fit.H, reference.corners_m) - apply_h(H, reference.corners_m)
    if np.max(np.hypot(moved[:, 0], moved[:, 1])) > max(1.0, 0.03 * span):
        return H
    return fit.H


def _heading(H: np.ndarray, reference: Reference, smooth: np.ndarray) -> np.ndarray:
    """The homography (pad metres -> pixels) for the pad's heading.

    The H alone looks the same after a half turn; on a pad whose other marks
    do not (a triangle, stars above the H), the turn under which more of the
    marks' edges are found is the pad's.
    """
    model = reference.marks_model
    if reference.symmetric or model is None:
        return H
    img = smooth.astype(np.float32)
    turned = H @ _HALF_TURN
    return turned if edge_share(img, model, turned) > edge_share(img, model, H) else H


def _fit_pose(
    reference: Reference, smooth: np.ndarray, cam: Camera, H: np.ndarray, *, polish: bool
):
    """The camera's pose over the pad from the located homography, or None.

    The homography already holds every edge of the pad that was found; the
    pose is the rigid motion that maps the pad's points (the H's corners and
    the marks' vertices) where it does, by IPPE. A small pad seen nearly head
    on fits two poses almost equally, tilted either way: unless one fits
    clearly better, the one nearer to looking straight down wins, as a
    hovering multirotor's camera does. IPPE works from the homography's local
    Jacobian; a few Levenberg-Marquardt steps on all the points take a tenth
    of a pixel off, which on a small pad is a few percent of range. With the
    pad's other marks found (``polish``), the pose then takes a few steps on all
    the pad's edges with the camera model, whose 6 unknowns noise moves less
    than the homography's 8; kept when it finds at least as many of the edges.
    Returns the fit and the share of the whole pad's edges found where the pose
    puts them.
    """
    pts_m = reference.pose_points_m
    px = apply_h(H, pts_m)
    obj = np.column_stack([pts_m, np.zeros(len(pts_m))])
    best = None
    for rvec0, tvec0 in ippe_candidates(pts_m, px, cam):
        rvec, tvec = cv2.solvePnPRefineLM(obj, px, cam.K, cam.dist, rvec0.copy(), tvec0.copy())
        err = project(pts_m, rvec, tvec, cam) - px
        rms = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
        cand = (rms, tilt_deg(rvec), EdgeFit(rvec, tvec, rms, len(pts_m), 0))
        if best is None or _better(cand, best):
            best = cand
    if best is None:
        return None
    fit = best[2]
    img = smooth.astype(np.float32)
    support = edge_support(img, reference.edge_model, cam, fit.rvec, fit.tvec)
    if polish:
        refined = fit_edges(img, reference.edge_model, cam, fit.rvec, fit.tvec, search_px=1.5)
        if refined is not None:
            better = edge_support(img, reference.edge_model, cam, refined.rvec, refined.tvec)
            if better >= support:  # a drift along a flat valley finds fewer edges
                fit, support = refined, better
    return fit, support


def _better(a, b) -> bool:
    """(rms, tilt, fit) a before b: the better fit, or on a tie (both within a
    tenth of a pixel, or within AMBIGUOUS_FIT of each other) the smaller tilt."""
    if max(a[0], b[0]) < 0.1 or min(a[0], b[0]) > AMBIGUOUS_FIT * max(a[0], b[0]):
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
