"""Model-based pose refinement on the pad's edges.

Corners of a distant pad are poor evidence: the H's short sides (a stroke's
end, a few pixels long) cannot be measured, and a pad 50 px wide seen nearly
head-on leaves tilt and sideways position trading off against each other.
Edges are better evidence: every long straight edge of the pad (the H's
sides, the side bars', the board's outline) is sampled along its projection,
the true edge is located on the gray image across it (strongest gradient of
the expected polarity, sub-pixel), and the pose is adjusted by Gauss-Newton to
minimise the distances of those edge points to the projected model edges,
measured along the edge normals (the classic RAPiD / edge-tracking scheme).
The projection's Jacobian comes from ``pipeline.planar_projection`` (OpenCV's model).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from pipeline import edge_kernels as kernels
from pipeline.camera import Camera
from pipeline.jit import compiled, pixels, plain
from pipeline.planar_projection import plane_pixels, project_plane

MIN_SIDE_PX = 7.0  # sides shorter than this in the image are not sampled
RESOLVED_PX = 1.0  # a side nearer a side alongside it than this is not told from it
END_MARGIN = 0.12  # at most this share of a straight side is left out at each end
END_MARGIN_OF_EXTENT = 0.02  # and at most this share of the model's size
MODEL_SAMPLES = 600  # points along all the model's sides, spread by length
MAX_SAMPLES_PER_SIDE = 40
CURVE_VERTICES = 12  # polygons with more vertices trace a curve (a ring, a disc's rim)
RIM_ALONE = 4.0  # a rim's side with no fitted side alongside it needs this many times the room


@dataclass(frozen=True, eq=False)
class EdgeModel:
    """The pad's straight sides in pad metres, with what is needed to sample them."""

    a_m: np.ndarray  # (S, 2) side starts
    b_m: np.ndarray  # (S, 2) side ends
    bright: np.ndarray  # (S,) the polygon is brighter than its surroundings
    polygon: np.ndarray  # (S,) which polygon each side belongs to
    clearance_m: np.ndarray  # (S,) distance to the nearest other side alongside
    curved: np.ndarray  # (S,) the side is a piece of a curve, not a straight edge

    @cached_property
    def sampling(self) -> tuple[np.ndarray, np.ndarray]:
        """The side each sample lies on, and where along it (0 at its start, 1 at its end).

        About ``MODEL_SAMPLES`` in all, spread by length: at least 3 on a
        straight side (its ends left out: the neighbouring side's edge
        disturbs them), at least 1 on a piece of a curve.
        """
        d = self.b_m - self.a_m
        length = np.hypot(d[:, 0], d[:, 1])
        per_m = MODEL_SAMPLES / max(float(length.sum()), 1e-12)
        counts = np.clip(np.round(length * per_m), 1, MAX_SAMPLES_PER_SIDE).astype(int)
        counts = np.where(self.curved, counts, np.maximum(counts, 3))
        side = np.repeat(np.arange(len(length)), counts)
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        k = np.arange(len(side)) - np.repeat(first, counts)
        n = np.repeat(counts, counts)
        # Left out at each end: a little of the model's size, at most a share
        # of a short side (a stroke's end).
        extent = float(np.ptp(np.vstack([self.a_m, self.b_m]), axis=0).max())
        f = np.minimum(END_MARGIN, END_MARGIN_OF_EXTENT * extent / np.maximum(length, 1e-12))
        f = f[side]
        t = np.where(self.curved[side], (k + 0.5) / n, f + (1 - 2 * f) * k / np.maximum(n - 1, 1))
        return side, t

    @cached_property
    def ends(self) -> np.ndarray:
        """The sides' starts, then their ends (2S x 2 metres)."""
        return np.vstack([self.a_m, self.b_m])

    @cached_property
    def ends_normalised(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The sides' starts and ends (`ends`), and the `normalising` map of them and its
        inverse (the homography fit's unknowns are conditioned by it)."""
        return (self.ends, *normalising(self.ends))

    @cached_property
    def samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Points along the sides (pad metres, see `sampling`) and the side each lies on."""
        side, t = self.sampling
        return self.a_m[side] + t[:, None] * (self.b_m - self.a_m)[side], side

    @classmethod
    def from_polygons(
        cls, polygons: list[tuple[np.ndarray, bool]], *, rims: Mapping[int, float] | None = None
    ) -> EdgeModel:
        """The sides of closed polygons (pad metres) with the side each is bright on.

        ``rims``: the polygons that are the board's outer edge, each with the width of
        the band of another colour right beyond it (pad metres; 0: the floor, see
        `pipeline.marks.band_beyond`). A blurred edge is pushed away from a side
        alongside it whose edge steps the other way (the two bound a band), by a few
        tenths of a pixel when they lie 2-3 px apart. Where both are
        fitted the two pushes balance; a rim has nothing beyond it (the floor), and
        when the side alongside it is too close to its own neighbour to be fitted (a
        thin ring inside a disc's rim) nothing balances it: a black disc's rim 2.8 px
        out from its red ring made the pad 1 % larger, its altitude 1 % lower, at
        10 m. A rim's side with a side alongside most of its length is fitted where that
        side is too, or where it lies ``RIM_ALONE`` times as far from it as it needs;
        and a rim with a band beyond it (a hem, whose far edge is no side of the model)
        where that lies ``RIM_ALONE`` times as far as it needs."""
        rims = rims or {}
        starts, ends, bright, owner, curved = [], [], [], [], []
        for k, (corners_m, is_bright) in enumerate(polygons):
            c = np.asarray(corners_m, np.float64).reshape(-1, 2)
            starts.append(c)
            ends.append(np.roll(c, -1, axis=0))
            bright.append(np.full(len(c), bool(is_bright)))
            owner.append(np.full(len(c), k))
            curved.append(np.full(len(c), len(c) > CURVE_VERTICES))
        a, b = np.vstack(starts), np.vstack(ends)
        poly = np.concatenate(owner)
        clearance, beside, shared = _clearance_m(a, b, poly)
        # (clearance: what the fits compare with the room a side needs, in pixels)
        held = np.where(beside >= 0, clearance[np.maximum(beside, 0)], np.inf)
        alone = np.maximum(held, clearance / RIM_ALONE)
        lone_rim = np.isin(poly, list(rims)) & (shared >= 0.5)
        clearance = np.where(lone_rim, np.minimum(clearance, alone), clearance)
        band = np.array([rims.get(int(k)) or np.inf for k in poly])
        clearance = np.minimum(clearance, band / RIM_ALONE)
        return cls(a, b, np.concatenate(bright), poly, clearance, np.concatenate(curved))


def normalising(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The scale and shift that takes points (N x 2) to about unit size around the
    origin, and its inverse (3 x 3 each)."""
    return _normalising(plain(pts).reshape(-1, 2))


@compiled
def _normalising(pts):
    # (numpy's numbers: the mean over rows summed in their order, as its reduction does)
    lo0, lo1, hi0, hi1 = pts[0, 0], pts[0, 1], pts[0, 0], pts[0, 1]
    s0, s1 = 0.0, 0.0
    for i in range(len(pts)):
        x, y = pts[i, 0], pts[i, 1]
        lo0, lo1, hi0, hi1 = min(lo0, x), min(lo1, y), max(hi0, x), max(hi1, y)
        s0, s1 = s0 + x, s1 + y
    c0, c1 = s0 / len(pts), s1 / len(pts)
    k = 1.0 / max(max(hi0 - lo0, hi1 - lo1), 1e-9)
    T = np.array([[k, 0.0, -k * c0], [0.0, k, -k * c1], [0.0, 0.0, 1.0]])
    T_inv = np.array([[1.0 / k, 0.0, c0], [0.0, 1.0 / k, c1], [0.0, 0.0, 1.0]])
    return T, T_inv


@dataclass(frozen=True, eq=False)
class EdgeFit:
    rvec: np.ndarray
    tvec: np.ndarray
    rms_px: float  # RMS distance of the inlier edge points to the model edges
    inliers: int
    sides: int  # model sides that contributed


def fit_edges(
    image: np.ndarray,
    model: EdgeModel,
    camera: Camera,
    rvec: np.ndarray,
    tvec: np.ndarray,
    *,
    iterations: int = 3,
    search_px: float = 2.5,
    centroid: bool = False,
) -> EdgeFit | None:
    """Refine a pose so that the pad's polygons' sides lie on the image's edges.

    Parameters
    ----------
    image : smoothed gray frame (2-D).
    model : the pad's sides (:meth:`EdgeModel.from_polygons`).
    camera : intrinsics of ``image``.
    rvec, tvec : starting pose (OpenCV pad -> camera).
    centroid : edges placed at their drops' centroid (`edge_kernels.edge_offsets`).
    """
    img = pixels(image)
    rvec = np.asarray(rvec, np.float64).reshape(3, 1).copy()
    tvec = np.asarray(tvec, np.float64).reshape(3, 1).copy()
    result = None  # (rvec, tvec, rms, inliers, sides) of the last good step
    for it in range(iterations):
        search = search_px if it == 0 else max(1.5, 0.6 * search_px)
        pa, pb, usable = _sides_in_view(model, camera, rvec, tvec, search + 2.0)
        proj, jac = project_plane(model.samples[0], rvec, tvec, camera)
        step, rms, inliers, sides, ok = kernels.pose_step(
            img, pa, pb, model.bright, model.polygon, model.curved, usable,
            model.samples[1], proj, jac, float(search), MIN_SIDE_PX, kernels.MIN_DROP,
            centroid,
        )  # fmt: skip
        if not ok:
            break
        rvec = rvec + step[:3, None]
        tvec = tvec + step[3:, None]
        if tvec[2, 0] <= 0:
            return None
        result = (rvec.copy(), tvec.copy(), rms, inliers, sides)
        turn, move = math.sqrt(float(step[:3] @ step[:3])), math.sqrt(float(step[3:] @ step[3:]))
        if turn < 2e-5 and move < 2e-5 * float(tvec[2, 0]):
            break
    return None if result is None else EdgeFit(*result)


def edge_support(
    image: np.ndarray, model: EdgeModel, camera: Camera, rvec, tvec, *, resolved_px: float = 0.0
) -> float:
    """Share of samples along all the pad's visible sides that sit on a real edge;
    with ``resolved_px``, along those that lie at least that far from a side alongside
    them (`RESOLVED_PX`: the sides a frame tells apart).

    A look-alike shape can fit the H's corners, but the dark board around it,
    the side bars and the board's outline will not be where the pose says.
    """
    pa, pb, usable = _sides_in_view(model, camera, rvec, tvec, resolved_px)
    proj = plane_pixels(model.samples[0], rvec, tvec, camera)
    return kernels.pose_support(
        pixels(image), pa, pb, model.bright, model.polygon,
        model.curved, usable, model.samples[1], proj, MIN_SIDE_PX, kernels.MIN_DROP,
    )  # fmt: skip


def sides_told_apart(model: EdgeModel, camera: Camera, rvec, tvec) -> bool:
    """Whether every side lies `RESOLVED_PX` or more from a side alongside it (then
    `edge_support` counts the same with ``resolved_px`` as without)."""
    return bool(_sides_in_view(model, camera, rvec, tvec, RESOLVED_PX)[2].all())


def _clearance_m(
    a: np.ndarray, b: np.ndarray, polygon: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each side, the distance to the nearest other side running alongside it, that
    side (-1: none) and the share of the side's length it runs alongside.

    Two parallel edges closer than the blur's reach bias each other's measured
    position, so such sides are left out when the pad is small in the image.
    """
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    u = d / length[:, None]
    mid = 0.5 * (a + b)
    out = np.full(len(a), np.inf)
    nearest = np.full(len(a), -1)
    shared = np.zeros(len(a))
    # A curve's neighbouring sides run on from each other, not alongside.
    follows = np.zeros(len(a), bool)
    for i in range(len(a)):
        parallel = np.abs(u[:, 0] * u[i, 1] - u[:, 1] * u[i, 0]) < 0.17
        follows[:] = False
        touching = (np.hypot(*(a - b[i]).T) < 1e-12) | (np.hypot(*(b - a[i]).T) < 1e-12)
        follows[touching & (polygon == polygon[i])] = True
        parallel &= ~follows
        parallel[i] = False
        if not parallel.any():
            continue
        rel = mid[parallel] - mid[i]
        across = np.abs(rel[:, 0] * u[i, 1] - rel[:, 1] * u[i, 0])
        along = np.abs(rel @ u[i])
        beside = along < 0.5 * (length[i] + length[parallel])  # they overlap lengthwise
        if beside.any():
            others = np.flatnonzero(parallel)
            k = int(np.argmin(np.where(beside, across, np.inf)))
            out[i], nearest[i] = float(across[k]), int(others[k])
            # (a curve alongside runs in pieces: those about as near count together)
            near = others[beside & (across <= 1.5 * out[i])]
            ta, tb = (a[near] - a[i]) @ u[i], (b[near] - a[i]) @ u[i]
            overlap = np.minimum(np.maximum(ta, tb), length[i]) - np.maximum(np.minimum(ta, tb), 0)
            shared[i] = min(1.0, float(np.maximum(overlap, 0.0).sum()) / length[i])
    return out, nearest, shared


def _sides_in_view(model: EdgeModel, camera: Camera, rvec, tvec, min_clearance_px: float):
    """The model's sides' ends in the image, and which sides lie at least
    ``min_clearance_px`` from a side alongside them."""
    ends = plane_pixels(model.ends, rvec, tvec, camera)
    R, _ = cv2.Rodrigues(rvec)
    depth = 0.5 * (model.a_m + model.b_m) @ R[2, :2] + float(np.asarray(tvec).ravel()[2])
    clearance_px = model.clearance_m * camera.fx / np.maximum(depth, 1e-6)
    n = len(model.a_m)
    return ends[:n], ends[n:], clearance_px >= min_clearance_px
