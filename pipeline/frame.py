"""process_frame: from one camera frame to the H, its invariants and the pose.

Where the pipeline looks: when the caller hands in the last result (``prior``),
first the H's sides where the pad's motion between the last two frames takes
them, then where they were (followed: fitted to the edges nearby, which is all a
pad moved by a few pixels needs); then a window around where the pad was, at a
resolution where the H spans about ``TRACK_SPAN_PX``; when that finds
nothing, the whole frame at ``COARSE_WIDTH_PX`` (a near pad's H, large enough
there, its sides then fitted again at the frame's own resolution; not for an H it
takes only from nearer than ``FIRST_LOOK_REACH_M``), then at a
working width of ``SEARCH_WIDTH_PX`` (with two more thresholds), then a wider
frame at its own resolution, and last enlarged toward ``FAR_SEARCH_WIDTH_PX`` (a
far pad is too small at the working width, and its H's legs of 2 px lose their
shape at the frame's own resolution: a 640 or a 1280 px frame doubled, 1920 px by
a third). An H located on a view but too small there to be judged is looked at
closer at once: a window around it, doubled, then the enlarged whole frame, before
the working view's other thresholds. Whatever finds the H (``pipeline.find``), the
pad is then measured at the frame's own resolution around it (a small pad's
enlarged), or on the enlarged view that found it (``pipeline.measure``). When no H
is found, a pad whose H is too far to be placed, or spoilt, is looked for by its
board (``pipeline.board_search``) on the finest view. The result says which way
found it (``found_by``: "follow", "track", "search" or "board").
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Iterator
from typing import NamedTuple

import cv2
import numpy as np

from pipeline.board_search import (
    CHROMA_PLACED,
    MIN_BOARD_PX,
    MIN_BOARD_SUPPORT,
    chroma_outline_found,
    find_boards,
)
from pipeline.camera import Camera
from pipeline.candidates import MIN_EVIDENCE, fit_h_sides
from pipeline.find import (
    FIRST_LOOK_MIN_SPAN_PX,
    CandidateVerifier,
    Stages,
    Tally,
    paint_verdict,
    search,
)
from pipeline.homography_fit import apply_h, span_of
from pipeline.jit import compiled_ieee, plain
from pipeline.measure import MEASURE_SPAN_PX, Measured, measure, pad_box_m
from pipeline.moments import shape_moments
from pipeline.pose import pick_by_yaw, to_pose
from pipeline.preprocess import (
    DEFAULT_METHOD,
    METHODS,
    Binarized,
    Halvings,
    check_image,
    chroma_levels,
    has_colour,
    smooth,
    smooth_channel,
    to_channel,
)
from pipeline.reference import SEARCH_WIDTH_PX, Reference
from pipeline.result import FrameResult
from pipeline.shapes import Region
from pipeline.view import MAX_ENLARGEMENT, View, enlargement

# Tried in turn when the default threshold finds nothing: thresholds that hold across
# shadows (see `pipeline.preprocess`).
FALLBACK_METHODS = ("shadow", "tophat")
COARSE_WIDTH_PX = 320  # a first look at the whole frame, this wide (a near pad's H is large)
# ... for a pad whose H it takes (`pipeline.find.FIRST_LOOK_MIN_SPAN_PX`) from this far at
# least: a small H is seen there only from nearer, where a pad is followed, not searched
# for. On the design bench, the paper sheet's H of 7 cm (2 m on 640 x 480 frames) was seen
# 0.7 ms a frame faster without it (6.1-6.6 against 5.5-5.9 ms, medians), the default
# pad's of 28 cm (7.6 m) 0.7 ms slower; the next smallest bench H reaches 7 m.
FIRST_LOOK_REACH_M = 3.0
TRACK_SPAN_PX = 100.0  # a tracked H is looked for at a scale where it spans about this
FAR_SEARCH_WIDTH_PX = 2560  # the last search: narrower frames enlarged toward it (view.py)
TRACK_REACH = 0.5  # the tracking window: the pad's last box grown by this much of its size
FOLLOW_REACH_PX = 6.0  # a followed H's sides are looked for this far from where they were
FOLLOW_COARSE_SPAN_PX = 120.0  # a larger pad is first followed on a view where it spans this
FOLLOW_SUPPORT = 0.9  # the share of the H's sides found again for a followed H to count
MAX_FOLLOW_GROWTH = 1.25  # and its size may change by this factor between two frames
MAX_CLOSER_LOOKS = 3  # small marks refused on a wide frame, looked at again enlarged

MaskSource = Callable[[], np.ndarray]  # a threshold mask, made when first asked for

__all__ = ["CandidateVerifier", "process_frame"]


def process_frame(
    image_bgr: np.ndarray,
    reference: Reference,
    camera: Camera,
    *,
    yaw_hint: float | None = None,
    gravity_hint: np.ndarray | None = None,
    method: str = DEFAULT_METHOD,
    verifier: CandidateVerifier | None = None,
    prior: FrameResult | None = None,
) -> FrameResult:
    """Find the reference's H in a frame and estimate the camera's pose over the pad.

    Parameters
    ----------
    image_bgr : H x W x 3 uint8 frame (or H x W gray), any size; ``camera`` may
        describe the frame at any resolution of the same aspect ratio.
    reference : the pad, from :meth:`Reference.from_image`.
    camera : the camera's intrinsics.
    yaw_hint : the camera's yaw in the pad frame (degrees, see
        ``pipeline.result.yaw_of``), e.g. from the vehicle's heading: picks
        which of the two poses of a 180-degree-symmetric pad to report.
    gravity_hint : the direction of gravity (down) in the camera frame (3
        numbers, any length), from the vehicle's roll and pitch and the
        camera's mount: the pad lies level, so it tells which of a planar
        pose's two solutions is right. Without it a pose that could be either
        is reported with ``pose.ambiguous``.
    method : thresholding of the reference's channel, one of
        ``pipeline.preprocess.METHODS`` ("seed" is the dissertation's chain).
    verifier : an optional check of each H-shaped candidate's corner pattern
        (the RBM/DBN of ``pipeline.learn``, trained for this reference),
        consulted before the pose.
    prior : the last result of this camera (a detection of a moment ago): the
        pad is first looked for where it was. ``found_by`` says which way found it.

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
    >>> res.detected, np.round(res.pose.position_m, 1).tolist(), res.found_by
    (True, [0.1, -0.2, 3.0], 'search')
    >>> process_frame(frame, ref, cam, yaw_hint=30.0, prior=res).found_by
    'follow'
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
    if prior is not None and not isinstance(prior, FrameResult):
        raise ValueError(f"prior must be a FrameResult or None, got {type(prior).__name__}")
    gravity = _check_gravity(gravity_hint)
    cam = _camera_for(camera, image.shape[1], image.shape[0])
    stages = Stages()
    tally = Tally()
    search_view = View.whole(image.shape, SEARCH_WIDTH_PX)
    mask: MaskSource | None = None
    # First the H where it was a moment ago, followed.
    followed = _follow(prior, image, reference, method)
    if followed is not None:
        view, levels, threshold, H = followed
        mask = functools.partial(_threshold_for, threshold, view, search_view)
        stages.lap("follow")
        measured = measure(image, reference, cam, H, gravity=gravity, found=(view, levels))
        stages.lap("pose")
        if measured is not None:
            outline = apply_h(measured.H, reference.corners_m)
            return _detected(
                measured, reference, outline, yaw_hint, "follow", mask, stages, t_start, prior
            )
    # Then searched for: around the last detection, then the whole frame (coarsely
    # first), then the whole frame again with the thresholds that hold across shadows.
    tries = [("track", _tracking_view(prior, reference, image.shape), method)]
    # A near pad is found on a quarter of the working view's pixels as well, and
    # measured at the frame's own resolution all the same; what that first look
    # misses or turns down is looked at again on the working view.
    coarse = View.whole(image.shape, COARSE_WIDTH_PX)
    if coarse.scale < search_view.scale and _first_look_reaches(reference, coarse.camera(cam)):
        tries.append(("search", coarse, method))
    tries.append(("search", search_view, method))
    if method == DEFAULT_METHOD:
        tries += [("search", search_view, fallback) for fallback in FALLBACK_METHODS]
    # A far pad: too small at the search's width, searched at the camera's own
    # resolution before giving up (native frames buy range), enlarged: a leg of
    # 2-3 px keeps its shape and corners only interpolated (on 1280 x 720 frames,
    # the bench's sweep found 0.675 of the pads 32 m away at the frame's own
    # resolution, 0.90 doubled, at about twice the time on a frame without the pad).
    far = View.enlarged(image.shape, FAR_SEARCH_WIDTH_PX)
    # A frame wider than the working width is searched at its own resolution first:
    # most far pads are found there, or by a closer look at a small mark it locates,
    # at a fraction of the enlarged frame's cost (on the altitude sweep's 1280 x 720
    # frames at 18-28 m, 16-23 ms a frame against 27-44 with the doubled frame alone).
    native = View.whole(image.shape, image.shape[1])
    if search_view.scale < native.scale < far.scale:
        tries.append(("search", native, method))
    tries.append(("search", far, method))
    far_found: tuple[Binarized, list[Region]] | None = None
    # (the holes of its mask, and of the working view's with the frame's own threshold: a
    # board the threshold left whole; a few a frame, kept as the contours are traced)
    far_holes: list[Region] = []
    working_holes: list[Region] = []
    # (the whole frame is searched three ways: its picture and channel made once)
    pictures: dict[View, tuple[np.ndarray, np.ndarray]] = {}
    halvings: Halvings = []  # (the frame's, shared by its coarser views)
    for way, view, how in _in_turn(tries, tally, image.shape, reference, method):
        if view is None:
            continue
        to_frame = view.to_frame
        if view not in pictures:
            picture = view.image(image, halvings)
            pictures[view] = (picture, to_channel(picture, reference.projection))
        working = view is search_view and how == method
        view_holes = far_holes if view is far else (working_holes if working else None)
        binary, shapes, hits = search(
            *pictures[view],
            reference,
            view.camera(cam),
            method=how,
            verifier=verifier,
            tally=tally,
            stages=stages,
            to_frame=to_frame,
            tracking=way == "track",
            enlarged=max(1.0, view.scale),
            first_look=view is coarse,
            holes=view_holes,
        )
        if view is coarse:  # (shown: the working view's threshold, made when asked for)
            mask = functools.partial(_working_mask, image, search_view, reference, how)
        else:
            mask = functools.partial(_mask_for, binary.mask, view, search_view)
        if view is far:
            far_found = (binary, shapes)
        for hit in hits:
            H_found, found = to_frame @ hit.fit.H, (view, binary.smooth)
            if view is coarse:
                fine = _fitted_finely(image, reference, H_found, coarse.scale)
                if fine is None:
                    continue
                H_found, found = fine
            measured = measure(image, reference, cam, H_found, gravity=gravity, found=found)
            stages.lap("pose")
            if measured is None:  # no pose of the pad lying level fits it (from this start)
                continue
            # An H too faint to count alone counted by the rest of its pad: its pose must
            # find the pad's edges, as a pad found by its board must (on the photos
            # bench's degraded negatives, faint H's in carpet noise and a printed
            # marker's squares posed on 0-17 % of them; the bench's faint H's posed
            # within 7 % of the altitude, on 30 % and more).
            # So must an H found on the coarse view: there its strokes' defects (a
            # look-alike's broken leg) may have merged away (on the design bench,
            # serif_octagon's look-alikes of 35-40 px, turned down on the working
            # view, posed on 5-7 % of the pad's edges, in 2 of 100 empty frames; its
            # pads on 35 % and more).
            faint = hit.evidence < MIN_EVIDENCE or view is coarse
            if faint and measured.support < MIN_BOARD_SUPPORT:
                continue
            contour = apply_h(to_frame, hit.candidate.region.contour.astype(np.float64))
            return _detected(
                measured, reference, contour, yaw_hint, way, mask, stages, t_start, prior
            )
    # Last, a pad whose H could not be placed (too far, or spoilt), by its board on the
    # finest view.
    if far_found is not None:
        far_binary, shapes = far_found
        to_frame = far.to_frame
        holes = far_holes + _holes_in(far, search_view, working_holes)
        chroma = None  # (a grey frame shows none)
        picture = pictures[far][0]
        if reference.board_chroma is not None and picture.ndim == 3 and has_colour(picture):
            chroma = functools.partial(_chroma_of, picture, reference.board_chroma)
        boards = find_boards(
            far_binary.smooth, shapes, reference, max(1.0, far.scale), holes, chroma,
            far_binary.mask,
        )  # fmt: skip
        for H in boards:
            if verifier is not None:
                # The verifier judges the H the board puts where it is, as any H.
                h_px = apply_h(H, reference.corners_m)
                if not verifier.accepts(h_px, h_px, far.camera(cam)):
                    tally.rejected += 1
                    continue
            # A board placed by its outline on its chroma (`board_search.CHROMA_PLACED`)
            # is judged there: its H's channel may show none of the pad's edges.
            placed = chroma_outline_found(chroma, reference, H) >= CHROMA_PLACED
            measured = measure(
                image, reference, cam, to_frame @ H, gravity=gravity,
                found=(far, far_binary.smooth), placed=placed,
            )  # fmt: skip
            stages.lap("board")
            if measured is None:
                continue
            if measured.support >= MIN_BOARD_SUPPORT or (
                placed
                and chroma_outline_found(chroma, reference, far.matrix @ measured.H)
                >= CHROMA_PLACED
            ):
                outline = apply_h(measured.H, reference.corners_m)
                return _detected(
                    measured, reference, outline, yaw_hint, "board", mask, stages, t_start, prior
                )
        stages.lap("board")
    return _nothing(stages.timings, t_start, tally.reason(reference.polarity), mask)


def _chroma_of(
    picture: np.ndarray, weights: np.ndarray, box: tuple[int, int, int, int]
) -> np.ndarray:
    """The box (x0, y0, x1, y1) of a view's picture read on a board's chroma."""
    x0, y0, x1, y1 = box
    return chroma_levels(picture[y0:y1, x0:x1], weights)


def _holes_in(far: View, view: View, holes: list[Region]) -> list[Region]:
    """The holes of ``view``'s mask wide enough for a board (`MIN_BOARD_PX`), in the
    pixels of ``far``: the working view's threshold leaves whole some boards that the
    enlarged view's noise breaks into, and the reverse (2 more of paper_ring's sheets
    in 100 far views, 7.6-8.8 m away at 640 x 480)."""
    if view == far:
        return []
    M = far.matrix @ view.to_frame
    scale = float(M[0, 0])
    least = MIN_BOARD_PX * max(1.0, far.scale) / scale
    out = []
    for h in holes:
        if max(h.box[2], h.box[3]) >= least:
            pts = np.rint(apply_h(M, h.contour.astype(np.float64))).astype(np.int32)
            out.append(Region(pts, h.area * scale**2))
    return out


def _first_look_reaches(reference: Reference, camera: Camera) -> bool:
    """Whether a first look through ``camera`` (the coarse view's) takes the pad's H
    from ``FIRST_LOOK_REACH_M`` away or farther (seen straight down)."""
    return reference.h_size_m * camera.fx / FIRST_LOOK_MIN_SPAN_PX >= FIRST_LOOK_REACH_M


def _in_turn(
    tries: list[tuple[str, View | None, str]],
    tally: Tally,
    shape: tuple[int, ...],
    reference: Reference,
    method: str,
) -> Iterator[tuple[str, View | None, str]]:
    """The tries in turn, with closer looks: a window enlarged around each of the
    small marks located and refused (``MAX_CLOSER_LOOKS``, the likeliest first),
    thresholded as the enlarged whole frame is (``method``): where that is doubled
    too, it does not judge them again (on the altitude sweep's 640 x 480 frames at
    18 m, windows thresholded as the top-hat view that had refused the H refused it
    again, where the doubled frame's local mean found it).

    When a view of the whole frame at its own resolution or coarser refuses H's too
    small there to be judged, a far pad's H may be among them: the windows around
    them come next, then the finer views of the whole frame, then the working
    view's other thresholds (each of which located and refused a far pad's H again
    before the enlarged view found it). Last, on a frame too wide to be enlarged
    whole to ``MAX_ENLARGEMENT`` (over 1280 px), windows around the small marks the
    other views refused: a far pad's H, a dozen pixels across with legs of 2 px,
    keeps its shape and corners only interpolated, and doubling a whole 1920 x 1080
    frame would cost four times its pixels on every frame without the pad."""
    looked: list[np.ndarray] = []
    pending = list(tries)
    while pending:
        way, view, how = pending.pop(0)
        yield way, view, how
        if way != "search" or view is None or view.scale > 1.0 or not tally.small_refused:
            continue
        yield from _closer_looks(tally, shape, reference, method, looked)
        finer = [t for t in pending if t[1] is not None and t[1].scale > view.scale]
        pending = finer + [t for t in pending if t not in finer]
    if enlargement(shape, FAR_SEARCH_WIDTH_PX) < MAX_ENLARGEMENT:
        yield from _closer_looks(tally, shape, reference, method, looked)


def _closer_looks(
    tally: Tally, shape: tuple[int, ...], reference: Reference, how: str, looked: list[np.ndarray]
) -> Iterator[tuple[str, View | None, str]]:
    """Windows enlarged to ``MAX_ENLARGEMENT`` around the small marks refused so far
    (not those in ``looked``, to which they are added), with room for their pad's
    board: the H's box grown by the pad's size over the H's."""
    for box in tally.closer_looks(MAX_CLOSER_LOOKS, looked):
        size = float(max(box[2] - box[0], box[3] - box[1]))
        grow = 0.5 * reference.pad_over_h * size + 4.0
        view = View.around(box, shape, grow, MAX_ENLARGEMENT, max_scale=MAX_ENLARGEMENT)
        yield "search", view, how


def _detected(
    measured: Measured,
    reference: Reference,
    contour: np.ndarray,
    yaw_hint: float | None,
    way: str,
    mask: MaskSource | None,
    stages: Stages,
    t_start: float,
    prior: FrameResult | None,
) -> FrameResult:
    """The result for a measured pad whose H's outline on the frame is ``contour``
    (and how it moved since ``prior``, when that found it too)."""
    fit = measured.fit
    # A pad whose heading this frame did not tell is reported as a symmetric one's.
    symmetric = reference.symmetric or not measured.heading_told
    found_pose = to_pose(
        fit.rvec, fit.tvec, fit.rms_px, symmetric, measured.ambiguous, measured.lean
    )
    # The twin is the H's: turned about its centre (its corners numbered 6 apart below).
    pose = pick_by_yaw(found_pose, yaw_hint, reference.h_centre_m)
    # The corners as found on the frame (they do not depend on the camera
    # model), numbered for the reported pose: corner i is where reference
    # corner i lies; the twin of a symmetric pad numbers them 6 apart.
    corners = apply_h(measured.H, reference.corners_m)
    if pose is not found_pose:
        corners = np.roll(corners, -6, axis=0)
    mom = shape_moments(contour)
    stages.timings["total"] = (time.perf_counter() - t_start) * 1e3
    return FrameResult(
        detected=True,
        corners_px=corners,
        hu=tuple(float(v) for v in mom.hu),
        orientation_deg=float(mom.orientation_deg),
        eccentricity=float(mom.eccentricity),
        pose=pose,
        timings_ms=stages.timings,
        contour_px=contour,
        score=measured.support,
        found_by=way,
        homography=measured.H,
        mask_source=mask,
        motion=_motion(prior, measured.H),
    )


def _follow(
    prior: FrameResult | None, image: np.ndarray, reference: Reference, method: str
) -> Followed | None:
    """The H followed from the last frame: its sides fitted to the edges near where
    its motion since the frame before takes them, else near where they were, in a
    window at the measurement's scale. A pad moves a few pixels between frames; when
    nearly all of the H's sides are found again (and its size holds), it is the same
    H, and the search's steps are not needed. A large pad, which moves more pixels, is
    followed from where it was on a coarser view first. Returns None when the search
    must take over."""
    if prior is None or not prior.detected or prior.homography is None:
        return None
    H = prior.homography
    span = _pad_span_px(H, reference)
    if not math.isfinite(span) or span < 1.0:
        return None
    # Where the pad would be had it moved on as it did between the last two frames.
    if prior.motion is not None:
        found = _follow_fine(image, reference, method, prior.motion @ H, span)
        if found is not None:
            return found
    if span > 1.5 * FOLLOW_COARSE_SPAN_PX:
        coarse = _window(image, H, reference, FOLLOW_COARSE_SPAN_PX / span)
        if coarse is None:
            return None
        levels = smooth_channel(coarse.image(image), reference.projection)
        H = _fit_near(levels, coarse, reference, H)
        if H is None:
            return None
    return _follow_fine(image, reference, method, H, span)


class Followed(NamedTuple):
    """A followed H: the window it was fitted in, the window's smoothed channel,
    its threshold mask (made when asked for: the fit does not need it) and the H's
    homography (pad metres -> frame pixels)."""

    view: View
    levels: np.ndarray
    threshold: MaskSource
    H: np.ndarray


def _follow_fine(
    image: np.ndarray, reference: Reference, method: str, H: np.ndarray, span: float
) -> Followed | None:
    """The H's sides fitted near where ``H`` puts them, at the measurement's scale."""
    view = _window(image, H, reference, MEASURE_SPAN_PX / span)
    if view is None:
        return None
    projection = reference.projection
    channel = to_channel(view.image(image), projection)
    levels = smooth(channel)
    H = _fit_near(levels, view, reference, H)
    if H is None:
        return None
    threshold = functools.partial(_threshold, reference, channel, method)
    return Followed(view, levels, threshold, H)


def _threshold(reference: Reference, channel: np.ndarray, method: str) -> np.ndarray:
    return reference.binarize(channel, method).mask


def _working_mask(image: np.ndarray, view: View, reference: Reference, method: str) -> np.ndarray:
    """The threshold mask of a view of the frame (the first look's is a quarter as fine)."""
    return _threshold(reference, to_channel(view.image(image), reference.projection), method)


def _motion(prior: FrameResult | None, H: np.ndarray) -> np.ndarray | None:
    """How the pad moved on the frame since ``prior`` found it (frame pixels ->
    frame pixels), or None."""
    if prior is None or not prior.detected or prior.homography is None:
        return None
    motion = _over(plain(H), plain(prior.homography))
    return motion if np.isfinite(motion).all() else None


@compiled_ieee
def _over(H, G):
    """``H @ inv(G)``, scaled to 1 at [2, 2] (inf or nan where that is 0): G's inverse up to
    its scale is its adjugate (LAPACK's general inverse, called cold, cost a tracked
    frame 0.1 ms)."""
    adj = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            r1, r2 = (c + 1) % 3, (c + 2) % 3
            c1, c2 = (r + 1) % 3, (r + 2) % 3
            adj[r, c] = G[r1, c1] * G[r2, c2] - G[r1, c2] * G[r2, c1]
    out = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            out[r, c] = H[r, 0] * adj[0, c] + H[r, 1] * adj[1, c] + H[r, 2] * adj[2, c]
    return out / out[2, 2]


def _window(image: np.ndarray, H: np.ndarray, reference: Reference, scale: float) -> View | None:
    """The view (at ``scale``, at most 1) of the pad ``H`` puts in the frame, with room
    for its sides to be found ``FOLLOW_REACH_PX`` away."""
    was = apply_h(H, pad_box_m(reference))
    span = span_of(was)
    box = np.concatenate([was.min(axis=0), was.max(axis=0)])
    return View.around(box, image.shape, 0.1 * span + FOLLOW_REACH_PX / min(scale, 1.0), scale)


def _fitted_finely(
    image: np.ndarray, reference: Reference, H: np.ndarray, found_scale: float
) -> tuple[np.ndarray, tuple[View, np.ndarray]] | None:
    """An H found on a coarse view (``found_scale``), its sides fitted again at the
    measurement's scale, as the working view's H's are found: its homography (frame
    pixels) and the window with its smoothed channel, or None when they are not found
    there, or not painted as an H there (`pipeline.find.paint_verdict`). (Measured
    from the coarse corners, which are a frame pixel or two off, the real-world mix's
    poses came up to a tenth worse; a look-alike's gap of a frame pixel or two, merged
    away on the coarse view, shows here: a broken H on the design bench's floor.)"""
    span = _pad_span_px(H, reference)
    view = _window(image, H, reference, MEASURE_SPAN_PX / span) if span >= 1.0 else None
    if view is None:
        return None
    picture = view.image(image)
    levels = smooth_channel(picture, reference.projection)
    # (a coarse pixel's error, in the window's pixels)
    reach = max(2.5, 1.5 * view.scale / found_scale)
    fitted = fit_h_sides(levels, reference, view.matrix @ H, search_px=reach)
    if fitted is None:
        return None
    if paint_verdict(picture, reference, fitted[0].H):
        return None
    return view.to_frame @ fitted[0].H, (view, levels)


def _fit_near(
    levels: np.ndarray, view: View, reference: Reference, H: np.ndarray
) -> np.ndarray | None:
    """The H's sides fitted on a view's smoothed channel within ``FOLLOW_REACH_PX`` of
    where ``H`` (pad metres -> frame pixels) puts them: the fitted homography (frame
    pixels), or None when they are not found again at the size they had."""
    start = view.matrix @ H
    fitted = fit_h_sides(levels, reference, start, search_px=FOLLOW_REACH_PX)
    if fitted is None or fitted[0].support < FOLLOW_SUPPORT:
        return None
    fit = fitted[0]
    size = span_of(apply_h(fit.H, reference.corners_m))
    size_was = span_of(apply_h(start, reference.corners_m))
    if not 1 / MAX_FOLLOW_GROWTH <= size / max(size_was, 1e-9) <= MAX_FOLLOW_GROWTH:
        return None
    return view.to_frame @ fit.H


def _pad_span_px(H: np.ndarray, reference: Reference) -> float:
    px = apply_h(H, pad_box_m(reference))
    return span_of(px) if np.isfinite(px).all() else math.nan


def _tracking_view(
    prior: FrameResult | None, reference: Reference, shape: tuple[int, ...]
) -> View | None:
    """The window around where the pad was, at a scale where its H spans about
    ``TRACK_SPAN_PX``; None without a prior detection."""
    if prior is None or not prior.detected or prior.homography is None:
        return None
    px = apply_h(prior.homography, pad_box_m(reference))
    if not np.isfinite(px).all():
        return None
    span = span_of(px)
    h_span = span_of(apply_h(prior.homography, reference.corners_m))
    box = np.concatenate([px.min(axis=0), px.max(axis=0)])
    # A far pad is tracked as finely as the far search found it: enlarged.
    return View.around(
        box,
        shape,
        TRACK_REACH * span + 8.0,
        TRACK_SPAN_PX / max(h_span, 1.0),
        max_scale=enlargement(shape, FAR_SEARCH_WIDTH_PX),
    )


def _threshold_for(threshold: MaskSource, view: View, search: View) -> np.ndarray:
    """``_mask_for`` of a mask made when asked for."""
    return _mask_for(threshold(), view, search)


def _mask_for(mask: np.ndarray, view: View, search: View) -> np.ndarray:
    """The threshold mask a view was searched with, in the search view's pixels
    (a tracking window's mask is laid where the window is, the rest blank)."""
    if view == search:
        return mask
    out = np.zeros(search.size[::-1], np.uint8)
    to_search = search.matrix @ view.to_frame
    return cv2.warpAffine(
        mask, to_search[:2], search.size, dst=out, flags=cv2.INTER_NEAREST,
        borderMode=cv2.BORDER_TRANSPARENT,
    )  # fmt: skip


def _check_gravity(gravity_hint) -> np.ndarray | None:
    if gravity_hint is None:
        return None
    try:
        g = np.asarray(gravity_hint, np.float64).reshape(3)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"gravity_hint must be 3 numbers or None, got {gravity_hint!r}") from exc
    norm = math.sqrt(float(g.dot(g)))  # (np.linalg.norm's arithmetic, without its checks)
    if not np.isfinite(g).all() or norm < 1e-9:
        raise ValueError(f"gravity_hint must be a finite, non-zero 3-vector, got {gravity_hint!r}")
    return g / norm


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
    timings: dict[str, float], t_start: float, reason: str, mask: MaskSource | None = None
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
        mask_source=mask,
    )
