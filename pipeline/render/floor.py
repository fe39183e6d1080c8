"""Procedural ground textures that tile seamlessly, so the floor never ends.

Every texture is periodic over its tile (noise is upsampled from random grids with
wrap-around borders; joints and stripes divide the period), so the renderer can wrap
texture coordinates and any camera, at any height and tilt, sees only floor.
"""

from __future__ import annotations

import cv2
import numpy as np

FLOOR_KINDS: tuple[str, ...] = (
    "asphalt",
    "concrete",
    "grass",
    "pavers",
    "plain",
    "sand",
    "carpet",
    "wood",
)
"""Ground types. ``"textured"`` in `make_scene` draws one of `TEXTURED_KINDS` (the
benchmark's mix since the start, so its figures stay comparable); ``"any"`` draws one
of every kind but ``"plain"``."""

TEXTURED_KINDS: tuple[str, ...] = ("asphalt", "concrete", "grass", "pavers")
OUTDOOR_KINDS: tuple[str, ...] = tuple(k for k in FLOOR_KINDS if k != "plain")

FLOOR_TILE_PX = 2048
FLOOR_PX_PER_M = 200.0
"""Floor resolution: 5 mm texels, a 10.24 m period."""


def make_floor(kind: str, rng: np.random.Generator, tile_px: int = FLOOR_TILE_PX) -> np.ndarray:
    """A seamless square ground texture of mid grey levels.

    Parameters
    ----------
    kind : one of `FLOOR_KINDS`.
    rng : source of the texture's randomness.
    tile_px : side of the tile in texels; a power of two >= 256 (so every mip level
        keeps the period exact).

    Returns
    -------
    BGR uint8, ``tile_px`` x ``tile_px``; wraps around seamlessly on both axes.

    Examples
    --------
    >>> tile = make_floor("asphalt", np.random.default_rng(0), 256)
    >>> tile.shape, 60 < float(tile.mean()) < 180
    ((256, 256, 3), True)
    """
    if kind not in FLOOR_KINDS:
        raise ValueError(f"kind must be one of {FLOOR_KINDS}, got {kind!r}")
    if not isinstance(rng, np.random.Generator):
        raise ValueError("rng must be a numpy.random.Generator")
    n = int(tile_px)
    if n < 256 or n & (n - 1):
        raise ValueError(f"tile_px must be a power of two >= 256, got {tile_px!r}")
    maker = {
        "asphalt": _asphalt,
        "concrete": _concrete,
        "grass": _grass,
        "pavers": _pavers,
        "plain": _plain,
        "sand": _sand,
        "carpet": _carpet,
        "wood": _wood,
    }[kind]
    bgr = maker(rng, n)
    return np.clip(np.rint(bgr), 0, 255).astype(np.uint8)


def periodic_noise(rng: np.random.Generator, size: int, cells: int) -> np.ndarray:
    """Smooth noise (about unit variance) with ``cells`` features across a tile, periodic.

    ``size`` must be a multiple of ``cells``. Bicubic upsampling of a random grid with
    wrap-around borders keeps the result seamless.
    """
    if size % cells:
        raise ValueError(f"cells must divide size, got size={size}, cells={cells}")
    grid = rng.standard_normal((cells, cells)).astype(np.float32)
    if cells == size:
        return grid
    k = size / cells
    # Output pixel x samples grid coordinate (x + 0.5) / k - 0.5 (pixel centres align).
    m = np.array([[1 / k, 0, 0.5 / k - 0.5], [0, 1 / k, 0.5 / k - 0.5]], np.float64)
    out = cv2.warpAffine(
        grid,
        m,
        (size, size),
        flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_WRAP,
    )
    # Bicubic interpolation of white noise loses variance; put it back so the
    # amplitudes below mean the same at every scale.
    return out / max(float(out.std()), 1e-6)


def _octaves(rng: np.random.Generator, n: int, spec: list[tuple[int, float]]) -> np.ndarray:
    """Sum of periodic noises: (features across the tile, amplitude in grey levels)."""
    total = np.zeros((n, n), np.float32)
    for cells, amp in spec:
        total += amp * periodic_noise(rng, n, min(cells, n))
    return total


def _tint(gray: np.ndarray, bgr: tuple[float, float, float]) -> np.ndarray:
    """A grey image coloured by per-channel factors (mean factor near 1)."""
    return gray[..., None] * np.asarray(bgr, np.float32)[None, None, :]


def _wrap_blur(img: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Filter with wrap-around borders (filter2D has no wrap mode), keeping periodicity."""
    p = max(kernel.shape)
    padded = np.pad(img, ((p, p), (p, p)), mode="wrap")
    return cv2.filter2D(padded, -1, kernel)[p:-p, p:-p]


def _asphalt(rng: np.random.Generator, n: int) -> np.ndarray:
    base = rng.uniform(95, 125)
    gray = base + _octaves(rng, n, [(8, 7), (32, 5), (256, 4), (n // 2, 7), (n, 6)])
    # Aggregate: sparse light and dark grains a texel or two across.
    grains = rng.random((n, n)) < 0.015
    gray[grains] += rng.uniform(20, 45)
    dark = rng.random((n, n)) < 0.01
    gray[dark] -= rng.uniform(15, 30)
    gray = _wrap_blur(gray, np.full((2, 2), 0.25, np.float32))
    img = _tint(gray, (1.03, 1.0, 0.97))
    if rng.random() < 0.5:
        img = _stripe(rng, img, n)
    return img


def _stripe(rng: np.random.Generator, img: np.ndarray, n: int) -> np.ndarray:
    """A worn painted road line across the whole tile (so it stays periodic)."""
    width = int(rng.integers(16, 26))  # 8-13 cm
    pos = int(rng.integers(n))
    colour = np.array((150, 185, 195) if rng.random() < 0.5 else (180, 182, 182), np.float32)
    wear = 0.55 + 0.25 * periodic_noise(rng, n, 64)
    idx = (np.arange(width) + pos) % n
    out = img.copy()
    alpha = np.clip(wear[:, idx], 0, 1)[..., None]
    if rng.random() < 0.5:
        out[:, idx] = out[:, idx] * (1 - alpha) + colour * alpha
    else:
        alpha_t = np.clip(wear[idx, :], 0, 1)[..., None]
        out[idx, :] = out[idx, :] * (1 - alpha_t) + colour * alpha_t
    return out


def _concrete(rng: np.random.Generator, n: int) -> np.ndarray:
    base = rng.uniform(135, 160)
    gray = base + _octaves(rng, n, [(4, 8), (16, 6), (64, 3), (n // 2, 3), (n, 2.5)])
    # Expansion joints: thin dark grooves on a grid that divides the period.
    step = n // int(rng.choice([4, 8]))
    for k in range(step // 2, n, step):
        gray[:, k : k + 2] -= 35
        gray[k : k + 2, :] -= 35
    return _tint(gray, (0.99, 1.0, 1.01))


def _grass(rng: np.random.Generator, n: int) -> np.ndarray:
    base = rng.uniform(80, 105)
    blades = rng.standard_normal((n, n)).astype(np.float32)
    angle = rng.uniform(0, np.pi)
    # Short blades (2-3 cm) along a prevailing direction, plus isotropic clutter.
    kernel = np.zeros((5, 5), np.float32)
    for t in np.linspace(-2, 2, 5):
        kernel[round(2 + t * np.sin(angle)), round(2 + t * np.cos(angle))] = 1.0
    blades = _wrap_blur(blades, kernel / kernel.sum()) * 2.2
    clutter = _octaves(rng, n, [(8, 8), (32, 6), (128, 4), (n // 2, 5), (n, 4)])
    gray = base + 9 * blades + clutter
    patches = periodic_noise(rng, n, 16)
    img = _tint(gray, (0.75, 1.12, 0.95))
    # Dry patches turn the green toward straw.
    dry = np.clip(0.5 + 0.4 * patches, 0, 1)[..., None]
    straw = _tint(gray, (0.85, 1.05, 1.12))
    return img * (1 - dry) + straw * dry


def _pavers(rng: np.random.Generator, n: int) -> np.ndarray:
    cells = int(rng.choice([16, 32]))  # 0.32 m or 0.64 m stones at the default scale
    size = n // cells
    base = rng.uniform(110, 145)
    per_stone = rng.normal(0, 7, (cells, cells)).astype(np.float32)
    gray = base + np.kron(per_stone, np.ones((size, size), np.float32))
    gray += _octaves(rng, n, [(n // 4, 3), (n // 2, 4), (n, 3)])
    joint = max(2, size // 24)
    for k in range(0, n, size):
        gray[:, k : k + joint] = base - 40
        gray[k : k + joint, :] = base - 40
    # Move the joints half a stone in from the tile's edge so the wrap seam is plain stone.
    gray = np.roll(gray, (size // 2, size // 2), axis=(0, 1))
    gray = _wrap_blur(gray, np.full((3, 3), 1 / 9, np.float32))
    warm = rng.uniform(-0.05, 0.08)
    return _tint(gray, (1.0 - warm, 1.0, 1.0 + warm))


def _plain(rng: np.random.Generator, n: int) -> np.ndarray:
    gray = rng.uniform(110, 140) + _octaves(rng, n, [(8, 1.5), (n, 1.0)])
    return _tint(gray, (1.0, 1.0, 1.0))


def _sand(rng: np.random.Generator, n: int) -> np.ndarray:
    base = rng.uniform(140, 158)
    gray = base + _octaves(rng, n, [(4, 6), (16, 5), (64, 3), (n // 2, 4), (n, 6)])
    # Wind ripples: a few centimetres apart, wavy, along one of the tile's axes.
    ys = np.arange(n, dtype=np.float32)[:, None]
    waves = int(rng.choice([128, 256]))
    wobble = 3.0 * periodic_noise(rng, n, 8)
    gray += rng.uniform(3, 7) * np.sin(2 * np.pi * (waves * ys / n) + wobble)
    pebbles = rng.random((n, n)) < 0.004
    gray[pebbles] -= rng.uniform(25, 45)
    gray = _wrap_blur(gray, np.full((2, 2), 0.25, np.float32))
    return _tint(gray, (0.82, 1.0, 1.12))


def _carpet(rng: np.random.Generator, n: int) -> np.ndarray:
    # Loop pile: fine fibre noise over a faint woven grid, in a dyed colour.
    base = rng.uniform(95, 125)
    fibres = rng.standard_normal((n, n)).astype(np.float32)
    fibres = _wrap_blur(fibres, np.full((2, 2), 0.25, np.float32)) * 10
    ys, xs = np.mgrid[0:n, 0:n].astype(np.float32)
    weave = 4 * np.sin(2 * np.pi * xs / 4) * np.sin(2 * np.pi * ys / 4)
    gray = base + fibres + weave + _octaves(rng, n, [(4, 5), (32, 3)])
    dyes = [(1.25, 0.9, 0.8), (0.8, 0.85, 1.3), (0.95, 1.0, 1.05), (0.85, 1.1, 0.9)]
    return _tint(gray, dyes[int(rng.integers(len(dyes)))])


def _wood(rng: np.random.Generator, n: int) -> np.ndarray:
    # Deck boards: planks along x, each with its own shade and grain, dark joints.
    planks = int(rng.choice([16, 32]))  # 0.64 m or 0.32 m wide boards at 5 mm texels
    size = n // planks
    base = rng.uniform(105, 135)
    shade = rng.normal(0, 9, planks).astype(np.float32)
    rows = np.repeat(shade, size)[:, None]
    ys = np.arange(n, dtype=np.float32)[:, None]
    wobble = 4.0 * periodic_noise(rng, n, 16)
    grain = 5 * np.sin(2 * np.pi * (ys / 8.0) + wobble) + 3 * periodic_noise(rng, n, n // 4)
    gray = base + rows + grain + _octaves(rng, n, [(8, 4), (n // 2, 3)])
    joint = max(2, size // 40)
    for k in range(0, n, size):
        gray[k : k + joint, :] = base - 45
    gray = np.roll(gray, size // 2, axis=0)
    return _tint(gray, (0.72, 0.95, 1.25))
