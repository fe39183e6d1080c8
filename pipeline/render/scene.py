"""A flat world: an endless floor with the pad and look-alike shapes laid on it.

Everything that does not depend on the camera is prepared here, once per scene:
the floor's mip pyramid and, for each flat picture ("decal") on the floor, a
pyramid of premultiplied BGRA levels with affine maps from the pad plane to texels.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from pipeline.render.floor import (
    FLOOR_KINDS,
    FLOOR_PX_PER_M,
    FLOOR_TILE_PX,
    OUTDOOR_KINDS,
    TEXTURED_KINDS,
    make_floor,
)
from pipeline.render.pad import H_HEIGHT, LOOKALIKE_KINDS, PAINT_BGR, make_lookalike

_DECAL_BORDER = 4  # transparent texels kept around every pyramid level
_MIN_LEVEL_PX = 8  # stop the pyramid when a picture gets this small
_LOOKALIKE_PX = 256


@dataclass(frozen=True, eq=False)
class Decal:
    """A flat picture lying on the pad plane.

    ``levels``: premultiplied BGRA uint8 mip levels (level 0 full resolution), each
    surrounded by transparent texels. ``texel_from_plane``: per level, the 3x3 affine
    map from pad-plane metres (x, y, 1) to that level's texel coordinates (u, v, 1),
    texel centres at integers. ``texels_per_m``: level 0's resolution.
    """

    kind: str
    center_m: tuple[float, float]
    angle_deg: float
    width_m: float
    height_m: float
    levels: tuple[np.ndarray, ...] = field(repr=False)
    texel_from_plane: tuple[np.ndarray, ...] = field(repr=False)
    texels_per_m: float

    @property
    def corners_m(self) -> np.ndarray:
        """The picture's corners on the plane (4 x 2), clockwise from its top-left."""
        w, h = self.width_m / 2, self.height_m / 2
        local = np.array([(-w, h), (w, h), (w, -h), (-w, -h)])
        return local @ _rot2(self.angle_deg).T + np.asarray(self.center_m)

    @property
    def radius_m(self) -> float:
        """Radius of the circle around the picture's centre that holds all of it."""
        return math.hypot(self.width_m, self.height_m) / 2


@dataclass(frozen=True, eq=False)
class Scene:
    """The floor, the pad (or another picture such as an ArUco marker) and look-alikes.

    ``floor_levels``: the floor tile's mip pyramid (BGR uint8; level k has
    ``floor_px_per_m / 2**k`` texels per metre; the tile repeats forever, its centre
    texel at the origin). ``pad``: the picture at the origin, None when
    ``pad_visible`` is False. ``pad_width_m``/``pad_height_m``: its size even when hidden.
    """

    floor_kind: str
    floor_levels: tuple[np.ndarray, ...] = field(repr=False)
    floor_px_per_m: float
    pad: Decal | None
    pad_width_m: float
    pad_height_m: float
    lookalikes: tuple[Decal, ...]

    @property
    def pad_visible(self) -> bool:
        return self.pad is not None

    @property
    def decals(self) -> tuple[Decal, ...]:
        """All pictures in drawing order (the pad last, on top)."""
        return (*self.lookalikes, *(() if self.pad is None else (self.pad,)))

    def floor_texel_from_plane(self, level: int) -> np.ndarray:
        """3x3 map from pad-plane metres to texels of floor level ``level`` (to be wrapped)."""
        n = self.floor_levels[level].shape[1]
        k = self.floor_px_per_m / 2**level
        # Texel u = x * k + n/2 - 0.5 puts the origin between the two middle texels;
        # v grows downward in the picture, i.e. toward pad -y.
        return np.array([[k, 0, n / 2 - 0.5], [0, -k, n / 2 - 0.5], [0, 0, 1]], np.float64)


def make_scene(
    texture_bgr: np.ndarray,
    size_m: float,
    *,
    rng: np.random.Generator | int,
    floor: str = "textured",
    lookalikes: int = 0,
    lookalike_kinds: Sequence[str] = LOOKALIKE_KINDS,
    pad_visible: bool = True,
    alpha: np.ndarray | None = None,
    lookalike_bgr: tuple[float, float, float] = PAINT_BGR,
    h_size_m: float | None = None,
) -> Scene:
    """Lay ``texture_bgr`` flat at the origin on a procedural floor, with look-alikes.

    Parameters
    ----------
    texture_bgr : the pad's picture (or any picture, e.g. an ArUco marker), BGR or
        grey uint8, seen from above with its top edge toward pad +y.
    size_m : the picture's width in metres; its height follows its aspect ratio.
    rng : numpy Generator (or an int seed) for the floor and the look-alikes.
    floor : "textured" (one of `TEXTURED_KINDS`), "any" (any kind but plain), a kind in
        `FLOOR_KINDS`, or a sequence of kinds to draw one from.
    lookalikes : how many white look-alike shapes to paint beside the picture (0..8).
    lookalike_kinds : the kinds to draw from (subset of `LOOKALIKE_KINDS`).
    pad_visible : False leaves the picture out (floor and look-alikes stay).
    alpha : optional uint8 coverage of the picture (same height and width; 0 lets the
        floor show through, e.g. around a round pad or a painted H).
    lookalike_bgr : the look-alikes' paint (a design's H colour makes harder negatives).
    h_size_m : the H's extent, which the look-alikes' size follows (default: the seed
        pad's, ``H_HEIGHT * size_m``).

    Examples
    --------
    >>> from pipeline.render import make_pad_image
    >>> scene = make_scene(make_pad_image(256), 0.55, rng=0, floor="plain", lookalikes=2)
    >>> len(scene.lookalikes), scene.pad_visible
    (2, True)
    """
    texture = _check_texture(texture_bgr)
    try:
        size_m = float(size_m)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"size_m must be a number, got {size_m!r}") from exc
    if not math.isfinite(size_m) or size_m <= 0:
        raise ValueError(f"size_m must be positive and finite, got {size_m}")
    rng = _as_rng(rng)
    if isinstance(floor, str):
        choices = {"textured": TEXTURED_KINDS, "any": OUTDOOR_KINDS}.get(floor, (floor,))
    else:
        choices = tuple(floor)
    if not choices or any(k not in FLOOR_KINDS for k in choices):
        raise ValueError(
            f"floor must be 'textured', 'any', or kinds from {FLOOR_KINDS}, got {floor!r}"
        )
    floor_kind = str(rng.choice(choices)) if len(choices) > 1 else choices[0]
    if isinstance(lookalikes, bool) or not isinstance(lookalikes, int | np.integer):
        raise ValueError(f"lookalikes must be an integer, got {lookalikes!r}")
    if not 0 <= lookalikes <= 8:
        raise ValueError(f"lookalikes must be in 0..8, got {lookalikes}")
    kinds = tuple(lookalike_kinds)
    if lookalikes and (not kinds or any(k not in LOOKALIKE_KINDS for k in kinds)):
        raise ValueError(f"lookalike_kinds must be a non-empty subset of {LOOKALIKE_KINDS}")

    if alpha is not None:
        alpha = np.asarray(alpha)
        if alpha.shape != texture.shape[:2] or alpha.dtype != np.uint8:
            raise ValueError(
                f"alpha must be uint8 of the picture's size {texture.shape[:2]}, "
                f"got {alpha.dtype} {alpha.shape}"
            )
    paint = np.asarray(lookalike_bgr, np.float32).ravel()
    if paint.size != 3 or not np.all(np.isfinite(paint)) or paint.min() < 0 or paint.max() > 255:
        raise ValueError(f"lookalike_bgr must be three values in 0..255, got {lookalike_bgr!r}")

    tile = make_floor(floor_kind, rng, FLOOR_TILE_PX)
    height_m = size_m * texture.shape[0] / texture.shape[1]
    pad = _make_decal("pad", texture, alpha, (0.0, 0.0), 0.0, size_m)
    h_size = H_HEIGHT * size_m if h_size_m is None else float(h_size_m)
    if not math.isfinite(h_size) or h_size <= 0:
        raise ValueError(f"h_size_m must be positive and finite, got {h_size_m!r}")
    shapes = _place_lookalikes(rng, lookalikes, kinds, size_m, height_m, paint, h_size)
    return Scene(
        floor_kind=floor_kind,
        floor_levels=_floor_pyramid(tile),
        floor_px_per_m=FLOOR_PX_PER_M,
        pad=pad if pad_visible else None,
        pad_width_m=size_m,
        pad_height_m=height_m,
        lookalikes=shapes,
    )


def _check_texture(texture_bgr: np.ndarray) -> np.ndarray:
    if not isinstance(texture_bgr, np.ndarray):
        raise ValueError("texture_bgr must be a numpy array")
    tex = texture_bgr
    if tex.ndim == 2:
        tex = cv2.cvtColor(tex, cv2.COLOR_GRAY2BGR) if tex.size else tex
    if tex.ndim != 3 or tex.shape[2] != 3:
        raise ValueError(f"texture_bgr must be H x W x 3 (BGR) or H x W, got {texture_bgr.shape}")
    if min(tex.shape[:2]) < 2:
        raise ValueError(f"texture_bgr is empty or too small: {texture_bgr.shape}")
    if tex.dtype != np.uint8:
        raise ValueError(f"texture_bgr must be uint8, got {tex.dtype}")
    return np.ascontiguousarray(tex)


def _as_rng(rng: np.random.Generator | int) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, int | np.integer) and not isinstance(rng, bool):
        return np.random.default_rng(int(rng))
    raise ValueError(f"rng must be a numpy.random.Generator or an int seed, got {rng!r}")


def _rot2(angle_deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    return np.array([[c, -s], [s, c]])


def _make_decal(
    kind: str,
    bgr: np.ndarray,
    alpha: np.ndarray | None,
    center_m: tuple[float, float],
    angle_deg: float,
    width_m: float,
) -> Decal:
    """Build a decal's pyramid: premultiplied BGRA with a transparent rim at every level."""
    h, w = bgr.shape[:2]
    a = np.full((h, w), 255, np.uint8) if alpha is None else alpha
    if alpha is None:
        rgba = np.dstack([bgr, a])
    else:
        # Premultiply so that blurring (mip levels, bilinear) mixes colour and coverage right.
        pre = np.rint(bgr.astype(np.float32) * (a[..., None] / np.float32(255)))
        rgba = np.dstack([pre.astype(np.uint8), a])
    b = _DECAL_BORDER
    level = cv2.copyMakeBorder(rgba, b, b, b, b, cv2.BORDER_CONSTANT, value=(0, 0, 0, 0))
    k = w / width_m
    height_m = width_m * h / w
    # Plane -> picture-local metres (undo the rotation and the offset), then to texels:
    # u = (x_local + W/2) * k - 0.5 + b, v = (H/2 - y_local) * k - 0.5 + b.
    rot = np.eye(3)
    rot[:2, :2] = _rot2(-angle_deg)
    shift = np.array([[1, 0, -center_m[0]], [0, 1, -center_m[1]], [0, 0, 1]], np.float64)
    to_tex = np.array(
        [[k, 0, width_m / 2 * k - 0.5 + b], [0, -k, height_m / 2 * k - 0.5 + b], [0, 0, 1]]
    )
    affine = to_tex @ rot @ shift
    levels, maps = [level], [affine]
    inner = min(h, w)
    down = np.array([[0.5, 0, b], [0, 0.5, b], [0, 0, 1]], np.float64)
    while inner // 2 >= _MIN_LEVEL_PX:
        # pyrDown's output texel i is centred on input texel 2i; re-pad the rim it eats.
        smaller = cv2.pyrDown(levels[-1])
        levels.append(
            cv2.copyMakeBorder(smaller, b, b, b, b, cv2.BORDER_CONSTANT, value=(0, 0, 0, 0))
        )
        maps.append(down @ maps[-1])
        inner //= 2
    for arr in levels:
        arr.setflags(write=False)
    return Decal(
        kind=kind,
        center_m=(float(center_m[0]), float(center_m[1])),
        angle_deg=float(angle_deg),
        width_m=float(width_m),
        height_m=float(height_m),
        levels=tuple(levels),
        texel_from_plane=tuple(maps),
        texels_per_m=float(k),
    )


def _floor_pyramid(tile: np.ndarray) -> tuple[np.ndarray, ...]:
    """Mip levels of a periodic tile, each still periodic (wrap-padded before pyrDown)."""
    levels = [tile]
    while levels[-1].shape[0] > 16:
        cur = levels[-1]
        p = 4
        padded = np.pad(cur, ((p, p), (p, p), (0, 0)), mode="wrap")
        levels.append(np.ascontiguousarray(cv2.pyrDown(padded)[p // 2 : -p // 2, p // 2 : -p // 2]))
    for arr in levels:
        arr.setflags(write=False)
    return tuple(levels)


def _place_lookalikes(
    rng: np.random.Generator,
    count: int,
    kinds: tuple[str, ...],
    pad_w: float,
    pad_h: float,
    paint_bgr: np.ndarray,
    h_size: float,
) -> tuple[Decal, ...]:
    """Shapes in the H's paint sized like the H, beside the pad (never on it nor on each other)."""
    placed: list[Decal] = []
    margin = 0.05 * max(pad_w, pad_h)
    reach = 3.0 * max(pad_w, pad_h)
    for _ in range(count):
        kind = str(kinds[int(rng.integers(len(kinds)))])
        mask = make_lookalike(kind, _LOOKALIKE_PX, rng)
        # The masks fill ~0.9 of their square.
        side = h_size / 0.9 * rng.uniform(0.75, 1.4)
        radius = side / math.sqrt(2)
        for _attempt in range(500):
            ang = rng.uniform(0, 2 * math.pi)
            dist = rng.uniform(0.5 * pad_w, reach)
            c = (dist * math.cos(ang), dist * math.sin(ang))
            # Distance from the shape's centre to the pad's rectangle (zero inside it).
            dx = max(abs(c[0]) - pad_w / 2, 0.0)
            dy = max(abs(c[1]) - pad_h / 2, 0.0)
            if math.hypot(dx, dy) < radius + margin:
                continue
            if any(math.dist(c, o.center_m) < radius + o.radius_m + margin for o in placed):
                continue
            break
        else:  # pragma: no cover - the search area is far larger than the shapes
            raise RuntimeError("could not place the look-alikes without overlaps")
        paint = paint_bgr * rng.uniform(0.85, 1.02)
        bgr = np.broadcast_to(np.clip(paint, 0, 255).astype(np.uint8), (*mask.shape, 3))
        placed.append(_make_decal(kind, bgr, mask, c, rng.uniform(0, 360), side))
    return tuple(placed)
