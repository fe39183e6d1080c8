"""The reference pad: what the H looks like, measured once from a top-down picture."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from pipeline.edgefit import EdgeModel
from pipeline.edges import refine_polygon, surround_ratio
from pipeline.moments import shape_moments
from pipeline.preprocess import binarize, check_image
from pipeline.shapes import corner_angles, polygon_corners, regions

H_CORNERS = 12
_WORK_MAX = 1024  # pictures are measured at up to this many pixels a side


@dataclass(frozen=True, eq=False)
class Reference:
    """A helipad's H (and its side bars) in pad metres.

    Built by :meth:`from_image` from a top-down picture cropped to the pad's
    outer edge. ``corners_m``: the H's 12 corners in the pad frame (origin at
    the pad centre, +x to the picture's right, +y to its top), in contour
    order, the order every detection reports. ``bars_m``: other straight-sided
    white marks of the pad (the seed's side bars), 4 corners each, used to
    refine the pose over the whole pad. ``symmetric``: the pad looks the same
    after a 180 degree turn.
    """

    pad_size_m: float
    pad_height_m: float
    image: np.ndarray
    mask: np.ndarray
    corners_px: np.ndarray
    corners_m: np.ndarray
    bars_m: tuple[np.ndarray, ...]
    outline_m: np.ndarray | None
    hu: tuple[float, ...]
    orientation_deg: float
    eccentricity: float
    solidity: float
    symmetric: bool
    surround_ratio: float

    @cached_property
    def edge_model(self) -> EdgeModel:
        """Every straight side of the pad: the H's, the bars' and the outline's."""
        marks = [(self.corners_m, True)] + [(bar, True) for bar in self.bars_m]
        if self.outline_m is not None:
            marks.append((self.outline_m, False))
        return EdgeModel.from_polygons(marks)

    @property
    def h_size_m(self) -> float:
        """The H's extent (largest side of its bounding box), metres."""
        span = self.corners_m.max(axis=0) - self.corners_m.min(axis=0)
        return float(span.max())

    @classmethod
    def from_image(cls, image_bgr: np.ndarray, pad_size_m: float) -> Reference:
        """Measure the H on a top-down picture of the pad whose width is ``pad_size_m``.

        Raises ValueError saying what is wrong when the picture holds no usable H.

        Examples
        --------
        >>> from pipeline.render import make_pad_image
        >>> ref = Reference.from_image(make_pad_image(800), 0.55)
        >>> ref.corners_m.shape, ref.symmetric
        ((12, 2), True)
        """
        image = check_image(image_bgr, "image_bgr")
        try:
            pad_size_m = float(pad_size_m)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"pad_size_m must be a number, got {pad_size_m!r}") from exc
        if not math.isfinite(pad_size_m) or pad_size_m <= 0:
            raise ValueError(f"pad_size_m must be a positive number of metres, got {pad_size_m}")
        h_img, w_img = image.shape[:2]
        scale = min(1.0, _WORK_MAX / max(h_img, w_img))
        work = image
        if scale < 1.0:
            size = (round(w_img * scale), round(h_img * scale))
            work = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        # A top-down picture has even light, and its H may be hundreds of pixels
        # wide: a global threshold keeps its strokes whole.
        binary = binarize(work, "otsu")
        wh, ww = binary.mask.shape
        area = float(wh * ww)
        found = regions(binary.mask, min_area=0.002 * area, max_area=0.6 * area)
        if not found:
            raise ValueError(
                "no white shape found on the picture: expected a white H on a dark pad, "
                "cropped to the pad's outer edge"
            )
        h_region, h_poly, reasons = _pick_h(found, ww, wh)
        if h_region is None:
            raise ValueError(
                f"no usable H on the picture: {len(found)} white shape(s) found, none is an H "
                f"({'; '.join(reasons[:3])})"
            )
        refined = refine_polygon(binary.smooth, h_poly)
        if refined is not None:
            h_poly = refined[0]
        bars = []
        for r in found:
            if r is h_region or r.solidity < 0.93 or r.area < 0.004 * area:
                continue
            quad = polygon_corners(r.contour, 4)
            if quad is None:
                continue
            ang = corner_angles(quad)
            if np.all(np.abs(ang - 90.0) < 12.0):
                rq = refine_polygon(binary.smooth, quad)
                bars.append(rq[0] if rq is not None else quad)
        to_m = _pixels_to_metres(ww, wh, pad_size_m)
        corners_m = to_m(h_poly)
        bars_m = tuple(to_m(b) for b in bars)
        # The picture's edge is the board's outer edge when the board is dark
        # there; it then refines the pose over the pad's full width.
        rim = np.concatenate(
            [binary.mask[0], binary.mask[-1], binary.mask[:, 0], binary.mask[:, -1]]
        )
        outline = np.array([[-0.5, -0.5], [ww - 0.5, -0.5], [ww - 0.5, wh - 0.5], [-0.5, wh - 0.5]])
        outline_m = to_m(outline) if np.mean(rim > 0) < 0.02 else None
        mom = shape_moments(h_region.contour)
        # How dark the pad is right around the H, relative to the H: frames must
        # show the same (a look-alike painted on a floor does not).
        h_span_px = float(np.ptp(h_poly, axis=0).max())
        surround = surround_ratio(binary.smooth, h_poly, max(2.5, 0.03 * h_span_px))
        corners_px = (h_poly + 0.5) / scale - 0.5
        return cls(
            pad_size_m=pad_size_m,
            pad_height_m=pad_size_m * wh / ww,
            image=image,
            mask=binary.mask,
            corners_px=corners_px,
            corners_m=corners_m,
            bars_m=bars_m,
            outline_m=outline_m,
            hu=tuple(float(v) for v in mom.hu),
            orientation_deg=float(mom.orientation_deg),
            eccentricity=float(mom.eccentricity),
            solidity=float(h_region.solidity),
            symmetric=_is_symmetric(corners_m, bars_m),
            surround_ratio=surround,
        )

    def to_dict(self) -> dict:
        return {
            "pad_size_m": self.pad_size_m,
            "pad_height_m": self.pad_height_m,
            "image_size": [int(self.image.shape[1]), int(self.image.shape[0])],
            "corners_m": self.corners_m.tolist(),
            "corners_px": self.corners_px.tolist(),
            "bars_m": [b.tolist() for b in self.bars_m],
            "outline_m": None if self.outline_m is None else self.outline_m.tolist(),
            "hu": list(self.hu),
            "orientation_deg": self.orientation_deg,
            "eccentricity": self.eccentricity,
            "solidity": self.solidity,
            "symmetric": self.symmetric,
            "surround_ratio": self.surround_ratio,
        }


def _pick_h(found, width: int, height: int):
    """The region nearest the picture's centre with the corners of a block H."""
    centre = np.array([width / 2.0, height / 2.0])
    reasons: list[str] = []
    best = (None, None, math.inf)
    for r in found:
        if not 0.35 <= r.solidity <= 0.92:
            reasons.append(f"a shape of solidity {r.solidity:.2f}")
            continue
        poly = polygon_corners(r.contour, H_CORNERS)
        if poly is None:
            reasons.append("a shape without 12 corners")
            continue
        if not _h_topology(corner_angles(poly)):
            reasons.append("a 12-cornered shape whose corners are not those of an H")
            continue
        dist = float(np.linalg.norm(r.contour.mean(axis=0) - centre))
        if dist < best[2]:
            best = (r, poly, dist)
    return best[0], best[1], reasons


# Going round a block H: two outer corners, the two inner corners where the
# crossbar meets the legs, four outer corners, two inner corners, two outer.
_H_CONCAVE = np.array([0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0], bool)


def _h_topology(angles: np.ndarray) -> bool:
    """Whether 12 corner angles run like an H's (a '+' has 12 right angles too)."""
    convex = np.abs(angles - 90.0) < 20.0
    concave = np.abs(angles - 270.0) < 20.0
    if not np.all(convex | concave):
        return False
    return any(np.array_equal(concave, np.roll(_H_CONCAVE, k)) for k in range(12))


def _pixels_to_metres(width: int, height: int, pad_size_m: float):
    m_per_px = pad_size_m / width

    def convert(px: np.ndarray) -> np.ndarray:
        px = np.asarray(px, np.float64)
        x = (px[:, 0] + 0.5 - width / 2.0) * m_per_px
        y = (height / 2.0 - (px[:, 1] + 0.5)) * m_per_px
        return np.column_stack([x, y])

    return convert


def _is_symmetric(corners_m: np.ndarray, bars_m: tuple[np.ndarray, ...]) -> bool:
    """Whether a 180 degree turn about the pad centre maps every corner onto one."""
    tol = 0.03 * float(np.ptp(corners_m, axis=0).max())
    pts = np.vstack([corners_m, *bars_m]) if bars_m else corners_m
    turned = -pts
    d = np.linalg.norm(turned[:, None, :] - pts[None, :, :], axis=2)
    return bool(np.all(d.min(axis=1) < tol))
