"""Pad designs: a registry of named, data-driven pads and their ground truth.

A design is a list of painted layers (rectangles, convex polygons, discs, rings,
polygon outlines, stars) over a background, one of which is the H. Each layer is
drawn by the fraction of every pixel it covers: rectangles exactly (as
`pipeline.render.pad`), curved and slanted edges from their signed distance, so
the picture is anti-aliased and its edges sit where the geometry says at any size.

Coordinates: fractions of the pad's width, origin at the picture's centre, +x to
its right edge, +y to its top edge (the pad frame of `pipeline.render`, divided by
the pad's width). Every design is square; round pads and a painted H carry an
alpha channel so that the floor shows around them.

Examples
--------
>>> pic = DESIGNS["icao"].draw(256)
>>> pic.image.shape, pic.size_m, pic.h_corners_m.shape, pic.symmetric
((256, 256, 3), 4.5, (12, 2), True)
>>> sorted(DESIGNS)[:3]
['dark_on_light', 'default', 'grass_paint']
"""

from __future__ import annotations

import functools
import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.render.floor import FLOOR_PX_PER_M, make_floor
from pipeline.render.pad import (
    BOARD_BGR,
    H_CROSSBAR_HEIGHT,
    H_HEIGHT,
    H_LEG_WIDTH,
    H_WIDTH,
    PAD_SIZE_M,
    PAINT_BGR,
    PadGeometry,
    rect_coverage,
)
from pipeline.render.scene import Scene, make_scene

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (pad fractions, y up)
BGR = tuple[int, int, int]


# ---------------------------------------------------------------- shapes


class _Shape:
    """A region of the picture, able to say how much of each pixel it covers."""

    def coverage(self, n: int) -> np.ndarray:
        raise NotImplementedError


def _grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel centres in pad fractions (x right, y up) of an n x n picture."""
    c = (np.arange(n, dtype=np.float64) + 0.5) / n - 0.5
    return c[None, :], -c[:, None]


def _from_distance(sd: np.ndarray, n: int) -> np.ndarray:
    """Coverage from a signed distance (fractions; negative inside): a 1 px ramp."""
    return np.clip(0.5 - sd * n, 0.0, 1.0)


@dataclass(frozen=True)
class Rects(_Shape):
    """Disjoint axis-aligned rectangles, covered exactly."""

    rects: tuple[Rect, ...]

    def coverage(self, n: int) -> np.ndarray:
        # Pad fractions (y up) -> unit square (y down) for `rect_coverage`.
        unit = [(x0 + 0.5, 0.5 - y1, x1 + 0.5, 0.5 - y0) for x0, y0, x1, y1 in self.rects]
        return rect_coverage(unit, n)


@dataclass(frozen=True)
class Polygon(_Shape):
    """A convex polygon (vertices in either turning direction)."""

    points: tuple[tuple[float, float], ...]

    def signed_distance(self, n: int) -> np.ndarray:
        x, y = _grid(n)
        pts = np.asarray(self.points, np.float64)
        area2 = np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
        sd = np.full((n, n), -np.inf)
        for a, b in zip(pts, np.roll(pts, -1, axis=0), strict=True):
            d = b - a
            # Outward normal of edge a->b: right of the edge for a counter-clockwise polygon.
            nx, ny = (d[1], -d[0]) if area2 > 0 else (-d[1], d[0])
            norm = math.hypot(nx, ny)
            sd = np.maximum(sd, ((x - a[0]) * nx + (y - a[1]) * ny) / norm)
        return sd

    def coverage(self, n: int) -> np.ndarray:
        return _from_distance(self.signed_distance(n), n)


@dataclass(frozen=True)
class Disc(_Shape):
    radius: float
    center: tuple[float, float] = (0.0, 0.0)

    def coverage(self, n: int) -> np.ndarray:
        x, y = _grid(n)
        d = np.hypot(x - self.center[0], y - self.center[1])
        return _from_distance(d - self.radius, n)


@dataclass(frozen=True)
class Ring(_Shape):
    inner: float
    outer: float
    center: tuple[float, float] = (0.0, 0.0)

    def coverage(self, n: int) -> np.ndarray:
        x, y = _grid(n)
        d = np.hypot(x - self.center[0], y - self.center[1])
        return _from_distance(np.maximum(self.inner - d, d - self.outer), n)


@dataclass(frozen=True)
class Outline(_Shape):
    """The band between a convex polygon and a smaller one inside it."""

    outer: Polygon
    inner: Polygon

    def coverage(self, n: int) -> np.ndarray:
        return np.clip(self.outer.coverage(n) - self.inner.coverage(n), 0.0, 1.0)


@dataclass(frozen=True)
class Union(_Shape):
    """Shapes that do not overlap (their coverages add up)."""

    parts: tuple[_Shape, ...]

    def coverage(self, n: int) -> np.ndarray:
        return np.minimum(sum(p.coverage(n) for p in self.parts), 1.0)


def regular_polygon(sides: int, radius: float, rotation_deg: float = 0.0) -> Polygon:
    """A regular polygon centred at the origin, ``radius`` to its vertices."""
    angles = np.radians(rotation_deg + 90.0 + 360.0 * np.arange(sides) / sides)
    return Polygon(tuple((radius * math.cos(a), radius * math.sin(a)) for a in angles))


def polygon_outline(sides: int, radius: float, width: float, rotation_deg: float) -> Outline:
    """A band ``width`` wide (measured across it) inside a regular polygon's edge."""
    inner = radius - width / math.cos(math.pi / sides)
    return Outline(
        regular_polygon(sides, radius, rotation_deg), regular_polygon(sides, inner, rotation_deg)
    )


def star(center: tuple[float, float], radius: float, points: int = 5) -> Union:
    """A filled star: its inner polygon and one triangle per point (disjoint pieces)."""
    cx, cy = center
    inner_r = radius * math.sin(math.radians(18)) / math.sin(math.radians(126))
    outer = [math.radians(90 + 360 * k / points) for k in range(points)]
    inner = [a + math.pi / points for a in outer]
    ins = [(cx + inner_r * math.cos(a), cy + inner_r * math.sin(a)) for a in inner]
    parts: list[_Shape] = [Polygon(tuple(ins))]
    for k, a in enumerate(outer):
        tip = (cx + radius * math.cos(a), cy + radius * math.sin(a))
        parts.append(Polygon((ins[k - 1], tip, ins[k])))
    return Union(tuple(parts))


@dataclass(frozen=True)
class HShape(_Shape):
    """A block H (optionally with serifs) centred at the origin, in pad fractions.

    ``serif``: how far the serifs reach out past each leg on both sides, and
    ``serif_height`` how tall they are; the H's 12 corners are those of the block H
    under them (the lines of the strokes), so serifs add no corners.
    """

    width: float
    height: float
    leg: float
    bar: float
    serif: float = 0.0
    serif_height: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < 2 * self.leg < self.width or not 0 < self.bar < self.height:
            raise ValueError(f"H proportions do not make an H: {self}")
        if self.serif and not 0 < 2 * self.serif_height < self.height / 2 - self.bar / 2:
            raise ValueError(f"serif_height leaves no leg between serif and bar: {self}")

    @property
    def rects(self) -> tuple[Rect, ...]:
        """The H as disjoint rectangles."""
        a, b = self.width / 2, self.height / 2
        w, c = self.leg, self.bar / 2
        out: list[Rect] = [(-a + w, -c, a - w, c)]
        for x0, x1 in ((-a, -a + w), (a - w, a)):
            if not self.serif:
                out.append((x0, -b, x1, b))
                continue
            s, h = self.serif, self.serif_height
            out += [
                (x0 - s, b - h, x1 + s, b),
                (x0, -b + h, x1, b - h),
                (x0 - s, -b, x1 + s, -b + h),
            ]
        return tuple(out)

    @property
    def corners(self) -> np.ndarray:
        """12 x 2 corners, clockwise in the picture from the left leg's top-left."""
        a, b = self.width / 2, self.height / 2
        w, c = self.leg, self.bar / 2
        pts = [(-a, b), (-a + w, b), (-a + w, c), (a - w, c), (a - w, b), (a, b)]
        pts += [(a, -b), (a - w, -b), (a - w, -c), (-a + w, -c), (-a + w, -b), (-a, -b)]
        return np.array(pts, np.float64)

    def coverage(self, n: int) -> np.ndarray:
        return Rects(self.rects).coverage(n)


# ---------------------------------------------------------------- designs


@dataclass(frozen=True)
class DesignPicture:
    """A design drawn at one resolution, with its ground truth.

    ``image``: BGR uint8, top-down, cropped to the pad's square (what
    ``Reference.from_image`` takes). ``alpha``: uint8 coverage of the pad itself
    (None: the whole square is pad); where it is below 255 ``image`` shows the
    design's surroundings. ``h_corners_m``: the H's 12 outer corners in pad metres,
    in the order of `PadGeometry.h_corners_m`. ``symmetric``: the pad looks the same
    after a half turn.
    """

    image: np.ndarray
    alpha: np.ndarray | None
    size_m: float
    h_corners_m: np.ndarray
    symmetric: bool


@dataclass(frozen=True)
class Design:
    """One pad design: a background, painted layers (the H among them) and its size.

    ``board``: the pad's own outline when it is not the whole square (a disc);
    ``painted``: no board at all, the marks are paint on the floor. ``surround``: what
    lies around a round or painted pad in its reference picture (a BGR colour or a
    floor kind). ``floors``: the floor kinds its scenes are laid on (None: any).
    ``grain``: standard deviation, in percent, of the board's print/fabric texture.
    """

    name: str
    description: str
    size_m: float
    background: BGR
    h: HShape
    h_bgr: BGR
    below: tuple[tuple[_Shape, BGR], ...] = ()
    above: tuple[tuple[_Shape, BGR], ...] = ()
    symmetric: bool = True
    board: _Shape | None = None
    painted: bool = False
    surround: BGR | str = (120, 122, 124)
    floors: tuple[str, ...] | None = None
    grain: float = 0.0
    wear: float = 0.0
    texture_px: int = 1024

    @property
    def h_corners_m(self) -> np.ndarray:
        return self.h.corners * self.size_m

    @property
    def h_size_m(self) -> float:
        """The H's extent (the larger of its width and height), metres."""
        return max(self.h.width, self.h.height) * self.size_m

    def draw(self, size_px: int | None = None) -> DesignPicture:
        """The pad seen straight from above, ``size_px`` square (default ``texture_px``)."""
        n = self.texture_px if size_px is None else size_px
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 32:
            raise ValueError(f"size_px must be an integer >= 32, got {size_px!r}")
        n = int(n)
        rng = np.random.default_rng(zlib.crc32(self.name.encode()))
        img = np.empty((n, n, 3), np.float64)
        img[:] = self.background
        for shape, bgr in self.below:
            img = _paint(img, shape.coverage(n), bgr)
        h_cover = self.h.coverage(n)
        if self.painted and self.wear:
            # Worn paint: grass and grit show through in patches.
            holes = np.clip(_smooth_noise(rng, n, max(4, n // 16)) - 1.0, 0.0, 1.0)
            h_cover = h_cover * (1.0 - self.wear * holes)
        img = _paint(img, h_cover, self.h_bgr)
        for shape, bgr in self.above:
            img = _paint(img, shape.coverage(n), bgr)
        if self.grain:
            img *= 1.0 + self.grain / 100.0 * _smooth_noise(rng, n, n // 2)[..., None]
        alpha = None
        if self.painted:
            marks = h_cover.copy()
            for shape, _ in (*self.below, *self.above):
                marks = np.maximum(marks, shape.coverage(n))
            alpha = marks
        elif self.board is not None:
            alpha = self.board.coverage(n)
        if alpha is not None:
            img = img * alpha[..., None] + self._surround(n) * (1.0 - alpha[..., None])
        image = np.clip(np.rint(img), 0, 255).astype(np.uint8)
        a8 = None if alpha is None else np.clip(np.rint(alpha * 255), 0, 255).astype(np.uint8)
        return DesignPicture(image, a8, self.size_m, self.h_corners_m, self.symmetric)

    def scene(
        self,
        rng: np.random.Generator | int,
        *,
        floor: str | Sequence[str] = "textured",
        lookalikes: int = 0,
        pad_visible: bool = True,
    ) -> Scene:
        """`make_scene` with this pad (its picture drawn once and kept) on ``floor``.

        A design that names its ``floors`` is laid only on those; look-alikes are
        painted in the H's colour and sized like its H.
        """
        pic = _drawn(self.name, self.texture_px) if DESIGNS.get(self.name) is self else self.draw()
        return make_scene(
            pic.image,
            self.size_m,
            rng=rng,
            floor=self.floors if self.floors is not None else floor,
            lookalikes=lookalikes,
            pad_visible=pad_visible,
            alpha=pic.alpha,
            lookalike_bgr=self.h_bgr,
            h_size_m=self.h_size_m,
        )

    def _surround(self, n: int) -> np.ndarray:
        if not isinstance(self.surround, str):
            return np.asarray(self.surround, np.float64)[None, None, :]
        # A floor seen at the picture's scale: crop the tile to the pad's size.
        tile = make_floor(self.surround, np.random.default_rng(zlib.crc32(self.name.encode())))
        texels = min(tile.shape[0], max(8, round(self.size_m * FLOOR_PX_PER_M)))
        crop = tile[:texels, :texels]
        return cv2.resize(crop, (n, n), interpolation=cv2.INTER_AREA).astype(np.float64)


def _paint(img: np.ndarray, cover: np.ndarray, bgr: BGR) -> np.ndarray:
    colour = np.asarray(bgr, np.float64)[None, None, :]
    return img + (colour - img) * cover[..., None]


def _smooth_noise(rng: np.random.Generator, n: int, cells: int) -> np.ndarray:
    """Unit-variance noise with ``cells`` features across the picture."""
    cells = max(2, min(int(cells), n))
    grid = rng.standard_normal((cells, cells)).astype(np.float32)
    out = cv2.resize(grid, (n, n), interpolation=cv2.INTER_CUBIC).astype(np.float64)
    return out / max(float(out.std()), 1e-6)


# ---------------------------------------------------------------- the registry

_WHITE_PAINT: BGR = (232, 235, 235)
_PAPER: BGR = (236, 238, 240)
_INK: BGR = (42, 40, 44)


def _seed_pad() -> Design:
    g = PadGeometry()
    bars = Rects(tuple(g._bar_rects()))
    return Design(
        name="default",
        description="the seed's pad: white block H and side bars on a black 0.55 m board",
        size_m=PAD_SIZE_M,
        background=BOARD_BGR,
        h=HShape(H_WIDTH, H_HEIGHT, H_LEG_WIDTH, H_CROSSBAR_HEIGHT),
        h_bgr=PAINT_BGR,
        below=((bars, PAINT_BGR),),
        texture_px=1100,
    )


def _icao(circle: bool) -> Design:
    size = 5.0 if circle else 4.5
    # ICAO Annex 14 heliport H: 3 m tall, 1.8 m wide, 0.4 m strokes, white.
    h = HShape(1.8 / size, 3.0 / size, 0.4 / size, 0.4 / size)
    marks = ((Ring(2.0 / size, 2.3 / size), _WHITE_PAINT),) if circle else ()
    return Design(
        name="icao_circle" if circle else "icao",
        description=(
            "ICAO heliport H (3 x 1.8 m, 0.4 m strokes), white paint on a dark square"
            + (" inside a white circle" if circle else "")
        ),
        size_m=size,
        background=(60, 64, 61),
        h=h,
        h_bgr=_WHITE_PAINT,
        below=marks,
        grain=3.0,
    )


def _registry() -> dict[str, Design]:
    designs = [
        _seed_pad(),
        _icao(False),
        _icao(True),
        Design(
            name="dark_on_light",
            description="dark block H on a light grey card",
            size_m=0.5,
            background=(218, 221, 224),
            h=HShape(0.66, 0.56, 0.15, 0.13),
            h_bgr=(40, 38, 42),
            grain=1.5,
        ),
        Design(
            name="thin",
            description="thin-stroke white H (legs 9 % of its width) on navy fabric",
            size_m=0.6,
            background=(105, 58, 34),
            h=HShape(0.5, 0.6, 0.045, 0.045),
            h_bgr=(228, 230, 232),
            grain=3.0,
        ),
        Design(
            name="serif_octagon",
            description=(
                "white serif H in a charcoal octagon with a double white rim and three "
                "stars above the H, printed on white paper"
            ),
            size_m=0.6,
            background=_PAPER,
            below=(
                (regular_polygon(8, 0.47, 22.5), (52, 50, 50)),
                (polygon_outline(8, 0.435, 0.014, 22.5), (226, 228, 230)),
                (polygon_outline(8, 0.41, 0.008, 22.5), (226, 228, 230)),
                (Union(tuple(star((x, 0.3), 0.04) for x in (-0.13, 0.0, 0.13))), (226, 228, 230)),
            ),
            h=HShape(0.36, 0.42, 0.07, 0.06, serif=0.025, serif_height=0.035),
            h_bgr=(226, 228, 230),
            symmetric=False,
            grain=1.0,
        ),
        Design(
            name="orange_ring",
            description="white H in a white ring on an orange fabric disc with a dark hem",
            size_m=1.1,
            background=(38, 118, 232),
            below=((Ring(0.485, 0.5), (34, 32, 34)), (Ring(0.33, 0.375), (232, 226, 224))),
            h=HShape(0.30, 0.38, 0.06, 0.055),
            h_bgr=(232, 226, 224),
            board=Disc(0.5),
            surround=(108, 110, 112),
            grain=2.5,
        ),
        Design(
            name="red_on_black",
            description="red H in a red hexagon and ring on a black fabric disc",
            size_m=1.1,
            background=(30, 29, 31),
            below=(
                (polygon_outline(6, 0.36, 0.018, 0.0), (48, 42, 196)),
                (Ring(0.44, 0.455), (48, 42, 196)),
            ),
            h=HShape(0.30, 0.36, 0.07, 0.06),
            h_bgr=(48, 42, 196),
            board=Disc(0.5),
            surround=(196, 198, 200),
            grain=2.5,
        ),
        Design(
            name="grass_paint",
            description="white H painted straight on a lawn (1.2 x 0.8 m, 16 cm strokes), no board",
            size_m=2.0,
            background=_WHITE_PAINT,
            h=HShape(0.4, 0.6, 0.08, 0.08),
            h_bgr=_WHITE_PAINT,
            painted=True,
            surround="grass",
            floors=("grass",),
            wear=0.35,
        ),
        Design(
            name="paper_ring",
            description=(
                "thin dark sans-serif H in a thin dark ring with a triangle, printed on "
                "white paper (the shared photos' pad)"
            ),
            size_m=0.3,
            background=_PAPER,
            below=(
                (Ring(0.435, 0.447), _INK),
                (Polygon(((0.2, 0.22), (0.29, 0.22), (0.245, 0.3))), _INK),
            ),
            h=HShape(0.16, 0.24, 0.022, 0.02),
            h_bgr=_INK,
            symmetric=False,
            grain=1.0,
        ),
    ]
    return {d.name: d for d in designs}


DESIGNS: dict[str, Design] = _registry()
"""Every named design; ``"default"`` is `make_pad_image`'s pad, unchanged."""


@functools.lru_cache(maxsize=16)
def _drawn(name: str, size_px: int) -> DesignPicture:
    return DESIGNS[name].draw(size_px)


def get_design(name: str) -> Design:
    """The design called ``name`` (ValueError listing the names otherwise)."""
    try:
        return DESIGNS[name]
    except (KeyError, TypeError):
        raise ValueError(f"design must be one of {sorted(DESIGNS)}, got {name!r}") from None
