"""The reference pad: what the H looks like, learned once from a top-down picture."""

from __future__ import annotations

import dataclasses
import heapq
import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.colour import Projection, contrast, learn_projection
from pipeline.edgefit import EdgeModel
from pipeline.edges import refine_polygon
from pipeline.hfit import HFit, fit_h, h_deformation
from pipeline.homography_fit import Deformation
from pipeline.marks import (
    HALF_TURN_TOL,
    Mark,
    band_beyond,
    find_marks,
    moved_by_half_turn,
    symmetric_marks,
)
from pipeline.moments import shape_moments
from pipeline.preprocess import (
    Binarized,
    binarize_channel,
    border_pixels,
    check_image,
    chroma_levels,
    log_light,
    tophat_rise,
)
from pipeline.shape_match import ShapeMatcher
from pipeline.strokes import Notches, notches
from pipeline.template import reference_pyramid

H_CORNERS = 12
RELIABLE_H_PX = 22.0  # an H this many pixels across is found in nearly every frame
SEARCH_WIDTH_PX = 640  # frames are searched this wide first (pipeline.frame)
# Frames are searched at their own resolution last (pipeline.frame); the range that buys
# was measured on frames up to this wide (bench --sweep altitude): wider ones count as it.
MEASURED_WIDTH_PX = 1280
# OpenCV's warps (the frames' template check) take pictures under 32767 px a side.
MAX_SIDE_PX = 16384
_WORK_MAX = 1024  # pictures are measured at up to this many pixels a side
_LEVELS = 9  # thresholds tried per channel between its 2nd and 98th percentiles
_MIN_H_AREA = 0.002  # of the picture: smaller marks are text or noise, not the pad's H
_MAX_H_AREA = 0.6
_LESSER_MIN_PX = 8  # a mark narrower than this (work pixels) is not read as an H
_MAX_LESSER_LOOKS = 64
_MAX_CUT_SHAPES = 32  # shapes cut by the picture's edge kept to tell of a cut H
# A region with this share of the H's area beyond its fitted block H (grown by a quarter
# of a leg) is the H run into another mark of its paint: serifs and rounded ends leave
# 0.00-0.03 of it, a ring the H's legs cross 0.30. Frames show the two as one shape,
# no H's: such a pad was found from afar by its board alone, never within 4 m of it.
_MAX_BEYOND_H = 0.15
_ROUND_TOL = 0.09  # a mark whose corners and sides lie this near (of its radius) a circle is round
MIN_BOARD_CHROMA = 20.0  # a board this far (BGR levels) from the grey of its lightness has a colour
_MAX_TOUCH_LOOKS = 8  # shapes not an H opened (thin marks cut off) to tell of a touching H
# Nor may another mark of its paint (this share of the H's area at least, not a serif)
# lie nearer the H than this share of the picture's width: a frame at gaps of 0.4 and 0.6 %
# found the pad in 1 and 11 of 20 views from 1.8-2.5 m (the two merged), at 1 %, 20 of 20.
_MIN_GAP = 0.008
_GAP_MARK_AREA = 0.02
_MIN_CONTRAST = 25.0  # H against its board on the learned channel, 0..255
# The picture's border is its board's edge when its levels spread this little (of the
# contrast): 0.01-0.02 on square boards and sheets, 0.09-0.35 on discs and paint on grass.
_BOARD_UNIFORMITY = 0.05


class RoundBoard(NamedTuple):
    """The H's board where it is round (`Reference.round_board`): its circle's centre
    and radius (pad metres), and which of the reference's marks it is; ``seen_m``: the
    radius it shows from afar, a banded rim's band included (`pipeline.marks.Mark`: a
    black hem between an orange disc and lighter concrete is the disc's side of both)."""

    centre_m: np.ndarray
    radius_m: float
    mark: int
    seen_m: float


@dataclass(frozen=True, eq=False)
class Reference:
    """A helipad's H (and its other straight marks) in pad metres.

    Built by :meth:`from_image` from a top-down picture cropped to the pad's
    outer edge. ``corners_m``: the H's 12 corners in the pad frame (origin at
    the pad centre, +x to the picture's right, +y to its top), in contour
    order, the order every detection reports: those of the block H under any
    serifs. ``marks``: the pad's other edges (the seed's side bars, rings, a
    disc's or a board's rim, stars: ``pipeline.marks``), which refine the pose
    over the whole pad and tell an asymmetric pad's heading. ``symmetric``:
    the pad looks the same after a 180 degree turn.
    ``projection``: the colour channel in which the H is bright and its board
    dark (frames are searched on it). ``contrast``: H minus board on that
    channel; ``light_contrast``: the same on the light's log scale
    (`pipeline.preprocess.log_light`). ``leg_fraction``: the thinner leg's width
    over the H's width.
    ``lesser_hs``: the corners of the smaller marks of the H's paint shaped as an H
    (the letter H of a "HELIPAD" painted beside it): where the pad's H is hidden, one
    of them may pass for it, the pad posed several times too far (`pipeline.find`).
    """

    pad_size_m: float
    pad_height_m: float
    image: np.ndarray
    mask: np.ndarray
    corners_px: np.ndarray
    corners_m: np.ndarray
    marks: tuple[Mark, ...]
    hu: tuple[float, ...]
    orientation_deg: float
    eccentricity: float
    solidity: float
    symmetric: bool
    projection: Projection
    contrast: float
    light_contrast: float
    leg_fraction: float
    channel: np.ndarray  # the picture on the learned channel (work resolution)
    channel_px_per_m: float
    paint_bgr: tuple[float, float, float]  # the H's colour on the picture (median)
    board_bgr: tuple[float, float, float]  # its board's, right around it
    lesser_hs: tuple[np.ndarray, ...] = ()  # smaller H's in its paint (12 corners, metres)
    slant_deg: float = 0.0  # how far its H's parallel sides converge (`_slant_deg`)

    def binarize(self, channel: np.ndarray, method: str) -> Binarized:
        """A frame's channel (`pipeline.preprocess.to_channel`) thresholded for this
        pad's H (``method``: one of `pipeline.preprocess.METHODS`)."""
        return binarize_channel(
            channel,
            method,
            dark=self.projection.inverted_luma,
            rise=tophat_rise(self.light_contrast),
        )

    @cached_property
    def edge_model(self) -> EdgeModel:
        """Every side of the pad: the H's and its other marks'."""
        return self._pad_model(hems=False)

    @cached_property
    def hemmed_rims(self) -> Deformation | None:
        """For `edge_model`'s fits: each rim with a band beyond it (a hem, see
        `pipeline.marks.band_beyond`) free to lie further out or in along the pad's
        radius, by about the band's width; None when no rim has one. The hem's far edge
        pushes the rim's out, by as much as a few tenths of a pixel: the rim then still
        tells where the pad lies and how it is turned, but not how large it is."""
        model = self.edge_model
        hemmed = [k for k, m in enumerate(self.marks) if m.rim and m.band_m > 0]
        if not hemmed:
            return None
        a = np.zeros((len(model.a_m), 2, len(hemmed)))
        b = np.zeros_like(a)
        for k, mark in enumerate(hemmed):
            on = model.polygon == mark + 1
            a[on, :, k], b[on, :, k] = _radial(model.a_m[on]), _radial(model.b_m[on])
        return Deformation(a, b, np.array([self.marks[k].band_m for k in hemmed]))

    @cached_property
    def polish_model(self) -> EdgeModel:
        """`edge_model` for a pose's last steps with the attitude known: a rim with a
        hem beyond it is fitted only where the hem is ``RIM_ALONE`` times as wide as
        a side needs (`edge_model` itself when no rim has one)."""
        return self.edge_model if self.hemmed_rims is None else self._pad_model(hems=True)

    def _pad_model(self, *, hems: bool) -> EdgeModel:
        """The H's and the marks' sides, the rims' hems told (``hems``) or not."""
        polys = [(self.corners_m, True)] + [(m.corners_m, m.bright) for m in self.marks]
        rims = {
            k + 1: m.band_m if hems or m.banded else 0.0 for k, m in enumerate(self.marks) if m.rim
        }
        return EdgeModel.from_polygons(polys, rims=rims)

    @cached_property
    def marks_model(self) -> EdgeModel | None:
        """The sides of the marks alone (None when the pad has none)."""
        if not self.marks:
            return None
        rims = {k: m.band_m if m.banded else 0.0 for k, m in enumerate(self.marks) if m.rim}
        return EdgeModel.from_polygons([(m.corners_m, m.bright) for m in self.marks], rims=rims)

    @cached_property
    def heading_model(self) -> EdgeModel | None:
        """`marks_model`'s sides of the marks that a half turn about the H's centre moves
        onto no mark (a triangle, stars above the H; a board the H sits off the centre
        of): only they tell which way round the pad lies. None when none does."""
        model = self.marks_model
        if model is None:
            return None
        tol = HALF_TURN_TOL * float(np.ptp(self.corners_m, axis=0).max())
        moved = np.flatnonzero(moved_by_half_turn(self.h_centre_m, self.marks, tol))
        keep = np.isin(model.polygon, moved)
        if not keep.any():
            return None
        return EdgeModel(
            model.a_m[keep],
            model.b_m[keep],
            model.bright[keep],
            model.polygon[keep],
            model.clearance_m[keep],  # (as among all the marks: their edges are there)
            model.curved[keep],
        )

    @cached_property
    def board_is_outline(self) -> bool:
        """Whether the picture's outer edge is its board's (a square board, a sheet:
        its border all one level on the learned channel), which tells a far pad
        (`pipeline.board_search`); not a disc on its floor, nor paint on grass."""
        ch = self.channel.astype(np.float32)
        width = max(2, min(ch.shape) // 50)
        if float(border_pixels(ch, width).std()) > _BOARD_UNIFORMITY * self.contrast:
            return False
        # (and the board's colour, for a coloured board: an orange disc cropped to its
        # width on dark grey is one level with the grey on the channel)
        weights = self.board_chroma
        if weights is None:
            return True
        work = cv2.resize(self.image, ch.shape[::-1], interpolation=cv2.INTER_AREA)
        border = float(np.median(border_pixels(chroma_levels(work, weights), width)))
        return border >= 0.5 * float(np.dot(weights, self.board_bgr))

    @cached_property
    def outline_bright(self) -> bool:
        """Whether the board the picture's edge outlines is on the H's side of the
        threshold that shapes the H (a white sheet around a dark octagon): in frames it
        is a mark of the H's polarity, not a hole."""
        return self.board_is_outline and float(np.median(border_pixels(self.mask, 2))) > 0.0

    @cached_property
    def round_board(self) -> RoundBoard | None:
        """The H's board where it is round: the largest mark around the H that is a
        circle (or near one: an octagon's sides' middles lie 8 % within its corners) and
        dark inside on the channel, as the H's board is, or the board's rim (a disc's
        rim, an octagon printed on paper, the disc a ring holds). From afar it shows as
        an ellipse, which tells the pad as a square board's outline does
        (`pipeline.board_search`). A faint rim only on a coloured board, whose outline is
        looked for on its colour too."""
        found = None
        for k, mark in enumerate(self.marks):
            pts = mark.corners_m
            if (mark.bright and not mark.rim) or len(pts) < 8:
                continue
            if mark.faint and self.board_chroma is None:
                continue
            centre = pts.mean(axis=0)
            # (the sides' middles too: a polygon's corners alone lie on its circle)
            mids = 0.5 * (pts + np.roll(pts, -1, axis=0))
            radii = np.hypot(*(np.vstack([pts, mids]) - centre).T)
            radius = float(np.hypot(*(pts - centre).T).mean())
            if float(np.abs(radii - radius).max()) > _ROUND_TOL * radius:
                continue
            if float(np.hypot(*(self.corners_m - centre).T).max()) >= radius:
                continue  # (the H reaches past it: it is no board around the H)
            if found is None or radius > found.radius_m:
                found = RoundBoard(
                    centre, radius, k, radius + (mark.band_m if mark.banded else 0.0)
                )
        return found

    @cached_property
    def ring_cut(self) -> float | None:
        """Where an H ringed in its own paint is cut from its ring (the innermost such
        ring): a radius between the H's farthest corner and the ring's inside, over the
        ring's outer radius; None where no ring of the H's paint is round about the H.
        From afar the blur joins the H's tips to it (icao_circle's at 90 m and more at
        640 x 480: 1.5 px between them), and the two make one region that is no H
        (`pipeline.ring_cut`)."""
        centre = self.h_centre_m
        reach = float(np.hypot(*(self.corners_m - centre).T).max())
        best: tuple[float, float] | None = None  # (the ring's outer radius, the cut's)
        for ring in (m for m in self.marks if m.bright and not m.rim):
            outer = _round_radius(ring.corners_m, centre)
            if outer is None or outer <= reach or (best is not None and outer >= best[0]):
                continue
            # (its inside: the largest mark of the board's level within it)
            insides = [
                r
                for m in self.marks
                if not m.bright
                and (r := _round_radius(m.corners_m, centre)) is not None
                and reach < r < outer
            ]
            if insides:
                best = (outer, 0.5 * (reach + max(insides)))
        return None if best is None else best[1] / best[0]

    @cached_property
    def board_chroma(self) -> np.ndarray | None:
        """The board's own colour apart from its lightness: the unit BGR weights of its
        chroma (summing to 0, so that a grey of any lightness reads 0 on them and the
        board its chroma's size), when it has one (``MIN_BOARD_CHROMA``); None for a
        grey or white board, whose rim only lightness tells. A blue board on grass
        stands out there, where on the H's channel (white against blue: the blue dark,
        the grass no lighter) it barely steps (`pipeline.preprocess.chroma_levels`)."""
        return _chroma_weights(self.board_bgr)

    @property
    def outline_share(self) -> float | None:
        """How much of the picture the board's rim spans (its box over the picture's, the
        lesser of width and height), or None where no rim stands apart from what lies
        beyond it. Under 1, the picture shows more than the pad: a floor around a disc
        cropped to its width reads 0.97-1.0, and a square pad's picture taken with the
        ground around it, less. The pad's size is the picture's all the same, so if it
        is the board's, every distance comes that share short."""
        rims = [m.corners_m for m in self.marks if m.rim]
        if not rims:
            return None
        span = np.ptp(max(rims, key=lambda c: float(np.ptp(c, axis=0).prod())), axis=0)
        return float(min(span[0] / self.pad_size_m, span[1] / self.pad_height_m))

    @property
    def pad_over_h(self) -> float:
        """The pad's width over its H's: how far around a mark the size of the H
        the pad reaches."""
        return self.pad_size_m / self.h_size_m

    @property
    def painted_marks(self) -> bool:
        """Whether the pad shows marks in the H's paint (bars, rings, stars) besides
        its board's rim: what makes its pattern other than an H's on a plain ground."""
        return any(m.bright for m in self.marks)

    @cached_property
    def pose_points_m(self) -> np.ndarray:
        """The pad's points a pose is fitted to: the H's corners and the marks' vertices."""
        return np.vstack([self.corners_m, *(m.corners_m for m in self.marks)])

    @cached_property
    def notches(self) -> Notches:
        """Where a located H's notches are read (`pipeline.strokes.notch_fill`)."""
        return notches(self.corners_m, self.is_paint)

    def is_paint(self, points_m: np.ndarray) -> np.ndarray:
        """Whether the reference picture shows the H's paint (the H or a mark of its
        colour) at each pad point (N x 2 metres); points off the picture are not."""
        h, w = self.mask.shape
        pts = np.asarray(points_m, np.float64).reshape(-1, 2)
        u = np.round(pts[:, 0] * self.channel_px_per_m + w / 2.0 - 0.5).astype(int)
        v = np.round(h / 2.0 - pts[:, 1] * self.channel_px_per_m - 0.5).astype(int)
        inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
        out = np.zeros(len(pts), bool)
        out[inside] = self.mask[v[inside], u[inside]] > 0
        return out

    @cached_property
    def lesser_h_maps(self) -> tuple[np.ndarray, ...]:
        """Affine maps (3 x 3, pad metres -> pad metres) that put the H's corners on
        each of ``lesser_hs``: the two likeliest readings of each, its 12 corners
        taken from the two starts that fit best (an H read half a turn round fits
        about as well)."""
        src = np.column_stack([self.corners_m, np.ones(len(self.corners_m))])
        out = []
        for corners in self.lesser_hs:
            fits = []
            for shift in range(len(corners)):
                dst = np.roll(corners, -shift, axis=0)
                A, *_ = np.linalg.lstsq(src, dst, rcond=None)
                fits.append((float(np.sum((src @ A - dst) ** 2)), A))
            for _, A in sorted(fits, key=lambda f: f[0])[:2]:
                out.append(np.vstack([A.T, [0.0, 0.0, 1.0]]))
        return tuple(out)

    @cached_property
    def h_centre_m(self) -> np.ndarray:
        """The mean of the H's corners (pad metres)."""
        return self.corners_m.mean(axis=0)

    @cached_property
    def h_edges(self) -> EdgeModel:
        """The H's own sides: what a frame must show for a detection."""
        return EdgeModel.from_polygons([(self.corners_m, True)])

    @cached_property
    def h_deformation(self) -> Deformation:
        """How the H in view may differ from this picture's (its strokes' widths),
        fitted with its homography (``pipeline.hfit.h_deformation``)."""
        return h_deformation(self.corners_m) or Deformation.none(len(self.corners_m))

    @cached_property
    def shape(self) -> ShapeMatcher:
        """The H's outline for affine-invariant comparison with a frame's regions."""
        return ShapeMatcher.from_polygon(self.corners_m, symmetric=self.symmetric)

    @cached_property
    def template_pyramid(self) -> tuple[np.ndarray, ...]:
        """The picture and its learned channel at halving resolutions, for comparing
        frames with it."""
        h, w = self.channel.shape[:2]
        picture = self.image
        if picture.shape[:2] != (h, w):
            picture = cv2.resize(picture, (w, h), interpolation=cv2.INTER_AREA)
        return reference_pyramid(picture, self.channel)

    def reliable_altitude_m(self, camera: Camera, min_h_px: float = RELIABLE_H_PX) -> float:
        """The height up to which this pad's H spans ``min_h_px`` of ``camera``'s own
        pixels (a camera over ``MEASURED_WIDTH_PX`` wide counted as that wide), looking
        straight down: where missions can expect to find the pad.

        On the altitude sweep's frames the default pad is found in every frame up to
        16 m at 640 x 480 and 24 m at 1280 x 720, where its H spans 9.5 and 12.6 px.
        Where their H's span 22 px (20 frames a design and camera, the attitude hint
        given), every bench design's pad was found in 20, but red_on_black's in 19 at
        1280 x 720 and grass_paint's (an H painted on grass, with no board) in 16 at
        both, 18-19 at 28 px. At 1920 x 1080 an H of thin strokes at 28 px was found in
        14 of 16 frames (16 at 1280 x 720): a frame that wide is enlarged a third, not
        doubled (`pipeline.frame`), hence wider cameras counted as 1280 px.

        >>> from pipeline.render import make_pad_image
        >>> ref = Reference.from_image(make_pad_image(400), 0.55)
        >>> round(ref.reliable_altitude_m(Camera.from_fov(640, 480, 60.0)), 1)
        6.9
        >>> round(ref.reliable_altitude_m(Camera.from_fov(1280, 720, 60.0)), 1)
        13.9
        """
        fx = camera.fx * min(1.0, MEASURED_WIDTH_PX / camera.width)
        return fx * self.h_size_m / min_h_px

    @property
    def h_size_m(self) -> float:
        """The H's extent (largest side of its bounding box), metres."""
        span = self.corners_m.max(axis=0) - self.corners_m.min(axis=0)
        return float(span.max())

    @property
    def polarity(self) -> str:
        """ "bright" for a light H on a darker board, "dark" for the opposite."""
        return self.projection.polarity

    @classmethod
    def from_image(cls, image_bgr: np.ndarray, pad_size_m: float) -> Reference:
        """Learn the H on a top-down picture of the pad whose width is ``pad_size_m``.

        Any colours and polarity, stroke widths down to ~8 % of the H's width,
        serifs, rings, stars or text around it. Raises ValueError saying what
        is wrong when the picture holds no usable H.

        Examples
        --------
        >>> from pipeline.render import make_pad_image
        >>> ref = Reference.from_image(make_pad_image(800), 0.55)
        >>> ref.corners_m.shape, ref.symmetric, ref.polarity
        ((12, 2), True, 'bright')
        >>> dark = Reference.from_image(255 - make_pad_image(800), 0.55)
        >>> dark.polarity, bool(np.allclose(dark.corners_m, ref.corners_m, atol=1e-3))
        ('dark', True)
        """
        image = check_image(image_bgr, "image_bgr")
        try:
            pad_size_m = float(pad_size_m)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"pad_size_m must be a number, got {pad_size_m!r}") from exc
        if not math.isfinite(pad_size_m) or pad_size_m <= 0:
            raise ValueError(f"pad_size_m must be a positive number of metres, got {pad_size_m}")
        h_img, w_img = image.shape[:2]
        if max(h_img, w_img) > MAX_SIDE_PX:
            raise ValueError(
                f"the picture is {w_img}x{h_img} px: a reference picture may be at most "
                f"{MAX_SIDE_PX} px on a side (shrink it; the pad needs far fewer)"
            )
        scale = min(1.0, _WORK_MAX / max(h_img, w_img))
        work = image
        if scale < 1.0:
            size = (round(w_img * scale), round(h_img * scale))
            work = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        wh, ww = work.shape[:2]
        found = _find_h(work)
        if isinstance(found, str):
            raise ValueError(found)
        fit, region = found
        h_mask, board_mask = _h_and_board(region, fit)
        projection = learn_projection(work, h_mask, board_mask)
        channel = projection.apply(work)
        smooth = cv2.GaussianBlur(channel, (5, 5), 1.0)
        h_contrast = contrast(smooth, h_mask, board_mask)
        if h_contrast < _MIN_CONTRAST:
            if _outlined(work, region):
                raise ValueError(
                    "the H is drawn as an outline, its inside the board's colour: Visland "
                    "finds an H painted solid (fill the H in on the picture and on the pad)"
                )
            raise ValueError(
                f"the H barely stands out from its board (contrast {h_contrast:.0f} of 255): "
                "take the picture in even light, straight from above"
            )
        light = log_light(smooth, projection.inverted_luma)
        light_contrast = float(np.median(light[h_mask])) - float(np.median(light[board_mask]))
        board_level = float(smooth[board_mask].mean())
        level = 0.5 * (float(smooth[h_mask].mean()) + board_level)
        mask = np.where(smooth > level, 255, 0).astype(np.uint8)
        # The H was found at whichever threshold shaped it best; on the learned
        # channel, half-way between the paint and the board is where its edges are.
        fit = _refit(mask, region, fit)
        refined = refine_polygon(smooth, fit.corners)
        h_poly = refined[0] if refined is not None else fit.corners
        gap = _gap_to_paint(mask, h_poly, min(fit.leg_widths)) / ww
        if gap < _MIN_GAP:
            raise ValueError(
                f"the H nearly runs into another mark of its paint (a gap of {100 * gap:.1f} % "
                f"of the pad's width, {100 * _MIN_GAP:g} % at least is needed): {_TOUCHING}"
            )
        to_m = _pixels_to_metres(ww, wh, pad_size_m)
        corners_m = to_m(h_poly)
        # (a rim's band: its width in metres, the picture's pixels square)
        m_per_px = pad_size_m / ww
        board_bgr = _median_bgr(work, board_mask)
        weights = _chroma_weights(board_bgr)
        chroma = None
        if weights is not None:
            levels = chroma_levels(work, weights)
            chroma = (levels, float(np.median(levels[board_mask])))
        marks = tuple(
            Mark(
                to_m(poly),
                bright,
                rim,
                m_per_px * band_beyond(work, poly) if rim else 0.0,
                faint,
                banded,
            )
            for poly, bright, rim, faint, banded in find_marks(
                smooth, level, board_level, region, chroma
            )
        )
        contour = _outer_contour(region)
        mom = shape_moments(contour)
        hull = cv2.contourArea(cv2.convexHull(contour.reshape(-1, 1, 2).astype(np.int32)))
        corners_px = (h_poly + 0.5) / scale - 0.5
        return cls(
            pad_size_m=pad_size_m,
            pad_height_m=pad_size_m * wh / ww,
            image=image,
            mask=mask,
            corners_px=corners_px,
            corners_m=corners_m,
            marks=marks,
            hu=tuple(float(v) for v in mom.hu),
            orientation_deg=float(mom.orientation_deg),
            eccentricity=float(mom.eccentricity),
            solidity=float(np.count_nonzero(region) / hull) if hull > 0 else 0.0,
            symmetric=symmetric_marks(corners_m, marks),
            projection=projection,
            contrast=h_contrast,
            light_contrast=light_contrast,
            leg_fraction=fit.leg_fraction,
            paint_bgr=_median_bgr(work, h_mask),
            board_bgr=board_bgr,
            channel=channel,
            channel_px_per_m=ww / pad_size_m,
            lesser_hs=tuple(to_m(c) for c in _lesser_hs(mask, region)),
            slant_deg=_slant_deg(region, fit.corners, min(fit.leg_widths)),
        )

    def to_dict(self) -> dict:
        return {
            "pad_size_m": self.pad_size_m,
            "pad_height_m": self.pad_height_m,
            "image_size": [int(self.image.shape[1]), int(self.image.shape[0])],
            "corners_m": self.corners_m.tolist(),
            "corners_px": self.corners_px.tolist(),
            "marks": [m.to_dict() for m in self.marks],
            "hu": list(self.hu),
            "orientation_deg": self.orientation_deg,
            "eccentricity": self.eccentricity,
            "solidity": self.solidity,
            "symmetric": self.symmetric,
            "projection": self.projection.to_dict(),
            "contrast": self.contrast,
            "light_contrast": self.light_contrast,
            "leg_fraction": self.leg_fraction,
            "lesser_hs": [c.tolist() for c in self.lesser_hs],
            "outline_share": self.outline_share,
            "slant_deg": self.slant_deg,
        }


def _channels(work: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """Gray and the colour-opponent channels, smoothed, where an H may stand out."""
    lab = cv2.cvtColor(work, cv2.COLOR_BGR2LAB)
    b, _, r = cv2.split(work)
    chans = [
        ("gray", cv2.cvtColor(work, cv2.COLOR_BGR2GRAY)),
        ("a", lab[..., 1]),
        ("b", lab[..., 2]),
        ("blue", b),
        ("red", r),
    ]
    out = []
    for name, c in chans:
        s = cv2.GaussianBlur(c, (5, 5), 1.0)
        out.append((name, s))
        out.append((name + "-", 255 - s))
    return out


def _find_h(work: np.ndarray) -> tuple[HFit, np.ndarray] | str:
    """The pad's H: the region, over channels, polarities and thresholds, most like a
    block H (the one nearest the centre among equals). Returns (fit, region mask)
    or a sentence saying what was found instead."""
    wh, ww = work.shape[:2]
    area = float(wh * ww)
    centre = np.array([ww / 2.0, wh / 2.0])
    best: tuple[float, float, HFit, np.ndarray] | None = None
    shapes = 0
    seen: set[tuple[int, int, int, int]] = set()
    untold: list[tuple[int, int, np.ndarray]] = []  # the largest shapes no H was fitted to
    touching = False  # an H was fitted to a shape with another mark run into it
    cut: dict[tuple[int, int, int, int], np.ndarray] = {}  # shapes the picture's edge cuts
    for _name, chan in _channels(work):
        lo, hi = np.percentile(chan, [2, 98])
        if hi - lo < _MIN_CONTRAST:
            continue
        for level in np.linspace(lo, hi, _LEVELS + 2)[1:-1]:
            binary = (chan > level).astype(np.uint8)
            n, labels, stats, cents = cv2.connectedComponentsWithStats(binary, connectivity=8)
            for k in range(1, n):
                x, y, w, h, a = stats[k]
                if not _MIN_H_AREA * area <= a <= _MAX_H_AREA * area:
                    continue
                if a > 0.95 * w * h:
                    continue  # a filled box
                key = (x // 4, y // 4, w // 4, h // 4)
                if x == 0 or y == 0 or x + w == ww or y + h == wh:
                    # The H lies inside the picture; one the edge cuts is told of.
                    if key not in cut and len(cut) < _MAX_CUT_SHAPES:
                        cut[key] = labels[y : y + h, x : x + w] == k
                    continue
                if key in seen:
                    continue  # the same shape at another threshold or in another channel
                seen.add(key)
                shapes += 1
                region = labels[y : y + h, x : x + w] == k
                fit = fit_h(_framed(region))
                if fit is None:
                    heapq.heappush(untold, (int(a), shapes, region))
                    if len(untold) > _MAX_TOUCH_LOOKS:
                        heapq.heappop(untold)  # (the smallest)
                    continue
                block = _block_h(region.shape, fit.corners - 2.0, min(fit.leg_widths))
                if _beyond_h(region, *block) > _MAX_BEYOND_H:
                    touching = True
                    continue
                fit = HFit(
                    corners=fit.corners + np.array([x - 2, y - 2]),
                    iou=fit.iou,
                    width_px=fit.width_px,
                    height_px=fit.height_px,
                    leg_widths=fit.leg_widths,
                    crossbar=fit.crossbar,
                )
                off = float(np.linalg.norm(cents[k] - centre)) / math.hypot(ww, wh)
                # Serifs and anti-aliasing cost a little IoU; the pad's own H is
                # central, and of two thresholds of one H the better fit wins.
                score = fit.iou - 0.3 * off
                if best is None or score > best[0]:
                    full = np.zeros((wh, ww), bool)
                    full[y : y + h, x : x + w] = region
                    best = (score, fit.iou, fit, full)
    if best is None:
        if any(fit_h(_framed(region)) is not None for region in cut.values()):
            return (
                "the H touches the picture's edge: crop the picture to the pad's outer "
                "edge, with the whole H inside it"
            )
        if touching or any(_opened_h(region) for _, _, region in untold):
            return (
                "the H runs into another mark of its paint (a ring or a frame touching it): "
                + _TOUCHING
            )
        if shapes == 0:
            return (
                "no shape stands out on the picture: expected a pad whose H contrasts "
                "with its board, cropped to the pad's outer edge"
            )
        return (
            f"no usable H on the picture: {shapes} shape(s) examined over gray and colour "
            "channels, none has the two legs and crossbar of an H"
        )
    return best[2], best[3]


_TOUCHING = (
    "the camera's frames show the two as one shape, no H's. Visland finds an H standing "
    "clear of its pad's other marks: leave a gap of the board's colour between them, on "
    "the pad and on its picture"
)


def _gap_to_paint(mask: np.ndarray, h_poly: np.ndarray, leg: float) -> float:
    """The distance (pixels) from the block H ``h_poly`` to the nearest other mark of
    ``mask`` (the paint) of ``_GAP_MARK_AREA`` of its area at least; 0 when the H's
    own paint runs on into one (`_beyond_h`), inf when there is none. Paint joined to
    the H within `_block_h`'s margin is the H's: serifs, or a picture taken at a slant,
    its legs leaning out of the block H."""
    poly, grown = _block_h(mask.shape, h_poly, leg)
    n, labels, stats, _ = cv2.connectedComponentsWithStats((mask > 0).astype(np.uint8))
    own = np.zeros(n, bool)
    own[np.unique(labels[poly > 0])] = True
    own[0] = False
    if _beyond_h(own[labels], poly, grown) > _MAX_BEYOND_H:
        return 0.0
    others = ~own & (stats[:, cv2.CC_STAT_AREA] >= _GAP_MARK_AREA * np.count_nonzero(poly))
    others[0] = False
    if not others.any():
        return math.inf
    distance = cv2.distanceTransform(1 - poly, cv2.DIST_L2, 5)
    return float(distance[others[labels]].min())


def _slant_deg(region: np.ndarray, corners: np.ndarray, leg: float) -> float:
    """How far (degrees) the sides of the H's ``region`` that a block H has parallel
    converge: its legs' outer sides, and the line along its legs' tops against the one
    along their feet. A picture taken at a slant, not straight from above, makes them
    converge: the default pad's picture seen 5 degrees off the vertical from a pad's
    width away, by 2.4 degrees (its poses then came 5 % off the altitude; 10 degrees
    off, 5.0 and 8 %); the bench's pictures, by 0, and a photo rectified by hand, 0.5."""
    contours, _ = cv2.findContours(
        region.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
    )
    edge = max(contours, key=cv2.contourArea).reshape(-1, 2).astype(np.float64)
    c, reach = corners, 0.4 * leg
    pairs = (
        (_along(edge, [(c[0], c[11])], reach), _along(edge, [(c[5], c[6])], reach)),
        (
            _along(edge, [(c[0], c[1]), (c[4], c[5])], reach),
            _along(edge, [(c[11], c[10]), (c[7], c[6])], reach),
        ),
    )
    out = 0.0
    for u, v in pairs:
        if u is not None and v is not None:
            out = max(out, math.degrees(math.acos(min(1.0, abs(float(u @ v))))))
    return out


def _along(
    edge: np.ndarray, sides: list[tuple[np.ndarray, np.ndarray]], reach: float
) -> np.ndarray | None:
    """The unit direction of the line fitted to the ``edge`` points within ``reach`` of
    the middle 70 % of ``sides`` ((a, b) segments), or None when too few are."""
    near = []
    for a, b in sides:
        d = b - a
        length = float(np.hypot(*d))
        if length < 1e-9:
            continue
        u = d / length
        rel = edge - a
        t, off = rel @ u / length, rel @ np.array([-u[1], u[0]])
        near.append(edge[(np.abs(off) < reach) & (t > 0.15) & (t < 0.85)])
    pts = np.vstack(near) if near else np.zeros((0, 2))
    if len(pts) < 8:
        return None
    vx, vy, _, _ = cv2.fitLine(pts.astype(np.float32), cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
    return np.array([vx, vy], np.float64) / math.hypot(vx, vy)


def _beyond_h(region: np.ndarray, poly: np.ndarray, grown: np.ndarray) -> float:
    """The share of the block H's area (``poly``, ``grown``: `_block_h`'s, on the
    region's pixels) that the region covers beyond it and its margin."""
    return np.count_nonzero(region & (grown == 0)) / max(np.count_nonzero(poly), 1)


def _block_h(
    shape: tuple[int, ...], corners: np.ndarray, leg: float
) -> tuple[np.ndarray, np.ndarray]:
    """The block H's pixels (uint8 0/1), and the same grown by a quarter of its ``leg``:
    the margin serifs, rounded ends and blur take."""
    poly = np.zeros(shape[:2], np.uint8)
    cv2.fillPoly(poly, [np.round(corners).astype(np.int32)], 1)
    return poly, cv2.dilate(poly, _disc(max(1, round(0.25 * leg))))


def _opened_h(region: np.ndarray) -> bool:
    """Whether an H stands out of a shape (bool, its box) once its thinner parts are
    cut off (opened by discs of 2-6 % of its size): an H whose legs touch a ring or
    a frame painted round it."""
    size = max(region.shape)
    for share in (0.02, 0.04, 0.06):
        r = round(share * size)
        if r < 2:
            continue
        opened = cv2.morphologyEx(region.astype(np.uint8), cv2.MORPH_OPEN, _disc(r))
        n, labels, stats, _ = cv2.connectedComponentsWithStats(opened)
        if n < 2:
            continue
        k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        x, y, w, h, _a = stats[k]
        if min(w, h) >= 8 and fit_h(_framed(labels[y : y + h, x : x + w] == k)) is not None:
            return True
    return False


def _framed(region: np.ndarray) -> np.ndarray:
    """A region (bool, its box) with 2 px of ground around it: the uint8 0/1 mask `fit_h`
    takes."""
    crop = np.zeros((region.shape[0] + 4, region.shape[1] + 4), np.uint8)
    crop[2:-2, 2:-2] = region
    return crop


def _refit(mask: np.ndarray, region: np.ndarray, fit: HFit) -> HFit:
    """The block H fitted again to the H's region of ``mask`` (the one that covers
    most of the region first found), or the first fit when that fails."""
    n, labels = cv2.connectedComponents((mask > 0).astype(np.uint8))
    counts = np.bincount(labels[region], minlength=n)
    counts[0] = 0
    k = int(counts.argmax())
    if counts[k] == 0:
        return fit
    ys, xs = np.nonzero(labels == k)
    x0, y0 = xs.min(), ys.min()
    crop = np.zeros((ys.max() - y0 + 5, xs.max() - x0 + 5), np.uint8)
    crop[ys - y0 + 2, xs - x0 + 2] = 255
    again = fit_h(crop)
    if again is None:
        return fit
    return dataclasses.replace(again, corners=again.corners + np.array([x0 - 2, y0 - 2]))


def _outlined(work: np.ndarray, region: np.ndarray) -> bool:
    """Whether the H-shaped ``region`` is the inside of an outline: a band right around
    it stands out from it (on gray or any colour) as its board beyond does not."""
    reg = region.astype(np.uint8)
    band = (cv2.dilate(reg, _disc(4)) > 0) & ~(cv2.dilate(reg, _disc(1)) > 0)
    inside = cv2.erode(reg, _disc(2)) > 0
    if not band.any() or not inside.any():
        return False
    step = np.abs(np.median(work[band], axis=0) - np.median(work[inside], axis=0))
    return bool(step.max() >= 2 * _MIN_CONTRAST)


def _lesser_hs(mask: np.ndarray, region: np.ndarray) -> list[np.ndarray]:
    """The corners (pixels) of the marks of ``mask`` (the H's paint) besides the H's
    ``region`` that are smaller than it and shaped as an H (looked for among the
    ``_MAX_LESSER_LOOKS`` largest)."""
    _, labels, stats, _ = cv2.connectedComponentsWithStats((mask > 0).astype(np.uint8))
    ys, xs = np.nonzero(region)
    h_box = max(xs.max() - xs.min(), ys.max() - ys.min()) + 1
    own = set(np.unique(labels[region]).tolist())
    out: list[np.ndarray] = []
    looked = 0
    for k in np.argsort(-stats[:, cv2.CC_STAT_AREA]):
        x, y, w, h, _a = stats[k]
        if k == 0 or k in own or min(w, h) < _LESSER_MIN_PX or max(w, h) >= h_box:
            continue
        looked += 1
        if looked > _MAX_LESSER_LOOKS:
            break
        fit = fit_h(_framed(labels[y : y + h, x : x + w] == k))
        if fit is not None:
            out.append(fit.corners + np.array([x - 2, y - 2]))
    return out


def _h_and_board(region: np.ndarray, fit: HFit) -> tuple[np.ndarray, np.ndarray]:
    """The H's inner pixels and the board's pixels right around it (and between its legs)."""
    leg = max(1.0, min(fit.leg_widths))
    r_in = max(2, round(0.2 * leg))
    r_out = max(r_in + 3, round(1.0 * leg))
    reg = region.astype(np.uint8)
    core = cv2.erode(reg, _disc(max(1, round(0.2 * leg)))) > 0
    if np.count_nonzero(core) < 10:
        core = region
    near = cv2.dilate(reg, _disc(r_in)) > 0
    far = cv2.dilate(reg, _disc(r_out)) > 0
    hull = np.zeros_like(reg)
    cv2.fillConvexPoly(hull, cv2.convexHull(fit.corners.astype(np.int32)), 1)
    board = (far | (hull > 0)) & ~near
    return core, board


def _chroma_weights(bgr: tuple[float, float, float]) -> np.ndarray | None:
    """Unit BGR weights of a colour's chroma, or None for a grey (`Reference.board_chroma`)."""
    colour = np.asarray(bgr, np.float64)
    chroma = colour - colour.mean()
    size = float(np.linalg.norm(chroma))
    return None if size < MIN_BOARD_CHROMA else chroma / size


def _median_bgr(image: np.ndarray, mask: np.ndarray) -> tuple[float, float, float]:
    b, g, r = (float(v) for v in np.median(image[mask], axis=0))
    return b, g, r


def _disc(radius: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def _outer_contour(region: np.ndarray) -> np.ndarray:
    contours, _ = cv2.findContours(
        region.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
    )
    c = max(contours, key=cv2.contourArea)
    return c.reshape(-1, 2)[::-1].copy()


def _radial(pts_m: np.ndarray) -> np.ndarray:
    """The unit vectors from the pad's centre out to points (N x 2, pad metres)."""
    return pts_m / np.maximum(np.hypot(*pts_m.T), 1e-9)[:, None]


def _pixels_to_metres(width: int, height: int, pad_size_m: float):
    m_per_px = pad_size_m / width

    def convert(px: np.ndarray) -> np.ndarray:
        px = np.asarray(px, np.float64)
        x = (px[:, 0] + 0.5 - width / 2.0) * m_per_px
        y = (height / 2.0 - (px[:, 1] + 0.5)) * m_per_px
        return np.column_stack([x, y])

    return convert


def _round_radius(corners_m: np.ndarray, centre_m: np.ndarray) -> float | None:
    """The radius of a polygon that is a circle about ``centre_m`` (every corner within
    ``_ROUND_TOL`` of its radius from it), else None."""
    if len(corners_m) < 8:
        return None
    radii = np.hypot(*(corners_m - centre_m).T)
    radius = float(radii.mean())
    if float(np.abs(radii - radius).max()) > _ROUND_TOL * radius:
        return None
    return radius
