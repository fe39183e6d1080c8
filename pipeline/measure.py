"""Measuring the found pad: its homography on the whole pad's edges, its heading, the pose.

The search finds the H at a working resolution; the pad is measured in a
window around it at the frame's own resolution (no finer than
``MEASURE_SPAN_PX`` across the pad: a pixel in a few hundred is all a pose
needs), where its edges are sharpest; a small pad's window enlarged.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.edgefit import RESOLVED_PX, EdgeFit, edge_support, fit_edges, sides_told_apart
from pipeline.homography_fit import (
    MIN_CLEARANCE_PX,
    MIN_SIDE_PX,
    HomographyFit,
    affine_part,
    apply_h,
    apply_point,
    fit_homography,
    seen_from_above,
    span_of,
)
from pipeline.homography_fit import support as edge_share
from pipeline.jit import compiled, plain
from pipeline.planar_projection import reprojection_rms
from pipeline.pose import (
    camera_height_m,
    half_turn,
    ippe_candidates,
    lean_rotation,
    refine_with_gravity,
    rotation_angle_deg,
    tilt_deg,
    tilt_from_level_deg,
)
from pipeline.preprocess import smooth_channel
from pipeline.reference import Reference
from pipeline.view import MAX_ENLARGEMENT, View

MEASURE_SPAN_PX = 320.0  # the pad is measured at most this many pixels across
# A pad narrower than this (frame pixels) is measured on a window interpolated up to
# MAX_ENLARGEMENT: at the frame's own resolution its H's blurred sides are a pixel or
# two apart (on the altitude sweep with the attitude, 640 x 480 pads of 30-34 px came
# 1.6 % of the altitude off against 1.2-1.3 % enlarged, 1280 x 720 pads of 17 px 2.16 %
# against 1.95 %). Not larger ones: the design bench's paper pad (51-305 px, its H a
# quarter of it) came 3.1 % off at p95 enlarged where its H was under 24 px, 1.8 % not.
ENLARGED_BELOW_PX = 48.0
MAX_TILT_OFF_DEG = 3.0  # a refined pose may lean this far from the attitude's level
# With the attitude known, a pad whose pixels insist on leaning further than this from
# level is not the pad lying flat (an H of other proportions seen at a slant, or a wrong
# pose): the hint's error and a sloping pad stay well under it.
MAX_LEAN_DEG = 12.0
LEVELLING_STEPS = 3  # ... the pixels' weight lowered 4-fold at most this many times
# The pad's points, placed by its homography, weighed against the attitude. A tilt
# moves them by about span^2 / fx pixels a radian (its "shown" tilt), while their
# noise and blurred edges' bias stay a few tenths of a pixel whatever the span: each
# point is within POINT_SIGMA_PX where the tilt shows by the SHOWN figure below (in
# px/rad; at 640 px and 60 degrees 4.5 is a pad of 50 px, 18 one of 100 px), and in
# inverse proportion under it. Whether the pad may lie level is judged against the
# noise (NOISE_SHOWN); the pose weighs the bias as well (TILT_SHOWN: far pads' tilts
# went 3-7 degrees off a hint 1 degree right; more weight on the hint than this took
# the 0.55 m pad at 5-6 m over 1 % of the altitude, a 0.7 degree hint's own error).
# Under POLISH_SHOWN the pad's edges, fitted without the attitude, do not move a
# hinted pose.
POINT_SIGMA_PX = 0.3
# ... as this many points at most: one homography places them all. A ring's polygon of
# 200-odd vertices had outweighed the attitude 9-fold against the default pad's 24 (its
# H's and bars' corners): on frames rendered apart from this project (the picture warped
# by OpenCV, supersampled), the attitude exact, ringed pads' poses leaned up to 2.2
# degrees from level, red_on_black's 10 m away 1.9 % of the altitude off (median), not 1.0.
WEIGHED_POINTS = 24
NOISE_SHOWN_PX_PER_RAD, TILT_SHOWN_PX_PER_RAD, POLISH_SHOWN_PX_PER_RAD = 4.5, 18.0, 18.0
AMBIGUOUS_FIT = 0.8  # two poses whose RMS errors are within this ratio are a tie
TOLD_TILT_DEG = 3.0  # without the attitude, a pose not pinned this well is ambiguous
MAX_BENT = 0.01  # of the pad's span: the RMS of a pose that the homography fits
# ... and, the pose held level by the attitude, the RMS past which no pad lying level is
# in view: the bench's poses within 10 % of the altitude (1275, today's views and the
# real-world mix's) fitted within 1.84 %, the altitude sweep's within 3 % (12-50 px
# pads) within 2.26 %; an I-beam painted on grass, taken for grass_paint's H stretched
# 2.5:1, at 5.6 %, and the sweep's far poses 6-10 % off at 3.4-5.4 %.
MAX_LEVEL_BENT = 0.03
# Without the attitude, the RMS past which the homography is no plane's that this camera
# sees: the shared photos' pads, through an assumed lens and the photos bench's
# degradations, fitted within 3 % (252 found at seeds 1-2); an H squashed to a sliver
# on a carpet's noise (neg_111, seed 9, closer look), at 18 %.
MAX_UNPOSED = 0.1
# The farthest from the pad's normal a camera over it sees the pad from: the tilt sweep's
# views at 45 degrees come to 74, the real photos' poses (as they are and seen 3 more
# ways, seeds 1-3) to 60; an H squashed to a sliver in carpet noise (neg_111, seed 7,
# view 2) was posed 86 degrees off it, the camera 0.6 m up and 9 m aside.
MAX_VIEW_DEG = 80.0
WIDE_SEARCH_PX = 6.0  # how far the whole pad's edges are first looked for
# Without the attitude, a pose the pad's edges read otherwise, tilted this much apart, is
# ambiguous (`_read_otherwise`); fitted again from the marks' way round, so far and often.
OTHERWISE_DEG = 1.5
AGAIN_SEARCH_PX, AGAIN_STEPS = 1.5, 2
SELF_SUFFICIENT_PX = 100.0  # an H this large pins the pose by itself
MIN_MARKS_FOUND = 0.5  # of the marks' resolvable sides, for the whole pad to count
# Fewer sides seen than this: their share is weighed by their lengths (a closer look's
# window held one side of a sheet's outline along a straight edge, a third of its 95 px
# found, and a triangle's side of 6 px in carpet noise, 80 %: "half the marks" around a
# speck of 6 px in a negative; a far rim's two sides too wide to merge, 96 % found).
MIN_MARK_SIDES_SEEN = 3
# A mark's stroke this thin (its two sides this many px apart) may be one blurred line
# in a frame: the whole pad is fitted again without such strokes when too few of its
# marks are found with them (a printed ring of 1.4 px left 60 % of the marks unfound,
# and the pose to the H alone).
BLURRED_STROKE_PX = 2.0
AFFINE_GAIN = 0.25  # more of the marks found from the H's affine part, for it to be kept
MARK_SIDE_PX = 4.0  # a mark's straight side shorter than this (a star's point) is not told
# The whole pad's fit may move the H's corners this far (or 3 % of its span): an H of
# 15 px fitted alone is off by up to a pixel and a half (its strokes are 2 px wide).
MOVED_PX = 1.5
AFFINE_MIN_SUPPORT = 0.2  # of the pad's edges, for a pose from the H's affine part
# A pose under which neither the pad's edges nor its H's own are found is not this pad's:
# an H of other strokes, located with its strokes free, posed as the reference's H finds
# none of its sides (on the real-world mix's grass, 0-2 %). The bench's right poses found
# 9 % of the pad's edges at least, the real photos' (their references drawn, not cut
# from them) 1 %, and then 16 % of their H's.
MIN_EDGES_FOUND = 0.05
ALONG_GRID_DEG = 3.0  # the H's sides this near the pixel grid: see `_unlocked`
# ... and the most the centroid may move the H's corners: the lock's (0.39 px on each
# of a corner's two sides) and a little noise. On the yaw sweep's square views it moved
# them 0.34-0.62 px; on a far orange_ring in the real-world mix (H 23 px), 0.81, and
# put the pad 6.0 % of its height off, not 2.1.
MAX_UNLOCK_PX = 0.75
# Of the heading marks' edges (`_heading`): one half turn must find this many more. On the
# altitude sweep's and both mixes' views of serif_octagon and paper_ring (809 poses),
# neither 0.05 nor this told a wrong turn; this told 94-100 % as many.
HEADING_MARGIN = 0.1


@dataclass(frozen=True, eq=False)
class Measured:
    """``H``: pad metres -> frame pixels; ``fit``: the pose (OpenCV pad -> camera);
    ``support``: the share of the whole pad's edges (those the frame tells apart) found
    where the pose puts them; ``ambiguous``: another pose fits as well (see `_fit_pose`);
    ``heading_told``: the pad's marks told its heading (see `_heading`);
    ``lean``: with the attitude, how the pixels alone lean the pad from its level
    (`pipeline.pose.lean_rotation`, see `_fit_pose`)."""

    H: np.ndarray
    fit: EdgeFit
    support: float
    ambiguous: bool
    heading_told: bool = False
    lean: np.ndarray | None = None


def measure(
    frame: np.ndarray,
    reference: Reference,
    camera: Camera,
    H: np.ndarray,
    *,
    gravity: np.ndarray | None,
    found: tuple[View, np.ndarray] | None = None,
    placed: bool = False,
) -> Measured | None:
    """Measure the pad located by ``H`` (pad metres -> pixels of ``frame``, whose
    camera is ``camera``). ``found``: the view the H was found in and its smoothed
    channel, used again when it is already as fine as a measurement needs.
    ``placed``: ``H`` placed by the pad's edges on another picture than the channel
    (a coloured board's outline on its chroma), the caller to judge the pose there:
    the channel need not show the pad's edges (``MIN_EDGES_FOUND``)."""
    if not seen_from_above(H, reference.corners_m):
        return None  # (a fit folded or mirrored: no pad lying level looks so)
    outline = pad_box_m(reference)
    px = apply_h(H, outline)
    span = span_of(px)
    box = np.concatenate([px.min(axis=0), px.max(axis=0)])
    most = MAX_ENLARGEMENT if span < ENLARGED_BELOW_PX else 1.0
    view = View.around(
        box, frame.shape, max(4.0, 0.1 * span), MEASURE_SPAN_PX / max(span, 1.0), max_scale=most
    )
    if view is None:
        return None
    if found is not None and _covers(found[0], view):
        view, levels = found
        Hv = view.matrix @ H
    else:
        levels = smooth_channel(view.image(frame), reference.projection)
        Hv = view.matrix @ H
        refit = fit_homography(levels, reference.h_edges, Hv, search_px=2.5)
        if refit is not None:
            Hv = refit.H
    cam = view.camera(camera)
    # With the attitude known, a hemmed rim's size is left free (`Reference.hemmed_rims`):
    # on the bench's hemmed pad at 2-12 m, the hem's edge made the pad 0.3-0.6 % too
    # large, the altitude as short. (Without it, a far pad's tilt rests on the rim's size
    # against the H's: there, so freed, poses flagged ambiguous came 3-8 % off, not 1 %.)
    whole = whole_pad(Hv, reference, levels, free_rims=gravity is not None)
    # With the pad's other marks found, or a lens whose distortion the
    # homography cannot follow, the pose is refined on the edges.
    marks_found = whole is not Hv
    starts: list[tuple[np.ndarray, bool, float | None]] = [(whole, marks_found, None)]
    if gravity is not None:
        # A small H's perspective is mostly its noise: JPEG blocks or a motion smear
        # along its sides put the pad 30-50 degrees off level. When no pose fits, the
        # attitude is left to tell the tilt, from the homography's affine part; the
        # pose must then find the pad's edges (an H of other strokes painted on the
        # floor leans as far, and is no pad).
        affine = affine_part(Hv, reference.h_centre_m)
        starts.append((affine, False, AFFINE_MIN_SUPPORT))
    for start, with_marks, min_support in starts:
        Hs, told = _heading(start, reference, levels)
        # A pad square to the pixel grid is posed off the parabola's lock, and from the
        # locked homography only where that pose is refused: one pose, as at any other
        # yaw (posing both and keeping the locked one's verdict had cost every frame of a
        # landing facing the pad 0.4-0.5 ms, for the same detections on six designs'
        # bench and square views).
        tries = [(Hs, False)]
        if min_support is None and _along_grid(Hs, reference):
            unlocked = _unlocked(reference, levels, start, Hs, with_marks, gravity, view)
            if unlocked is not None:
                tries.insert(0, (unlocked, True))
        for H_try, centroid in tries:
            fitted = _pose_of(reference, levels, cam, H_try, with_marks, gravity, view, centroid)
            if fitted is None or (min_support is not None and fitted[1] < min_support):
                continue
            fit, support, ambiguous, lean = fitted
            if camera_height_m(fit.rvec, fit.tvec) <= 0.0:
                continue  # (edges taken astray can fit a camera under the ground)
            unfound = not placed and support < MIN_EDGES_FOUND
            if unfound and (
                edge_support(levels, reference.h_edges, cam, fit.rvec, fit.tvec) < MIN_EDGES_FOUND
            ):
                continue
            if gravity is None and with_marks and not ambiguous:
                ambiguous = _read_otherwise(reference, levels, cam, Hv, start, Hs, fit, view)
            # The pose counts by the edges a frame this fine tells apart:
            # serif_octagon's double rim (four octagons 5-8 mm apart, under a pixel
            # apart from 3-5 m on at 640 x 480) was counted unfound, and poses of its
            # sheet 15 m away, 2-8 % off, found 0.17-0.20 of the pad's edges, 0.29-0.32
            # of those told apart. (The fits above weigh a polish by all the edges: by
            # those told apart, the design bench's views without the attitude came
            # further off, serif_octagon's p95 2.08 -> 2.90 %.)
            told_apart = support
            if not sides_told_apart(reference.edge_model, cam, fit.rvec, fit.tvec):
                told_apart = edge_support(
                    levels, reference.edge_model, cam, fit.rvec, fit.tvec, resolved_px=RESOLVED_PX
                )
            return Measured(view.to_frame @ H_try, fit, told_apart, ambiguous, told, lean)
    return None


def _read_otherwise(
    reference: Reference,
    levels: np.ndarray,
    cam: Camera,
    Hv: np.ndarray,
    start: np.ndarray,
    Hs: np.ndarray,
    fit: EdgeFit,
    view: View,
) -> bool:
    """Whether the pad's edges, fitted another way, tilt a pose without the attitude
    over ``OTHERWISE_DEG`` from ``fit`` (posed from ``Hs``: the whole pad fitted from
    the H's homography ``Hv`` as ``start``, then turned as its marks tell): without the
    strokes so thin that a blur may make one line of them, and, where the marks turned
    the pad about, fitted again from their way round.

    A blurred line's flanks lie further out than its sides, and a stroke that thin is
    fitted only where its sides come a pixel apart (on one side of it, or one part);
    fitted the wrong way round, a heading mark's sides find what lies where it is not.
    On frames rendered apart from this project at 20 dB, a paper sheet's printed ring
    of about a pixel and its triangle so pulled the sheet's corners 1-1.9 px off, and 4
    of 150 poses without the attitude came 3.2-6 degrees off, their tilt thought pinned
    to 0.7 degrees; fitted the other ways, 0.3-1.8. Neither way is better everywhere
    (on the bench's own frames, fitted without the thin strokes, serif_octagon's and
    paper_ring's unflagged poses came up to 2.5-2.9 degrees off, not 1.2-1.4): where
    the two part, the pixels do not tell the tilt."""
    others = []
    if _thin_strokes(Hv, reference):
        thin = _fit_whole_pad(levels, reference, Hv, BLURRED_STROKE_PX, False)
        span = span_of(apply_h(Hv, reference.corners_m))
        if (
            thin is not None
            and _marks_found(thin, reference) >= MIN_MARKS_FOUND
            and _in_place(thin.H, Hv, reference, span)
        ):
            others.append(_heading(thin.H, reference, levels)[0])
    if Hs is not start:
        again = fit_homography(
            levels,
            reference.edge_model,
            Hs,
            iterations=AGAIN_STEPS,
            search_px=AGAIN_SEARCH_PX,
            sides_alike=False,
        )
        if again is not None:
            others.append(again.H)
    for H in others:
        other = _pose_of(reference, levels, cam, H, True, None, view)
        if other is not None and _angle_deg(other[0].rvec, fit.rvec) > OTHERWISE_DEG:
            return True
    return False


def _along_grid(H: np.ndarray, reference: Reference) -> bool:
    """Whether ``H`` puts the H's sides along the pixel rows and columns (their
    median within ``ALONG_GRID_DEG``), where the edge locator's parabola locks."""
    model = reference.h_edges
    return bool(_off_grid_deg(plain(H), model.a_m, model.b_m) < ALONG_GRID_DEG)


@compiled
def _off_grid_deg(H, a_m, b_m):
    """The median over the sides ``H`` puts in the image of their angle to the nearest
    pixel row or column, degrees (asked of every pose's start: compiled)."""
    off = np.empty(a_m.shape[0])
    for j in range(a_m.shape[0]):
        ax, ay = apply_point(H, a_m[j, 0], a_m[j, 1])
        bx, by = apply_point(H, b_m[j, 0], b_m[j, 1])
        deg = math.atan2(by - ay, bx - ax) * (180.0 / math.pi) % 90.0
        off[j] = min(deg, 90.0 - deg)
    return np.median(off)


def _unlocked(
    reference: Reference,
    levels: np.ndarray,
    start: np.ndarray,
    Hs: np.ndarray,
    with_marks: bool,
    gravity: np.ndarray | None,
    view: View,
) -> np.ndarray | None:
    """The homography ``Hs`` of a pad whose sides lie along the pixel grid, refitted
    from ``start`` with the edges at their drops' centroid (`edge_kernels.edge_offsets`;
    hovering with the camera square to the pad, the parabola's lock put the pad 0.92 %
    of its height off (median) against 0.28-0.56 % at other yaws); None when the
    refit moves the H's corners further than the lock accounts for."""
    model = reference.edge_model if with_marks else reference.h_edges
    free_rims = with_marks and gravity is not None
    refit = fit_homography(
        levels,
        model,
        start,
        iterations=1,
        search_px=1.5,
        sides_alike=not with_marks,
        deform=reference.hemmed_rims if free_rims else None,
        centroid=True,
    )
    if refit is None:
        return None
    # (`_heading` returns its start itself, or it turned half about the H's centre)
    turned = refit.H if Hs is start else refit.H @ half_turn(reference.h_centre_m)
    moved = apply_h(turned, reference.corners_m) - apply_h(Hs, reference.corners_m)
    if np.hypot(moved[:, 0], moved[:, 1]).max() > MAX_UNLOCK_PX * max(view.scale, 1.0):
        return None
    return turned


def _pose_of(
    reference: Reference,
    levels: np.ndarray,
    cam: Camera,
    H: np.ndarray,
    with_marks: bool,
    gravity: np.ndarray | None,
    view: View,
    centroid: bool = False,
) -> tuple[EdgeFit, float, bool, np.ndarray | None] | None:
    """`_fit_pose` on the points ``H`` places in ``view``: the marks' only where the
    marks were found (placed by the H's homography alone they add no evidence, only a
    count that outweighs the attitude), then polished on the pad's edges where they
    were, or where the lens's distortion is more than a homography follows."""
    return _fit_pose(
        reference,
        levels,
        cam,
        H,
        reference.pose_points_m if with_marks else reference.corners_m,
        polish=with_marks or cam.has_distortion,
        gravity=gravity,
        enlarged=max(view.scale, 1.0),
        centroid=centroid,
    )


def pad_box_m(reference: Reference) -> np.ndarray:
    """The pad's outer corners (4 x 2 metres)."""
    w, h = reference.pad_size_m / 2, reference.pad_height_m / 2
    return np.array([[-w, h], [w, h], [w, -h], [-w, -h]])


def _covers(found: View, need: View) -> bool:
    """Whether the view the H was found in holds the measuring window as finely."""
    inside = (
        found.x0 <= need.x0 and found.y0 <= need.y0 and found.x1 >= need.x1 and found.y1 >= need.y1
    )
    return inside and found.scale >= need.scale - 1e-9


def whole_pad(
    H: np.ndarray,
    reference: Reference,
    levels: np.ndarray,
    *,
    any_size: bool = False,
    free_rims: bool = False,
) -> np.ndarray:
    """The homography refitted on the edges of the whole pad, when they are found.

    The H alone pins the plane's tilt poorly: its corners, a few tens of pixels
    apart, leave a degree of tilt to a tenth of a pixel. The pad's other marks
    (a ring, a rim, bars) lie farther out; seen from the H's homography they may
    be several pixels off, so they are searched for widely first. Kept when
    most of the marks' edges are found and it still puts the H where it was.
    An H over ``SELF_SUFFICIENT_PX`` pins the pose by itself (its marks are then
    looked for only with ``any_size``: to tell whether they are there). Returns
    ``H`` itself (the same object) when the marks were not found or not looked for.
    ``free_rims``: hemmed rims' sizes fitted too (`Reference.hemmed_rims`).
    """
    return pad_marks(H, reference, levels, any_size=any_size, free_rims=free_rims)[0]


def pad_marks(
    H: np.ndarray,
    reference: Reference,
    levels: np.ndarray,
    *,
    any_size: bool = False,
    free_rims: bool = False,
) -> tuple[np.ndarray, float]:
    """`whole_pad`'s homography and the share of the marks' sides found with it (at
    least ``MIN_MARKS_FOUND``; 0 when it is ``H`` itself)."""
    model = reference.marks_model
    span = span_of(apply_h(H, reference.corners_m))
    if model is None or (span > SELF_SUFFICIENT_PX and not any_size):
        return H, 0.0
    fit, found = _marks_fit(levels, reference, H, free_rims)
    if fit is not None and found >= MIN_MARKS_FOUND and _in_place(fit.H, H, reference, span):
        return fit.H, found
    # The perspective of a small H's homography is mostly its noise, which the marks'
    # distance amplifies (a sheet four times its H's size, the H 13-17 px: its corners
    # placed up to 10 px off, beyond where their edges are looked for). From the
    # homography's affine part the marks are looked for again; kept when clearly more
    # of them are found (a blur hides them from both starts alike).
    affine = affine_part(H, reference.h_centre_m)
    fit_a, found_a = _marks_fit(levels, reference, affine, free_rims)
    more = found_a >= max(MIN_MARKS_FOUND, found + AFFINE_GAIN)
    if fit_a is not None and more and _in_place(fit_a.H, H, reference, span):
        return fit_a.H, found_a
    return H, 0.0


def _marks_fit(
    levels: np.ndarray, reference: Reference, start: np.ndarray, free_rims: bool
) -> tuple[HomographyFit | None, float]:
    """The whole pad fitted from ``start`` and the share of its marks found (0 when
    the fit failed); fitted again without the strokes a blur may have merged when
    too few were found with them."""
    fit = _fit_whole_pad(levels, reference, start, MIN_CLEARANCE_PX, free_rims)
    found = 0.0 if fit is None else _marks_found(fit, reference)
    if found < MIN_MARKS_FOUND and _thin_strokes(start, reference):
        thin = _fit_whole_pad(levels, reference, start, BLURRED_STROKE_PX, free_rims)
        if thin is not None:
            fit, found = thin, _marks_found(thin, reference)
    return fit, found


def _in_place(fitted: np.ndarray, H: np.ndarray, reference: Reference, span: float) -> bool:
    """Whether the whole pad's fit still puts the H's corners where ``H`` did."""
    moved = apply_h(fitted, reference.corners_m) - apply_h(H, reference.corners_m)
    return bool(np.max(np.hypot(moved[:, 0], moved[:, 1])) <= max(MOVED_PX, 0.03 * span))


def _fit_whole_pad(
    levels: np.ndarray,
    reference: Reference,
    H: np.ndarray,
    min_clearance_px: float,
    free_rims: bool,
) -> HomographyFit | None:
    return fit_homography(
        levels,
        reference.edge_model,
        H,
        iterations=3,
        search_px=WIDE_SEARCH_PX,
        sides_alike=False,
        deform=reference.hemmed_rims if free_rims else None,
        min_clearance_px=min_clearance_px,
    )


def _thin_strokes(H: np.ndarray, reference: Reference) -> bool:
    """Whether some of the pad's sides lie between ``MIN_CLEARANCE_PX`` and
    ``BLURRED_STROKE_PX`` from a side alongside them, where ``H`` puts them."""
    model = reference.edge_model
    a, b = apply_h(H, model.a_m), apply_h(H, model.b_m)
    scale = np.hypot(*(b - a).T) / np.maximum(np.hypot(*(model.b_m - model.a_m).T), 1e-12)
    clearance = model.clearance_m * scale
    return bool(np.any((clearance >= MIN_CLEARANCE_PX) & (clearance < BLURRED_STROKE_PX)))


def _marks_found(fit: HomographyFit, reference: Reference) -> float:
    """The share of the marks' sides (long enough to tell, ``MARK_SIDE_PX``) that the
    whole-pad fit found, of a few sides their lengths' (``MIN_MARK_SIDES_SEEN``); the
    model lists the H's 12 sides first. A faint rim's sides count only where the other
    marks have too few to tell: from afar its edge is lost, and a pad should not count
    short for it (orange_ring_synth's disc on dark grey, a third of its pad's sides: 99
    of its 160 sweep views at 18-51 m found, against 97 with them counted)."""
    model = reference.edge_model
    ends = apply_h(fit.H, model.ends)
    n = len(model.a_m)
    length = np.hypot(*(ends[n:] - ends[:n]).T)
    use = np.arange(n) >= len(reference.corners_m)
    use &= (length >= MARK_SIDE_PX) | model.curved
    faint = np.isin(model.polygon, [k + 1 for k, m in enumerate(reference.marks) if m.faint])
    if np.count_nonzero(use & ~faint & np.isfinite(fit.side_found)) >= MIN_MARK_SIDES_SEEN:
        use &= ~faint
    found = fit.side_found[use]
    seen = np.isfinite(found)
    count = np.count_nonzero(seen)
    if count >= MIN_MARK_SIDES_SEEN:
        return float(found[seen].sum()) / count
    weight = length[use][seen]
    return float(found[seen] @ weight) / float(weight.sum()) if seen.any() else 0.0


def _heading(H: np.ndarray, reference: Reference, levels: np.ndarray) -> tuple[np.ndarray, bool]:
    """The homography (pad metres -> pixels) for the pad's heading, and whether the
    frame told it.

    The H alone looks the same after a half turn; on a pad whose other marks
    do not (a triangle, stars above the H), the turn under which more of the
    edges of those marks (`Reference.heading_model`) are found is the pad's: the
    marks a half turn maps onto themselves (a ring, an octagon, rims) find theirs
    alike both ways, and their noise told the wrong turn (on the altitude sweep's
    views of serif_octagon, 6 of 243 poses, 8.7-19.6 m away, were turned about,
    told by rims and octagon while the stars went unseen). The sides long enough to
    tell (``MARK_SIDE_PX``) decide first; the shorter ones count too when those look
    the same both ways (a star's points). When both turns find about as few of
    them (``HEADING_MARGIN``: the marks blurred or too small to see), the frame does
    not tell the heading: the pose is then reported as a symmetric pad's, for the
    caller's heading to decide.
    """
    model = reference.heading_model
    if reference.symmetric or model is None:
        return H, False
    # The H is what was located: its twin is a half turn about the H's centre, which
    # lies off the pad's where text or a mark sits beside it.
    turned = H @ half_turn(reference.h_centre_m)
    for shortest in (MARK_SIDE_PX, MIN_SIDE_PX):
        share = edge_share(levels, model, H, shortest)
        turned_share = edge_share(levels, model, turned, shortest)
        if abs(turned_share - share) >= HEADING_MARGIN:
            return (turned if turned_share > share else H), True
    return (turned if turned_share > share else H), False


def _fit_pose(
    reference: Reference,
    levels: np.ndarray,
    cam: Camera,
    H: np.ndarray,
    pts_m: np.ndarray,
    *,
    polish: bool,
    gravity: np.ndarray | None,
    enlarged: float = 1.0,
    centroid: bool = False,
) -> tuple[EdgeFit, float, bool, np.ndarray | None] | None:
    """The camera's pose over the pad from the located homography, or None.

    The homography already holds every edge of the pad that was found; the
    pose is the rigid motion that maps the pad's points ``pts_m`` (the H's
    corners, and the marks' vertices when the marks were found) where it
    does: IPPE's two candidates, each taken a few Levenberg-Marquardt steps on
    all the points (IPPE works from the homography's local Jacobian; the steps
    take a tenth of a pixel off, a few percent of range on a small pad), or
    with the attitude, steps that weigh it too.

    A small pad seen nearly head on fits the two almost equally, tilted
    either way. With the camera's attitude (``gravity``: down in the camera
    frame), the one that lies level wins and is refined with the attitude as
    a prior, leaning no further from level than ``MAX_TILT_OFF_DEG``. Without
    it, the better fit wins, or on a tie the one nearer to looking straight
    down (as a hovering multirotor's camera does), and the pose is reported
    ambiguous when the two differ, or when its points hardly show its tilt.
    With the pad's other marks found (``polish``), the pose then takes a few
    steps on all the pad's edges with the camera model, whose 6 unknowns noise
    moves less than the homography's 8; kept when it finds at least as many of
    the edges (and, with the attitude, on a pad large enough to show its tilt,
    staying level; a hemmed rim then only where its hem is wide: see
    `Reference.polish_model`).
    Returns the fit, the share of the whole pad's edges found where the pose
    puts them, whether it is ambiguous, and with the attitude how the homography
    alone leans the pad from level (`pipeline.pose.lean_rotation`; else None).
    ``centroid``: the polish places the edges at their drops' centroid (`_unlocked`).
    """
    px = apply_h(H, pts_m)
    lean: np.ndarray | None = None
    cands = []
    for rvec0, tvec0 in ippe_candidates(pts_m, px, cam):
        cands.append(
            (reprojection_rms(pts_m, rvec0, tvec0, cam, px), tilt_deg(rvec0), rvec0, tvec0)
        )
    # Both of IPPE's poses are refined only when they compete (a small pad
    # seen head on); otherwise the one that fits.
    cands.sort(key=lambda c: c[0])
    if len(cands) > 1 and not _tie(cands[0], cands[1]):
        cands = cands[:1]
    # (With the attitude, the steps below weigh it too: from IPPE's poses, on the bench's
    # frames, they came within 0.02 % of the altitude of where they came from these
    # steps', which cost 3.5-12 % of a pad frame's time.)
    if gravity is None:
        obj = np.column_stack([pts_m, np.zeros(len(pts_m))])
        for i, (_, _, rvec0, tvec0) in enumerate(cands):
            rvec, tvec = cv2.solvePnPRefineLM(obj, px, cam.K, cam.dist, rvec0.copy(), tvec0.copy())
            cands[i] = (reprojection_rms(pts_m, rvec, tvec, cam, px), tilt_deg(rvec), rvec, tvec)
    if not cands:
        return None
    ambiguous = False
    # How far the homography shows the pad's tilt: over the whole pad it places.
    all_m = reference.pose_points_m
    all_px = apply_h(H, all_m)
    shown = _tilt_shown(all_px, cam, enlarged)
    if gravity is not None:
        _, _, rvec, tvec = min(cands, key=lambda c: tilt_from_level_deg(c[2], gravity))
        # Whether the pixels, within their noise, let the pad lie level (judged
        # before the pose trusts them less for their bias, which would level any
        # look-alike; on all the pad's points) ...
        sigma_px = _per_point(POINT_SIGMA_PX * max(1.0, NOISE_SHOWN_PX_PER_RAD / shown), all_m)
        check, _ = refine_with_gravity(all_m, all_px, cam, rvec, tvec, gravity, sigma_px=sigma_px)
        if tilt_from_level_deg(check, gravity) > MAX_LEAN_DEG:
            return None
        # How the homography alone leans it: noisier frame to frame than the check, but
        # not drawn toward level (by a camera pitched 8 degrees taken for a downward one,
        # the check's were 6.3 degrees, these 8.0: the median of 40 views).
        lean = lean_rotation(rvec, gravity)
        # ... and the pose, with their bias as well (on ``pts_m``: points the
        # homography placed but no edge measured do not outweigh the attitude).
        sigma_px = _per_point(POINT_SIGMA_PX * max(1.0, TILT_SHOWN_PX_PER_RAD / shown), pts_m)
        rvec, tvec = refine_with_gravity(pts_m, px, cam, rvec, tvec, gravity, sigma_px=sigma_px)
        # Pixels that still lean the pad further from level than the attitude's error
        # allows are biased (a motion blur, a shadow along a side): on the bench's
        # real-world mix every such pose was 2-10 degrees off. They weigh less until
        # the pad lies level within that.
        for _ in range(LEVELLING_STEPS):
            if tilt_from_level_deg(rvec, gravity) <= MAX_TILT_OFF_DEG:
                break
            sigma_px *= 4.0
            rvec, tvec = refine_with_gravity(pts_m, px, cam, rvec, tvec, gravity, sigma_px=sigma_px)
        fit = EdgeFit(rvec, tvec, reprojection_rms(pts_m, rvec, tvec, cam, px), len(pts_m), 0)
        if fit.rms_px > MAX_LEVEL_BENT * _span(px):
            return None
    else:
        cands.sort(key=functools.cmp_to_key(lambda a, b: -1 if _better(a, b) else 1))
        rms, _, rvec, tvec = cands[0]
        ambiguous = len(cands) > 1 and _tie(cands[0], cands[1]) and _apart(cands[0], cands[1])
        # The points pin the tilt to about their noise (POINT_SIGMA_PX, or the fit's
        # RMS where larger) over the tilt they show: a pose whose tilt they do not pin
        # within TOLD_TILT_DEG at two sigmas is not told from one tilted that far. On
        # the bench's views without the hint, poses 3-6.5 degrees off showed their tilt
        # by 5.6-11.5 px a radian (pads of 55-80 px), and H's with no mark found (20-50
        # px) were up to 34 degrees off with no tie to tell.
        sigma = max(POINT_SIGMA_PX, rms)
        ambiguous |= _tilt_shown(px, cam, enlarged) < 2.0 * sigma / np.radians(TOLD_TILT_DEG)
        # A homography no pose fits within a hundredth of the pad's span is bent (fitted
        # to edges that are not all the pad's): on the bench's views such poses were
        # 8-52 degrees off; the right ones fitted within 0.8 % (1.4 % once in 315).
        span = _span(px)
        ambiguous |= rms > MAX_BENT * span
        if rms > MAX_UNPOSED * span:
            return None
        fit = EdgeFit(rvec, tvec, rms, len(pts_m), 0)
    support = edge_support(levels, reference.edge_model, cam, fit.rvec, fit.tvec)
    if polish and (gravity is None or shown >= POLISH_SHOWN_PX_PER_RAD):
        model = reference.edge_model if gravity is None else reference.polish_model
        refined = fit_edges(
            levels, model, cam, fit.rvec, fit.tvec, search_px=1.5, centroid=centroid
        )
        level = refined is not None and (
            gravity is None or tilt_from_level_deg(refined.rvec, gravity) < MAX_TILT_OFF_DEG
        )
        if level:
            better = edge_support(levels, reference.edge_model, cam, refined.rvec, refined.tvec)
            if better >= support:  # a drift along a flat valley finds fewer edges
                fit, support = refined, better
    if gravity is not None and tilt_from_level_deg(fit.rvec, gravity) > MAX_LEAN_DEG:
        return None
    if _seen_from_deg(fit.rvec, fit.tvec) > MAX_VIEW_DEG:
        return None
    return fit, support, ambiguous, lean


def _seen_from_deg(rvec: np.ndarray, tvec: np.ndarray) -> float:
    """The angle between the pad's normal and the line from the camera to its centre:
    the camera's height over the pad's plane against its distance."""
    t = np.asarray(tvec, np.float64).reshape(3)
    cos = abs(camera_height_m(rvec, t)) / max(math.sqrt(float(t @ t)), 1e-12)
    return math.degrees(math.acos(min(cos, 1.0)))


def _per_point(sigma_px: float, pts_m: np.ndarray) -> float:
    """``sigma_px`` for each of ``pts_m`` weighed against the attitude: one homography
    places them all, so past ``WEIGHED_POINTS`` more of them (a ring's polygon's
    vertices) add weight, not evidence."""
    return sigma_px * math.sqrt(max(1.0, len(pts_m) / WEIGHED_POINTS))


def _span(px: np.ndarray) -> float:
    return max(span_of(px), 1.0)


def _tilt_shown(px: np.ndarray, cam: Camera, enlarged: float) -> float:
    """About how many of the frame's own pixels the pad's points move for a radian
    of its tilt (a view ``enlarged`` by interpolation shows no more than the frame)."""
    return _span(px) ** 2 / (cam.fx * enlarged)


def _tie(a, b) -> bool:
    """Whether two (rms, tilt, ...) fits are as good: both within a tenth of a
    pixel, or within AMBIGUOUS_FIT of each other."""
    return max(a[0], b[0]) < 0.1 or min(a[0], b[0]) > AMBIGUOUS_FIT * max(a[0], b[0])


def _apart(a, b) -> bool:
    """Whether two (rms, tilt, rvec, tvec) poses differ by more than a degree."""
    return _angle_deg(a[2], b[2]) > 1.0


def _angle_deg(rvec_a: np.ndarray, rvec_b: np.ndarray) -> float:
    """The angle between two rotations (Rodrigues vectors), degrees."""
    return rotation_angle_deg(cv2.Rodrigues(rvec_a)[0], cv2.Rodrigues(rvec_b)[0])


def _better(a, b) -> bool:
    """(rms, tilt, ...) a before b: the better fit, or on a tie the smaller tilt."""
    if _tie(a, b):
        return a[1] < b[1]
    return a[0] < b[0]
