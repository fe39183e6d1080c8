"""Shape moments: area, centroid, Hu's seven invariants, orientation, eccentricity.

The seed's section 4.2 describes these (eqs. 4.8-4.16) with two typos that are not
copied here: the normalised moment is ``eta_pq = mu_pq / mu_00 ** ((p + q) / 2 + 1)``
(eq. 4.13 puts ``mu_pq`` in the denominator), and ``mu_21`` (eq. 4.12) is
``m21 - 2 x m11 - y m20 + 2 x^2 m01``. OpenCV's ``cv2.moments``/``cv2.HuMoments``
agree with this module and serve as the tests' oracle.

Moments are summed here with numpy about a nearby origin (the mean of the points),
which keeps the central moments accurate for shapes far from the image origin:

- a contour is a polygon through its points (Green's theorem, as ``cv2.moments`` does
  for contours; the traversal direction does not matter);
- a mask counts each non-zero pixel ``(x, y)`` as a unit mass at that point (as
  ``cv2.moments(mask, binaryImage=True)`` does).

Examples
--------
>>> import numpy as np
>>> square = np.array([[0, 0], [10, 0], [10, 10], [0, 10]])
>>> m = shape_moments(square)
>>> m.area, m.centroid, round(m.hu[0], 6), m.eccentricity
(100.0, (5.0, 5.0), 0.166667, 0.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.jit import compiled

__all__ = ["ShapeMoments", "hu_distance", "shape_moments"]


@dataclass(frozen=True)
class ShapeMoments:
    """Moment features of one shape, in pixel units of the image it came from.

    ``area``: polygon area (contour) or pixel count (mask). ``centroid``: (x, y).
    ``hu``: Hu's seven invariants, as ``cv2.HuMoments`` gives them; the 7th changes
    sign when the shape is mirrored. ``orientation_deg``: the principal (long) axis,
    in (-90, 90], measured counter-clockwise from the image's +x axis *as seen on
    screen* (image y points down, so an axis running up and to the right is
    positive); 0 when the second moments have no preferred axis at all, and
    meaningless when ``eccentricity`` is near 0 (a circle, a square).
    ``eccentricity``: ``sqrt(1 - lambda_min / lambda_max)`` of the second-moment
    matrix: 0 for a circle or a square, ``sqrt(1 - (b/a)^2)`` for an a:b ellipse, 1 for
    a line.
    """

    area: float
    centroid: tuple[float, float]
    hu: tuple[float, float, float, float, float, float, float]
    orientation_deg: float
    eccentricity: float

    def to_dict(self) -> dict:
        return {
            "area": self.area,
            "centroid": list(self.centroid),
            "hu": list(self.hu),
            "orientation_deg": self.orientation_deg,
            "eccentricity": self.eccentricity,
        }


def shape_moments(shape: np.ndarray) -> ShapeMoments:
    """Moment features of a contour or a binary mask.

    Parameters
    ----------
    shape : array
        A contour: (N, 2) or OpenCV (N, 1, 2) points (x, y), N >= 3, of any numeric
        dtype except bool/uint8; or a mask: a 2-D bool or uint8 array whose non-zero
        pixels are the shape.

    Returns
    -------
    ShapeMoments

    Raises
    ------
    ValueError
        If ``shape`` is None, of the wrong shape or dtype, not finite, empty, or of
        zero area.

    Examples
    --------
    >>> import numpy as np
    >>> mask = np.zeros((20, 40), bool)
    >>> mask[5:8, 2:32] = True
    >>> m = shape_moments(mask)
    >>> m.area, m.centroid, m.orientation_deg
    (90.0, (16.5, 6.0), 0.0)
    """
    if shape is None:
        raise ValueError("shape must be a contour or a 2-D mask, got None")
    arr = np.asarray(shape)
    if arr.ndim == 2 and arr.dtype in (np.bool_, np.uint8):
        mu, origin = _mask_central(arr)
    elif (arr.ndim == 3 and arr.shape[1:] == (1, 2)) or (arr.ndim == 2 and arr.shape[1] == 2):
        mu, origin = _contour_central(arr.reshape(-1, 2))
    else:
        raise ValueError(
            "shape must be a contour of shape (N, 2) or (N, 1, 2), or a 2-D bool/uint8 "
            f"mask; got shape {arr.shape} and dtype {arr.dtype}"
        )
    return _features(mu, origin)


def hu_distance(a: np.ndarray, b: np.ndarray, *, count: int = 7, eps: float = 1e-12) -> float:
    """Log-scaled distance between two Hu vectors, for telling look-alike shapes apart.

    ``sum_i |m(a_i) - m(b_i)|`` over the first ``count`` invariants, with
    ``m(h) = sign(h) * log10(1 + |h| / eps)``: for ``|h| >> eps`` this is
    ``sign(h) * log10|h|`` plus a constant that cancels between values of equal sign
    (the log scale of ``cv2.matchShapes``' CONTOURS_MATCH_I3); it goes smoothly to 0
    at ``h = 0``, so zeros and values below ``eps`` count as zero instead of as
    minus infinity.

    Parameters
    ----------
    a, b : sequence of 7 floats
        Hu invariants, e.g. ``ShapeMoments.hu``.
    count : int
        How many invariants to compare, 1..7 (the H is symmetric under a half turn, so
        its 3rd..7th are noise around 0).
    eps : float
        Magnitude below which an invariant counts as zero.

    Examples
    --------
    >>> round(hu_distance([0.2, 0.01, 0, 0, 0, 0, 0], [0.2, 0.001, 0, 0, 0, 0, 0]), 6)
    1.0
    """
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or not 1 <= count <= 7:
        raise ValueError(f"count must be an integer in 1..7, got {count!r}")
    if isinstance(eps, bool) or not isinstance(eps, int | float) or not 0 < eps < math.inf:
        raise ValueError(f"eps must be a positive finite number, got {eps!r}")
    ha = _hu_vector(a, "a")[:count]
    hb = _hu_vector(b, "b")[:count]

    def scaled(h: np.ndarray) -> np.ndarray:
        return np.sign(h) * np.log10(1.0 + np.abs(h) / eps)

    return float(np.sum(np.abs(scaled(ha) - scaled(hb))))


# --- moments ----------------------------------------------------------------------------
# Raw moments are in the order m00 m10 m01 m20 m11 m02 m30 m21 m12 m03, central ones in
# the order mu00 mu20 mu11 mu02 mu30 mu21 mu12 mu03.


def _contour_central(pts: np.ndarray) -> tuple[np.ndarray, tuple[float, float]]:
    """Central moments of the polygon through ``pts``, and its centroid."""
    # (numpy's numbers: integers, timedeltas, floats and complex; the kinds, not
    # np.issubdtype, which costs a frame more than the moments)
    if pts.dtype in (np.bool_, np.uint8) or pts.dtype.kind not in "iumfc":
        raise ValueError(f"shape: contour points must be numbers, got dtype {pts.dtype}")
    if pts.dtype.kind == "c":
        raise ValueError("shape: contour points must be real (x, y) coordinates")
    pts = pts.astype(np.float64)
    if pts.shape[0] < 3:
        raise ValueError(f"shape: a contour needs at least 3 points, got {pts.shape[0]}")
    if not np.isfinite(pts).all():
        raise ValueError("shape: contour points must be finite (found NaN or inf)")
    origin = pts.mean(axis=0)
    sums = _polygon_sums(np.ascontiguousarray(pts - origin))
    m00 = sums[0]
    span = float((pts.max(axis=0) - pts.min(axis=0)).max())
    if abs(m00) <= 1e-12 * max(span * span, 1.0):
        raise ValueError("shape: the contour encloses zero area")
    if m00 < 0:  # clockwise in these axes: every moment comes out negated
        sums = -sums
    mu, cx, cy = _central_from_raw(sums)
    return mu, (float(origin[0] + cx), float(origin[1] + cy))


@compiled
def _polygon_sums(pts):
    """The raw moments of the polygon through ``pts`` (N x 2), by Green's
    theorem over its edges (x0, y0) -> (x1, y1)."""
    out = np.zeros(10)
    n = pts.shape[0]
    for i in range(n):
        x0, y0 = pts[i, 0], pts[i, 1]
        x1, y1 = pts[(i + 1) % n, 0], pts[(i + 1) % n, 1]
        cross = x0 * y1 - x1 * y0
        out[0] += cross / 2
        out[1] += cross * (x0 + x1) / 6
        out[2] += cross * (y0 + y1) / 6
        out[3] += cross * (x0 * x0 + x0 * x1 + x1 * x1) / 12
        out[4] += cross * (x0 * (2 * y0 + y1) + x1 * (y0 + 2 * y1)) / 24
        out[5] += cross * (y0 * y0 + y0 * y1 + y1 * y1) / 12
        out[6] += cross * (x0 + x1) * (x0 * x0 + x1 * x1) / 20
        m21 = x0 * x0 * (3 * y0 + y1) + 2 * x0 * x1 * (y0 + y1) + x1 * x1 * (y0 + 3 * y1)
        m12 = y0 * y0 * (3 * x0 + x1) + 2 * y0 * y1 * (x0 + x1) + y1 * y1 * (x0 + 3 * x1)
        out[7] += cross * m21 / 60
        out[8] += cross * m12 / 60
        out[9] += cross * (y0 + y1) * (y0 * y0 + y1 * y1) / 20
    return out


@compiled
def _central_from_raw(m):
    """Central moments from raw ones taken about some origin, and the centroid from
    that origin."""
    m00, m10, m01, m20, m11 = m[0], m[1], m[2], m[3], m[4]
    m02, m30, m21, m12, m03 = m[5], m[6], m[7], m[8], m[9]
    cx, cy = m10 / m00, m01 / m00
    mu = np.array(
        [
            m00,
            m20 - cx * m10,
            m11 - cx * m01,
            m02 - cy * m01,
            m30 - 3 * cx * m20 + 2 * cx * cx * m10,
            m21 - 2 * cx * m11 - cy * m20 + 2 * cx * cx * m01,
            m12 - 2 * cy * m11 - cx * m02 + 2 * cy * cy * m10,
            m03 - 3 * cy * m02 + 2 * cy * cy * m01,
        ]
    )
    return mu, cx, cy


def _mask_central(mask: np.ndarray) -> tuple[np.ndarray, tuple[float, float]]:
    """Central moments of a mask's non-zero pixels, and its centroid."""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        raise ValueError("shape: the mask has no pixels set (zero area)")
    cx, cy = xs.mean(), ys.mean()
    dx, dy = xs - cx, ys - cy
    dx2, dy2 = dx * dx, dy * dy
    mu = np.array(
        [
            float(xs.size),
            float(dx2.sum()),
            float(np.dot(dx, dy)),
            float(dy2.sum()),
            float(np.dot(dx2, dx)),
            float(np.dot(dx2, dy)),
            float(np.dot(dx, dy2)),
            float(np.dot(dy2, dy)),
        ]
    )
    return mu, (float(cx), float(cy))


def _features(mu: np.ndarray, centroid: tuple[float, float]) -> ShapeMoments:
    v = _invariants(mu)
    return ShapeMoments(
        area=float(mu[0]),
        centroid=centroid,
        hu=tuple(float(h) for h in v[:7]),  # type: ignore[arg-type]
        orientation_deg=float(v[7]) + 0.0,  # no -0.0
        eccentricity=float(v[8]),
    )


@compiled
def _invariants(mu):
    """Hu's seven invariants, the orientation (degrees) and the eccentricity of the
    central moments ``mu``, in that order (a frame's moments: compiled)."""
    m00 = mu[0]
    # Normalised central moments: mu_pq / mu_00^((p + q) / 2 + 1) (not eq. 4.13).
    n20, n11, n02 = mu[1] / m00**2.0, mu[2] / m00**2.0, mu[3] / m00**2.0
    n30, n21, n12, n03 = mu[4] / m00**2.5, mu[5] / m00**2.5, mu[6] / m00**2.5, mu[7] / m00**2.5
    t0, t1 = n30 + n12, n21 + n03
    q0, q1 = n30 - 3 * n12, 3 * n21 - n03
    out = np.empty(9)
    out[0] = n20 + n02
    out[1] = (n20 - n02) ** 2 + 4 * n11 * n11
    out[2] = q0 * q0 + q1 * q1
    out[3] = t0 * t0 + t1 * t1
    out[4] = q0 * t0 * (t0 * t0 - 3 * t1 * t1) + q1 * t1 * (3 * t0 * t0 - t1 * t1)
    out[5] = (n20 - n02) * (t0 * t0 - t1 * t1) + 4 * n11 * t0 * t1
    out[6] = q1 * t0 * (t0 * t0 - 3 * t1 * t1) - q0 * t1 * (3 * t0 * t0 - t1 * t1)
    a, b, c = mu[1] / m00, mu[2] / m00, mu[3] / m00
    # Image y points down, so atan2's angle runs clockwise on screen: negate it.
    angle = -0.5 * math.degrees(math.atan2(2 * b, a - c))
    if angle <= -90.0:
        angle += 180.0
    out[7] = angle
    half_sum, half_gap = (a + c) / 2, math.hypot((a - c) / 2, b)
    big, small = half_sum + half_gap, max(half_sum - half_gap, 0.0)
    out[8] = math.sqrt(max(0.0, 1.0 - small / big)) if big > 0 else 0.0
    return out


def _hu_vector(h: object, name: str) -> np.ndarray:
    if h is None:
        raise ValueError(f"{name} must be 7 Hu invariants, got None")
    try:
        arr = np.asarray(h, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be 7 Hu invariants (numbers): {exc}") from exc
    if arr.size != 7:
        raise ValueError(f"{name} must hold 7 Hu invariants, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (found NaN or inf)")
    return arr
