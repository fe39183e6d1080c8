"""From a frame's bright regions to located H's: shape gate, corners, edge-fitted homography.

Each region of the thresholded channel is compared with the reference's H by
its affine-normalised shape (``pipeline.shape_match``), which is cheap and
indifferent to the view's tilt and to the H's proportions. The survivors, best
first, get their 12 corners: the seed's way first (curvature-scale-space
corners on the boundary, put in the reference's order, kept when a homography
maps the reference's corners onto them), else from the affine map the shape
match found. Either start is refined by fitting the H's sides to the
channel's edges (``pipeline.homography_fit``); the fit must find most of the
H's edges where it puts them.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.homography_fit import HomographyFit, apply_h, fit_homography, span_of
from pipeline.preprocess import Binarized
from pipeline.reference import H_CORNERS, Reference
from pipeline.shapes import Region, css_polygon, douglas_peucker, upsampled_contour

MIN_H_AREA_PX = 24.0  # smaller regions carry too few pixels for an H
MIN_H_SPAN_PX = 8.0  # an H narrower than this is not looked for (see find.SMALL_H_PX)
MAX_SPAN_GROWTH = 3.0  # a fit spanning this many times its region is not that region's H
MIN_SHAPE_IOU = 0.4  # whitened overlap with the reference's H (look-alikes rank below)
MAX_SHAPE_RESIDUAL = 0.1  # CSS corners: homography RMS / sqrt(area) (real H < 0.05)
HOPELESS_AFFINE = 3.0  # an affine fit this many times worse: no homography is tried
MIN_H_SUPPORT = 0.6  # share of the H's sides found on the channel's edges
# A fit of the H that has found less than this of its sides after a few steps gives up:
# on the design bench's frames and the altitude sweep's far ones (some 25,000 fits), 3 of
# the 4,000 that ended with MIN_H_SUPPORT had found so few by then (they ended at
# 0.60-0.62), and 5-26 % of those that did not, per design (most of the rest found too
# few edges to take a step at all).
HOPELESS_SUPPORT = 0.3
CONFIDENT_SUPPORT = 0.9  # a fit this good is not tried from another start
# Edge support plus shape overlap: two views of how much of an H this is. Real
# H's, even drawn with other proportions than the reference's, reach 1.45 and
# up; H-ish blobs of grass or sensor noise stay under 1.4 (measured on the
# shared real photos and the bench's floors).
MIN_EVIDENCE = 1.45
# Enough with the rest of the pad found around the H (find._check): an H of 2 px strokes
# spanning 15 px reaches only 1.0-1.4 (the bench's paper_ring at 2.4-3.2 m).
MIN_FRAMED_EVIDENCE = 1.0
# Evidence an H loses per spread of stroke weight it differs by from the reference's
# (``pipeline.hfit.h_deformation``): real pads against their pictures differ by up to
# 1.5 spreads with evidence 1.56 and up; serifed letters I on their side, fitted as H's
# of light strokes, came to 1.47-1.50 at 0.65-1 spreads (the shared photos; the bench's
# real-world floors).
UNLIKE_COST = 0.1
MIN_BLOB_SEPARATION = 3.0  # the region against the band around it, in pooled std devs
# A candidate smaller than this (the root of its area, view pixels) whose shape match's
# start found too few of the H's sides is no H, and its corners are not read (the CSS
# start): that start is within reach of a small H's sides (perspective bends its corners
# off their affine places by under a pixel). On the bench's real-world mix, the
# CSS corners found an H the start had missed on 3 candidates, of 54-76 px; on the
# altitude sweep's far frames (640 x 480, 12-24 m), on none of 1,600 smaller ones, whose
# reading was a third of a frame's time.
CSS_AFTER_NOTHING_FROM_PX = 40.0
FINE_TRACE_BELOW_PX = 4000.0  # H's smaller than this are traced on a finer grid
FINE_FACTOR = 4
MAX_LOCATED = 6  # candidates fitted per frame at most, best shape first


@dataclass(frozen=True, eq=False)
class Candidate:
    """A region shaped like the H: its boundary and shape overlap."""

    region: Region
    iou: float
    affine: np.ndarray  # 2 x 3, pad metres -> pixels, from the shape match

    @property
    def hu(self) -> tuple[float, ...]:
        """Hu's seven invariants of the region (the seed's moments)."""
        return tuple(cv2.HuMoments(cv2.moments(self.region.contour.reshape(-1, 1, 2))).ravel())


@dataclass(frozen=True, eq=False)
class Located:
    """A candidate whose H's sides were found: corners in the reference's order."""

    candidate: Candidate
    corners: np.ndarray  # (12, 2) pixels
    fit: HomographyFit
    start: str  # "css" (the seed's corners) or "shape" (the affine shape match)
    unlike: float = 0.0  # how far its strokes differ from the reference's, in spreads

    @property
    def evidence(self) -> float:
        """Edge support plus shape overlap (0..2), less what drawing the H's strokes
        other than the reference's cost: an H unlike its picture is weaker evidence
        of the pad (a serifed letter I on its side is an H of thin strokes)."""
        return self.fit.support + self.candidate.iou - UNLIKE_COST * self.unlike


def candidates(
    found: list[Region], reference: Reference, top: int | None = None
) -> list[Candidate]:
    """Regions whose whitened shape overlaps the reference's H, most alike first
    (the ``top`` most alike)."""
    lo = 0.5 * reference.solidity
    shaped = [r for r in found if r.span >= MIN_H_SPAN_PX and lo <= r.solidity <= 0.97]
    hits = reference.shape.match_many([r.contour for r in shaped], MIN_SHAPE_IOU, top=top)
    out = [Candidate(r, hit.iou, hit.affine) for r, hit in zip(shaped, hits, strict=True) if hit]
    out.sort(key=lambda c: -c.iou)
    return out


def locate_all(found: list[Region], binary: Binarized, reference: Reference) -> Iterator[Located]:
    """Located H's among the regions, best shape first (at most ``MAX_LOCATED`` tried)."""
    for cand in candidates(found, reference, MAX_LOCATED):
        located = locate(cand, binary, reference)
        if located is not None:
            yield located


def locate(cand: Candidate, binary: Binarized, reference: Reference) -> Located | None:
    """Fit the H's sides from the candidate's shape match, then if that does not
    find them well, from its CSS corners (the seed's reading); the fit with the
    most evidence wins.

    The affine start of the shape match needs no corners at all: it holds for
    thin strokes, serifs and blur that leave CSS a skewed reading (which may
    converge to a stretched H). The seed's corners do better on a bold H drawn
    with other proportions than the reference's, or a large one whose perspective
    bends it off the affine start (not on a small one: ``CSS_AFTER_NOTHING_FROM_PX``).
    """
    span = math.sqrt(cand.region.area)
    best: Located | None = None
    for name in ("shape", "css"):
        if name == "shape":
            H0 = np.vstack([cand.affine, [0.0, 0.0, 1.0]])
            # An affine start may be a few pixels off on a tilted view.
            search = min(max(0.12 * span, 2.5), 3.0)
        else:
            if best is None and span < CSS_AFTER_NOTHING_FROM_PX:
                break
            H0 = css_homography(cand.region, binary, reference)
            if H0 is None:
                continue
            search = 2.5
        fitted = fit_h_sides(binary.smooth, reference, H0, search_px=search)
        if fitted is None:
            continue
        fit, unlike = fitted
        deform = reference.h_deformation
        corners = apply_h(fit.H, deform.corners(reference.corners_m, fit.shape))
        # (a fit run away to a homography near singular spans thousands of pixels)
        if not MIN_H_SPAN_PX <= span_of(corners) <= MAX_SPAN_GROWTH * max(cand.region.span, 1.0):
            continue
        located = Located(cand, corners, fit, name, unlike)
        if best is None or (located.evidence, -fit.rms_px) > (best.evidence, -best.fit.rms_px):
            best = located
        if best.fit.support >= CONFIDENT_SUPPORT:
            break  # the H's edges were found: no need for another start
    return best


def fit_h_sides(
    levels: np.ndarray,
    reference: Reference,
    H0: np.ndarray,
    *,
    search_px: float,
    enough: float = CONFIDENT_SUPPORT,
) -> tuple[HomographyFit, float] | None:
    """The H's sides fitted to the edges from ``H0``: as the reference draws them,
    and when that finds fewer than ``enough`` of them, with its strokes' weight free
    too (a pad is rarely drawn exactly as its picture); the fit with the more evidence
    (see `Located.evidence`), with how far its strokes differ from the reference's
    (in spreads), or None when neither finds ``MIN_H_SUPPORT`` of the sides."""
    deform = reference.h_deformation
    best: tuple[HomographyFit, float] | None = None
    for how in (None, deform):
        fit = fit_homography(
            levels,
            reference.h_edges,
            H0,
            search_px=search_px,
            deform=how,
            give_up_below=HOPELESS_SUPPORT,
        )
        if fit is None or fit.support < MIN_H_SUPPORT:
            continue
        unlike = float(np.abs(fit.shape / deform.sigma).max()) if len(fit.shape) else 0.0
        if (
            best is None
            or fit.support - UNLIKE_COST * unlike > best[0].support - UNLIKE_COST * best[1]
        ):
            best = (fit, unlike)
        if best[0].support >= enough or not len(deform.sigma):
            break
    return best


def blob_separation(
    smooth: np.ndarray,
    region: Region,
    stroke_px: float,
    board_only: Callable[[np.ndarray], np.ndarray] | None = None,
) -> float:
    """How clearly a region stands out from the band around it: (mean inside - mean
    of the band) / pooled standard deviation, on the smoothed channel.

    A painted H is uniform on a uniform board; an H-ish blob of grass or sensor
    noise has more of the same around it. The band starts a pixel out (past the
    blurred edge) and is a stroke wide; ``board_only`` (frame pixels, N x 2 ->
    bool) keeps the band's pixels that are board. A shadow's edge or sun glare
    across the pad spreads both sides' levels over the whole H, though each part
    of the H still stands out from the board beside it: the separation is also
    taken per quadrant around the region's centre, and the better of the whole's
    and the quadrants' median counts.
    """
    c = region.contour.reshape(-1, 1, 2).astype(np.int32)
    x, y, w, h = cv2.boundingRect(c)
    reach = int(max(2.0, round(stroke_px)))
    p = reach + 2
    x0, y0 = max(x - p, 0), max(y - p, 0)
    x1, y1 = min(x + w + p, smooth.shape[1]), min(y + h + p, smooth.shape[0])
    m = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.fillPoly(m, [c - np.array([x0, y0], np.int32)], 1)
    k3 = np.ones((3, 3), np.uint8)
    core = cv2.erode(m, k3) if stroke_px >= 4 else m
    near = cv2.dilate(m, k3)
    far = cv2.dilate(m, np.ones((2 * reach + 1, 2 * reach + 1), np.uint8))
    patch = smooth[y0:y1, x0:x1].astype(np.float64)
    band_mask = (far > 0) & (near == 0)
    if board_only is not None:
        # Pixels the reference shows painted (a ring or a frame close to the H)
        # are not board.
        ys, xs = np.nonzero(band_mask)
        keep = board_only(np.column_stack([xs + x0, ys + y0]).astype(np.float64))
        band_mask[ys[~keep], xs[~keep]] = False
    # Levels summed per quadrant around the region's centre, inside (1) and in the
    # band (2): one pass for the whole and its quadrants.
    cx, cy = region.contour.mean(axis=0) - np.array([x0, y0])
    right = np.arange(patch.shape[1])[None, :] >= cx
    bottom = np.arange(patch.shape[0])[:, None] >= cy
    cls = (core > 0).astype(np.intp) + 2 * band_mask
    key = (4 * cls + right + 2 * bottom)[cls > 0]
    values = patch[cls > 0]
    n = np.bincount(key, minlength=12)[4:].reshape(2, 4).astype(np.float64)
    s1 = np.bincount(key, values, minlength=12)[4:].reshape(2, 4)
    s2 = np.bincount(key, values * values, minlength=12)[4:].reshape(2, 4)
    whole = _separation(n.sum(axis=1), s1.sum(axis=1), s2.sum(axis=1))
    parts = [v for q in range(4) if math.isfinite(v := _separation(n[:, q], s1[:, q], s2[:, q]))]
    if len(parts) < 3:
        return whole
    local = float(np.median(parts))
    return whole if whole >= local else local  # (a nan whole: the quadrants')


def _separation(n: np.ndarray, s1: np.ndarray, s2: np.ndarray) -> float:
    """(mean inside - mean of the band) / pooled standard deviation, from the two
    sets' counts, sums and sums of squares (inside first); nan for too few pixels."""
    if n[0] < 4 or n[1] < 4:
        return math.nan
    mean = s1 / n
    var = np.maximum(s2 / n - mean * mean, 0.0)
    pooled = math.sqrt(0.5 * float(var[0] + var[1]))
    return float(mean[0] - mean[1]) / max(pooled, 1.0)


def css_homography(region: Region, binary: Binarized, reference: Reference) -> np.ndarray | None:
    """The seed's reading: the homography (pad metres -> pixels) that puts the
    reference's corners on the region's 12 CSS corners, when they fit it."""
    for reading in corner_readings(region, binary):
        _, residual, H = match_corners(reading, reference.corners_m, region.area)
        if residual <= MAX_SHAPE_RESIDUAL:
            return H
    return None


def corner_readings(region: Region, binary: Binarized) -> Iterator[np.ndarray]:
    """Ways to read the 12 corners of a candidate, best first.

    Curvature-scale-space corners on the boundary (traced on a 4x finer grid
    for small candidates), then Douglas-Peucker polygons of the same boundary
    and of the pixel boundary: blur can round a corner off or add a ripple
    that CSS takes for one, and the cheaper readings are tried only then. Each
    is made when asked for (the caller stops at the first that fits).
    """
    fine = None
    if region.area <= FINE_TRACE_BELOW_PX:
        fine = upsampled_contour(binary.smooth, binary.mask, region, FINE_FACTOR)
    if fine is None:
        yield from _css_then_polygon(region.contour)
        return
    pts, offset = fine
    for poly in _css_then_polygon(pts):
        yield (poly + 0.5) / FINE_FACTOR - 0.5 + offset
    poly = douglas_peucker(region.contour, H_CORNERS)
    if poly is not None:
        yield poly


def _css_then_polygon(pts: np.ndarray) -> Iterator[np.ndarray]:
    """The CSS corners of a boundary, then its Douglas-Peucker polygon."""
    for read in (css_polygon, douglas_peucker):
        poly = read(pts, H_CORNERS)
        if poly is not None:
            yield poly


def match_corners(
    poly: np.ndarray, ref_m: np.ndarray, area: float
) -> tuple[np.ndarray, float, np.ndarray | None]:
    """Rotate the corner list onto the reference's order; return it, the fit residual
    and the homography from the reference's corners (None when there is none, or
    when even an affine map leaves them hopelessly far: the residual is then its).

    All 12 cyclic shifts are scored at once by an affine fit (a few microseconds);
    the best is checked with a full homography, whose residual relative to the
    shape's size says whether this is the reference's H at all.
    """
    n = len(ref_m)
    shifts = poly[_shift_index(n)]  # (n, n, 2): shift s starts at corner s
    fitted = np.einsum("ij,sjk->sik", _affine_projector(ref_m.tobytes(), n), shifts)
    err = np.sum((shifts - fitted) ** 2, axis=(1, 2))
    best = int(np.argmin(err))
    ordered = shifts[best]
    # A view's perspective bends an H's corners off their affine places by a few
    # percent of its size: far more, and no homography fits them either.
    affine_rms = math.sqrt(float(err[best]) / n / area)
    if affine_rms > HOPELESS_AFFINE * MAX_SHAPE_RESIDUAL:
        return ordered, affine_rms, None
    H = _dlt(ref_m, ordered)
    if H is None:
        return ordered, math.inf, None
    proj = apply_h(H, ref_m)
    rms = float(np.sqrt(np.mean(np.sum((proj - ordered) ** 2, axis=1))))
    return ordered, rms / math.sqrt(area), H


@functools.cache
def _shift_index(n: int) -> np.ndarray:
    return (np.arange(n)[None, :] + np.arange(n)[:, None]) % n


@functools.lru_cache(maxsize=16)
def _affine_projector(ref_bytes: bytes, n: int) -> np.ndarray:
    """The n x n matrix that takes n points to their least-squares affine image of
    the reference's points (given as the bytes of an n x 2 float64 array)."""
    ref = np.frombuffer(ref_bytes, np.float64).reshape(n, 2)
    X = np.column_stack([ref, np.ones(n)])
    return X @ np.linalg.pinv(X)


def _dlt(src: np.ndarray, dst: np.ndarray) -> np.ndarray | None:
    """The least-squares homography src -> dst (normalised direct linear transform)."""
    Ts, Td = _normaliser(src), _normaliser(dst)
    s, d = apply_h(Ts, src), apply_h(Td, dst)
    n = len(s)
    A = np.zeros((2 * n, 9))
    A[0::2, 0:2], A[0::2, 2] = s, 1.0
    A[1::2, 3:5], A[1::2, 5] = s, 1.0
    A[0::2, 6:8] = -d[:, :1] * s
    A[0::2, 8] = -d[:, 0]
    A[1::2, 6:8] = -d[:, 1:] * s
    A[1::2, 8] = -d[:, 1]
    Hn = np.linalg.svd(A)[2][-1].reshape(3, 3)
    H = np.linalg.inv(Td) @ Hn @ Ts
    if not np.isfinite(H).all() or abs(H[2, 2]) < 1e-12:
        return None
    return H / H[2, 2]


def _normaliser(pts: np.ndarray) -> np.ndarray:
    c = pts.mean(axis=0)
    scale = math.sqrt(2.0) / max(float(np.mean(np.hypot(*(pts - c).T))), 1e-12)
    return np.array([[scale, 0.0, -scale * c[0]], [0.0, scale, -scale * c[1]], [0.0, 0.0, 1.0]])
