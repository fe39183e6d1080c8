"""A candidate's corner pattern as a binary vector that an RBM can learn.

Why not the seed's encoding: the dissertation binarised the corners' raw pixel
coordinates. Those bits are dominated by where the H sits in the frame, how far
away it is and how it is turned, so two views of the same H share almost no bits
and a model has to learn every position, size and heading separately; its 36 %
error says as much. What tells an H from a look-alike is the *shape* of the
corner pattern, so the encoding removes everything else first:

1. The image's y axis points down and the pad's up, so y is mirrored: a view
   from above is then a proper rotation (plus scale and shift) of the pad.
2. Centroid of the 12 ordered corners to the origin, scale by the square root
   of the corner polygon's area (translation and scale gone).
3. The rotation that best lays the corners onto the reference's own normalised
   corners (2-D Kabsch, no reflection) turns the candidate upright. Only a
   similarity is removed, never an affine map: a stretched or sheared H (a
   mis-proportioned H, which the pipeline's homography gate cannot see) keeps
   its distortion in the code.
4. The normalised corners are splatted as small discs on a ``corner_grid``
   square grid, and the contour, put through the same map, is filled on a
   coarser ``shape_grid`` grid (broken legs, missing bars, extra blobs show
   there even when the 12 corners look right).
5. What a coarse grid cannot resolve, a few per cent of stretch, is what tells
   a mis-proportioned H from a tilted view of the right one (a 20 degree tilt
   stretches by 6 %, a wrong aspect ratio by 25 % and more). So the affine map
   that best takes the reference's corners onto the candidate's is measured
   too: its anisotropy log(s1 / s2) (singular values) and the RMS of what no
   affine map explains (wrong leg or bar proportions) are appended as
   thermometer codes (unit i is on when the value exceeds the i-th of evenly
   spaced levels), so that a small change flips a few bits, not a whole pattern.
   Perspective also stretches a real H's image (up to ~0.25 in log anisotropy
   for a close, tilted pad), so with the camera's intrinsics the same measure
   is taken once more on the homography from the reference's corners to the
   candidate's *normalised* image rays: its first two columns are r1, r2 of
   a rotation (equal length, orthogonal) for any real view of the right H,
   whatever the tilt, and are not for a stretched one. That reading is
   exact for large H's and noisy for small ones, so the candidate's size
   (log pixel area, another thermometer) goes in as well: it tells the
   network which of the two readings to trust. Finally, the corners are
   mapped back through the best homography onto the reference's layout and
   each one's offset from where it should be (what no view explains: thinner
   legs, a lower bar) is coded the same way.
6. 180 degree symmetry: a symmetric H's corner list can start at either end
   (corner ``i`` and ``i + 6`` swap under a half turn), which turns the aligned
   pattern by 180 degrees. For a symmetric reference both rasters are OR-ed
   with their own half turn, so both starts give the same code.

The rasters and the affine readings are invariant to translation, scale and
rotation of the candidate in the image, and to the half-turn ambiguity; the
perspective reading and the size are physical (they change when the camera
moves, not when it rolls about its optical axis). Near-misses overlap
because the discs cover a few cells.

Examples
--------
>>> import numpy as np
>>> from pipeline.render import PadGeometry
>>> corners = PadGeometry().h_corners_m
>>> enc = Encoder.for_corners(corners)
>>> px = corners * [400, -400] + [319.5, 239.5]  # a pad seen from above, in pixels
>>> code = enc.encode(px, px)
>>> turned = np.roll(px, 6, axis=0)  # the list starting at the other end
>>> code.shape, code.dtype.name, bool(np.array_equal(code, enc.encode(turned, turned)))
((1072,), 'float32', True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.camera import Camera

CORNER_GRID = 24
SHAPE_GRID = 16
ANISOTROPY_UNITS = 32
ANISOTROPY_MAX = 0.5  # log(s1 / s2); a 20 degree tilt gives ~0.06, a 1.25 stretch 0.22
RESIDUAL_UNITS = 16
RESIDUAL_MAX = 0.16  # RMS of the non-affine part, in units of sqrt(area)
METRIC_UNITS = 32
METRIC_MAX = 0.8  # log(s1 / s2) of the rays' homography; exactly 0 for a noiseless true view
OFFSET_UNITS = 12  # per coordinate of each (folded) corner
OFFSET_MAX = 0.2  # +- normalised units: where the rectified corners sit off the reference's
SIZE_UNITS = 16
SIZE_RANGE = (2.0, 4.5)  # log10 pixel area of the corner polygon
DISC_RADIUS_CELLS = 1.25  # a corner lights the cells within this many cell widths
EXTENT_MARGIN = 1.45  # grid half-width, as a multiple of the reference's largest coordinate
_SUBPIXEL_BITS = 4  # cv2.fillPoly fixed-point precision


def polygon_area(points: np.ndarray) -> float:
    """Absolute area of a closed polygon (shoelace)."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def normalise(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre on the mean and scale by sqrt(polygon area): (normalised, centre, scale)."""
    centre = points.mean(axis=0)
    area = polygon_area(points)
    if not math.isfinite(area) or area <= 0.0:
        raise ValueError("corners_px must span a polygon with positive area")
    scale = 1.0 / math.sqrt(area)
    return (points - centre) * scale, centre, scale


def kabsch_rotation(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """The 2x2 rotation R (no reflection) minimising sum |R src_i - dst_i|^2."""
    cross = float(np.sum(src[:, 0] * dst[:, 1] - src[:, 1] * dst[:, 0]))
    dot = float(np.sum(src * dst))
    a = math.atan2(cross, dot)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True, eq=False)
class Encoder:
    """Turns (ordered corners, contour) in pixels into a binary code.

    ``template``: the reference's corners, normalised (centroid 0, unit area),
    in its own contour order; ``extent``: the grid's half-width in normalised
    units; ``symmetric``: fold the half-turn ambiguity (see module docstring);
    ``camera``: the intrinsics the pixels are taken with, unless ``encode`` is
    given others.
    """

    template: np.ndarray
    extent: float
    symmetric: bool
    camera: Camera
    corner_grid: int = CORNER_GRID
    shape_grid: int = SHAPE_GRID

    @classmethod
    def for_corners(
        cls,
        corners_m: np.ndarray,
        *,
        symmetric: bool = True,
        camera: Camera | None = None,
        corner_grid: int = CORNER_GRID,
        shape_grid: int = SHAPE_GRID,
    ) -> Encoder:
        """An encoder for a reference whose H corners (pad metres, y up) are ``corners_m``."""
        pts = _check_points(corners_m, "corners_m", min_count=4)
        for name, g in (("corner_grid", corner_grid), ("shape_grid", shape_grid)):
            if isinstance(g, bool) or not isinstance(g, int) or not 4 <= g <= 128:
                raise ValueError(f"{name} must be an integer in 4..128, got {g!r}")
        template, _, _ = normalise(pts)
        if symmetric and len(template) % 2 == 0:
            # Make the measured layout exactly half-turn symmetric, so that both
            # starts of the corner list give bit-identical codes.
            template = 0.5 * (template - np.roll(template, len(template) // 2, axis=0))
        extent = EXTENT_MARGIN * float(np.abs(template).max())
        if camera is None:
            camera = Camera.from_fov(640, 480, 60.0)
        if not isinstance(camera, Camera):
            raise ValueError(f"camera must be a pipeline.Camera, got {type(camera).__name__}")
        return cls(template, extent, bool(symmetric), camera, corner_grid, shape_grid)

    @property
    def size(self) -> int:
        """Number of visible units."""
        return sum(n for _, n in self._layout())

    @property
    def blocks(self) -> dict[str, slice]:
        """Where each part of the code lies: corners, shape, anisotropy, residual, metric, size."""
        out, start = {}, 0
        for name, n in self._layout():
            out[name] = slice(start, start + n)
            start += n
        return out

    def _layout(self) -> list[tuple[str, int]]:
        return [
            ("corners", self.corner_grid**2),
            ("shape", self.shape_grid**2),
            ("anisotropy", ANISOTROPY_UNITS),
            ("residual", RESIDUAL_UNITS),
            ("metric", METRIC_UNITS),
            ("offsets", self._offset_count() * 2 * OFFSET_UNITS),
            ("size", SIZE_UNITS),
        ]

    def _offset_count(self) -> int:
        n = len(self.template)
        return n // 2 if self.symmetric and n % 2 == 0 else n

    def align(
        self, corners_px: np.ndarray, contour_px: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Corners and contour mapped by the similarity that lays them onto the template."""
        corners = _check_points(corners_px, "corners_px", min_count=len(self.template))
        if len(corners) != len(self.template):
            raise ValueError(
                f"corners_px must hold {len(self.template)} corners, got {len(corners)}"
            )
        contour = _check_points(contour_px, "contour_px", min_count=3)
        flip = np.array([1.0, -1.0])  # image y down -> pad y up
        norm, centre, scale = normalise(corners * flip)
        R = kabsch_rotation(norm, self.template)
        return norm @ R.T, ((contour * flip - centre) * scale) @ R.T

    def encode(
        self, corners_px: np.ndarray, contour_px: np.ndarray, camera: Camera | None = None
    ) -> np.ndarray:
        """The binary code (float32 0/1 vector of length :attr:`size`).

        Parameters
        ----------
        corners_px : (N, 2) the candidate's corners in pixels, in the reference's
            order (as ``pipeline.candidates`` locates them).
        contour_px : (M, 2) the candidate's boundary in pixels.
        camera : the intrinsics of the image the pixels are in (default: the
            encoder's ``camera``).
        """
        if camera is None:
            camera = self.camera
        elif not isinstance(camera, Camera):
            raise ValueError(f"camera must be a pipeline.Camera, got {type(camera).__name__}")
        corners, contour = self.align(corners_px, contour_px)
        dots = self._corner_raster(corners)
        shape = self._shape_raster(contour)
        if self.symmetric:
            dots |= np.rot90(dots, 2)
            shape |= np.rot90(shape, 2)
        aniso, rest = self.distortion(corners)
        return np.concatenate(
            [
                dots.ravel(),
                shape.ravel(),
                _thermometer(aniso, ANISOTROPY_MAX, ANISOTROPY_UNITS),
                _thermometer(rest, RESIDUAL_MAX, RESIDUAL_UNITS),
                _thermometer(self.metric_anisotropy(corners_px, camera), METRIC_MAX, METRIC_UNITS),
                *(
                    _thermometer(v + OFFSET_MAX, 2 * OFFSET_MAX, OFFSET_UNITS)
                    for v in self.offsets(corners_px).ravel()
                ),
                _thermometer(
                    math.log10(max(polygon_area(np.asarray(corners_px, np.float64)), 1.0))
                    - SIZE_RANGE[0],
                    SIZE_RANGE[1] - SIZE_RANGE[0],
                    SIZE_UNITS,
                ),
            ]
        ).astype(np.float32)

    def metric_anisotropy(self, corners_px: np.ndarray, camera: Camera) -> float:
        """log(s1 / s2) of the first two columns of the homography template -> image rays.

        Zero for a noiseless view of the reference's H from any pose; the log of
        the stretch for a stretched H (see the module docstring).
        """
        pts = np.asarray(corners_px, np.float64).reshape(-1, 1, 2)
        rays = cv2.undistortPoints(pts, camera.K, camera.dist).reshape(-1, 2)
        H, _ = cv2.findHomography(self.template, rays, 0)
        if H is None or not np.all(np.isfinite(H)):
            return math.inf
        s = np.linalg.svd(H[:, :2], compute_uv=False)
        return math.log(s[0] / s[1]) if s[1] > 1e-12 * s[0] else math.inf

    def offsets(self, corners_px: np.ndarray) -> np.ndarray:
        """Where each corner lies off the reference's once the best homography is undone.

        The candidate's corners are mapped back into the template's frame by the
        inverse of the homography template -> candidate; what is left is corner
        noise for the right H and a structured pattern for an H with other leg
        or bar proportions (which no homography explains). For a symmetric
        reference, corners i and i + n/2 are folded together ((d_i - d_(i+n/2)) / 2),
        which does not change when the corner list starts at the other end.
        Returns (k, 2), k = n/2 (symmetric) or n.
        """
        pts = np.asarray(corners_px, np.float64)
        H, _ = cv2.findHomography(self.template, pts, 0)
        n = len(self.template)
        try:
            back = cv2.perspectiveTransform(pts.reshape(-1, 1, 2), np.linalg.inv(H))
            dev = back.reshape(-1, 2) - self.template
        except (np.linalg.LinAlgError, cv2.error, ValueError):
            dev = np.full((n, 2), np.inf)
        if not np.all(np.isfinite(dev)):
            dev = np.full((n, 2), OFFSET_MAX * 10)  # no homography: off the scale
        if self._offset_count() < n:
            half = n // 2
            return 0.5 * (dev[:half] - dev[half:])
        return dev

    def distortion(self, aligned: np.ndarray) -> tuple[float, float]:
        """(log anisotropy, non-affine RMS) of the affine fit template -> aligned corners."""
        X = np.column_stack([self.template, np.ones(len(self.template))])
        coef, *_ = np.linalg.lstsq(X, aligned, rcond=None)
        s = np.linalg.svd(coef[:2], compute_uv=False)
        aniso = math.log(s[0] / s[1]) if s[1] > 1e-12 else math.inf
        rest = float(np.sqrt(np.mean(np.sum((X @ coef - aligned) ** 2, axis=1))))
        return aniso, rest

    def encode_many(
        self, items: list[tuple[np.ndarray, np.ndarray]], camera: Camera | None = None
    ) -> np.ndarray:
        """Codes of many (corners, contour) pairs, (len(items), size) float32."""
        out = np.zeros((len(items), self.size), np.float32)
        for i, (corners, contour) in enumerate(items):
            out[i] = self.encode(corners, contour, camera)
        return out

    def _cells(self, pts: np.ndarray, grid: int) -> np.ndarray:
        """Continuous cell coordinates (cell centres at integers, row 0 at +y)."""
        u = (pts[:, 0] + self.extent) / (2 * self.extent) * grid - 0.5
        v = (self.extent - pts[:, 1]) / (2 * self.extent) * grid - 0.5
        return np.column_stack([u, v])

    def _corner_raster(self, corners: np.ndarray) -> np.ndarray:
        g = self.corner_grid
        cells = self._cells(corners, g)
        idx = np.arange(g, dtype=np.float64)
        du = idx[None, None, :] - cells[:, 0, None, None]
        dv = idx[None, :, None] - cells[:, 1, None, None]
        return np.any(du**2 + dv**2 <= DISC_RADIUS_CELLS**2, axis=0)

    def _shape_raster(self, contour: np.ndarray) -> np.ndarray:
        g = self.shape_grid
        cells = self._cells(contour, g)
        # Far-away points would overflow fillPoly's fixed point; the grid is tiny anyway.
        cells = np.clip(cells, -4.0 * g, 5.0 * g)
        img = np.zeros((g, g), np.uint8)
        fixed = np.rint(cells * (1 << _SUBPIXEL_BITS)).astype(np.int32)
        cv2.fillPoly(img, [fixed.reshape(-1, 1, 2)], 1, lineType=cv2.LINE_8, shift=_SUBPIXEL_BITS)
        return img.astype(bool)


def _thermometer(value: float, top: float, units: int) -> np.ndarray:
    """``units`` bits, bit i on when value > (i + 0.5) * top / units."""
    levels = (np.arange(units) + 0.5) * (top / units)
    return value > levels


def _check_points(points: np.ndarray, name: str, *, min_count: int) -> np.ndarray:
    try:
        arr = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be an (N, 2) array of numbers") from exc
    if arr.ndim == 3 and arr.shape[1] == 1:
        arr = arr[:, 0, :]  # OpenCV's (N, 1, 2) contours
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must be an (N, 2) array, got shape {arr.shape}")
    if len(arr) < min_count:
        raise ValueError(f"{name} must hold at least {min_count} points, got {len(arr)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return arr
