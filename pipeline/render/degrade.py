"""Camera degradations: light, shadows, glare, blur, exposure, sensor noise, JPEG.

`degrade` applies them in the order a camera meets them: the scene's illumination
(lighting gain, cast shadow) and specular glare, then the optics' and the motion's
blur, the exposure's gain, the sensor's noise, the response curve (gamma) with
clipping, and last the encoder's JPEG compression. With only lighting, blur and
noise it is the dissertation's order, as it always was.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class Lighting:
    """Illumination and lens fall-off, as a per-pixel gain on the clean image.

    gain(x, y) = ``gain`` * (1 + ``gradient`` * d) * (1 - ``vignetting`` * r**2), where
    d is the pixel's offset from the image centre along ``gradient_dir_deg`` (0: image
    right, 90: image down) and r its distance from the centre, both in units of the
    half diagonal (so a corner has r = 1).

    Examples
    --------
    >>> Lighting(gain=1.2).gain_map(4, 2).shape
    (2, 4)
    """

    gain: float = 1.0
    gradient: float = 0.0
    gradient_dir_deg: float = 0.0
    vignetting: float = 0.0

    def __post_init__(self) -> None:
        for name in ("gain", "gradient", "gradient_dir_deg", "vignetting"):
            value = getattr(self, name)
            if not isinstance(value, int | float) or not math.isfinite(value):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
        if self.gain <= 0:
            raise ValueError(f"gain must be positive, got {self.gain}")
        if not 0 <= self.gradient < 1:
            raise ValueError(f"gradient must be in [0, 1), got {self.gradient}")
        if not 0 <= self.vignetting < 1:
            raise ValueError(f"vignetting must be in [0, 1), got {self.vignetting}")

    def gain_map(self, width: int, height: int) -> np.ndarray:
        """The per-pixel gain (float32, ``height`` x ``width``)."""
        half_diag = math.hypot(width - 1, height - 1) / 2 or 1.0
        xs = (np.arange(width, dtype=np.float32) - (width - 1) / 2) / half_diag
        ys = (np.arange(height, dtype=np.float32) - (height - 1) / 2) / half_diag
        ang = math.radians(self.gradient_dir_deg)
        gx = np.float32(self.gradient * math.cos(ang))
        gy = np.float32(self.gradient * math.sin(ang))
        lin = 1 + gx * xs[None, :] + gy * ys[:, None]
        vig = 1 - np.float32(self.vignetting) * (xs[None, :] ** 2 + ys[:, None] ** 2)
        return (np.float32(self.gain) * lin * vig).astype(np.float32)


def _number(value: object, name: str, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(f"{name} must be a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out) or not lo <= out <= hi:
        raise ValueError(f"{name} must be in [{lo}, {hi}], got {value!r}")
    return out


@dataclass(frozen=True)
class MotionBlur:
    """The camera moving during the exposure: a straight smear ``length_px`` long.

    ``angle_deg``: the smear's direction in the image, counter-clockwise from image
    right as seen on screen (0: horizontal, 90: vertical).

    Examples
    --------
    >>> k = MotionBlur(5.0, 0.0).kernel()
    >>> k.shape, round(float(k.sum()), 6), bool(k[4].sum() > 0.99)  # all on the middle row
    ((9, 9), 1.0, True)
    """

    length_px: float
    angle_deg: float = 0.0

    def __post_init__(self) -> None:
        _number(self.length_px, "length_px", 0.0, 64.0)
        _number(self.angle_deg, "angle_deg", -360.0, 360.0)

    def kernel(self) -> np.ndarray:
        """A normalised line kernel, anti-aliased along its length and across it."""
        half = self.length_px / 2
        r = math.ceil(half) + 1
        ang = math.radians(self.angle_deg)
        d = np.array([math.cos(ang), -math.sin(ang)])  # image y points down
        ys, xs = np.mgrid[-r : r + 1, -r : r + 1].astype(np.float64)
        # Sample the segment finely; spread each sample bilinearly over the grid.
        k = np.zeros_like(xs)
        ts = np.linspace(-half, half, max(2, int(8 * self.length_px) + 1))
        for t in ts:
            px, py = t * d
            k += np.clip(1 - np.abs(xs - px), 0, None) * np.clip(1 - np.abs(ys - py), 0, None)
        return (k / k.sum()).astype(np.float32)


@dataclass(frozen=True)
class Shadow:
    """A soft shadow cast across the ground (a pole, a branch, a building's edge).

    ``polygon_m``: the shadow's outline on the pad plane (N x 2, metres, pad frame);
    ``darkness``: the share of the light it takes away (0..0.95); ``softness_px``:
    the penumbra's Gaussian sigma in image pixels.
    """

    polygon_m: tuple[tuple[float, float], ...]
    darkness: float = 0.5
    softness_px: float = 2.0

    def __post_init__(self) -> None:
        pts = np.asarray(self.polygon_m, np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3 or not np.all(np.isfinite(pts)):
            raise ValueError(f"polygon_m must be 3 or more finite (x, y) points, got {pts.shape}")
        _number(self.darkness, "darkness", 0.0, 0.95)
        _number(self.softness_px, "softness_px", 0.0, 100.0)


@dataclass(frozen=True)
class Glare:
    """Sun glare: a specular bright blob added to the picture, saturating at its core.

    A Gaussian of sigma ``radius_px`` at ``center_px`` (x, y) adding up to
    ``strength`` grey levels, slightly warm.
    """

    center_px: tuple[float, float]
    radius_px: float
    strength: float

    def __post_init__(self) -> None:
        if len(self.center_px) != 2:
            raise ValueError(f"center_px must be (x, y), got {self.center_px!r}")
        for v in self.center_px:
            _number(v, "center_px", -1e6, 1e6)
        _number(self.radius_px, "radius_px", 0.5, 1e4)
        _number(self.strength, "strength", 0.0, 2000.0)

    def add_to(self, img: np.ndarray) -> None:
        """Add the blob to a float32 image in place."""
        h, w = img.shape[:2]
        x0, y0 = self.center_px
        r = self.radius_px
        gx = np.exp(-0.5 * ((np.arange(w, dtype=np.float32) - x0) / r) ** 2)
        gy = np.exp(-0.5 * ((np.arange(h, dtype=np.float32) - y0) / r) ** 2)
        blob = np.float32(self.strength) * np.outer(gy, gx)
        if img.ndim == 3:
            tint = np.array([0.94, 0.98, 1.0][: img.shape[2]], np.float32)
            img += blob[..., None] * tint
        else:
            img += blob


@dataclass(frozen=True)
class Exposure:
    """Exposure and the camera's response: ``gain`` before the noise, then
    out = 255 * (in / 255) ** ``gamma`` after it; what passes 255 clips."""

    gain: float = 1.0
    gamma: float = 1.0

    def __post_init__(self) -> None:
        _number(self.gain, "gain", 0.05, 10.0)
        _number(self.gamma, "gamma", 0.2, 5.0)


def random_lighting(rng: np.random.Generator) -> Lighting:
    """Lighting of an outdoor scene seen by a small camera: exposure, a gradient, fall-off.

    Examples
    --------
    >>> 0.6 < random_lighting(np.random.default_rng(1)).gain < 1.3
    True
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError("rng must be a numpy.random.Generator")
    return Lighting(
        gain=float(rng.uniform(0.65, 1.25)),
        gradient=float(rng.uniform(0.0, 0.35)),
        gradient_dir_deg=float(rng.uniform(0.0, 360.0)),
        vignetting=float(rng.uniform(0.0, 0.35)),
    )


def check_degradations(
    snr_db: float | None, blur_sigma_px: float, light: Lighting | None, rng: object
) -> None:
    """Raise ValueError naming the parameter when a degradation option is unusable."""
    if snr_db is not None:
        if isinstance(snr_db, bool) or not isinstance(snr_db, int | float | np.floating):
            raise ValueError(f"snr_db must be a number or None, got {snr_db!r}")
        if not math.isfinite(snr_db):
            raise ValueError(f"snr_db must be finite, got {snr_db}")
        if not isinstance(rng, np.random.Generator):
            raise ValueError("rng: a numpy.random.Generator is required when snr_db is set")
    if isinstance(blur_sigma_px, bool) or not isinstance(blur_sigma_px, int | float | np.floating):
        raise ValueError(f"blur_sigma_px must be a number, got {blur_sigma_px!r}")
    if not math.isfinite(blur_sigma_px) or blur_sigma_px < 0:
        raise ValueError(f"blur_sigma_px must be finite and >= 0, got {blur_sigma_px}")
    if light is not None and not isinstance(light, Lighting):
        raise ValueError(f"light must be a Lighting or None, got {type(light).__name__}")
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise ValueError("rng must be a numpy.random.Generator or None")


def check_extras(
    motion_blur: MotionBlur | None,
    glare: Glare | None,
    exposure: Exposure | None,
    jpeg_quality: int | None,
) -> None:
    """Raise ValueError naming the parameter when a newer degradation is unusable."""
    for value, kind, name in (
        (motion_blur, MotionBlur, "motion_blur"),
        (glare, Glare, "glare"),
        (exposure, Exposure, "exposure"),
    ):
        if value is not None and not isinstance(value, kind):
            raise ValueError(f"{name} must be a {kind.__name__} or None, got {value!r}")
    if jpeg_quality is not None and (
        isinstance(jpeg_quality, bool)
        or not isinstance(jpeg_quality, int | np.integer)
        or not 1 <= jpeg_quality <= 100
    ):
        raise ValueError(f"jpeg_quality must be an integer in 1..100 or None, got {jpeg_quality!r}")


def degrade(
    clean: np.ndarray,
    *,
    light: Lighting | None = None,
    blur_sigma_px: float = 0.0,
    snr_db: float | None = None,
    rng: np.random.Generator | None = None,
    shade: np.ndarray | None = None,
    glare: Glare | None = None,
    motion_blur: MotionBlur | None = None,
    exposure: Exposure | None = None,
    jpeg_quality: int | None = None,
) -> np.ndarray:
    """Lighting, shade and glare; Gaussian then motion blur; exposure gain; white
    Gaussian noise; gamma; clipping to uint8; JPEG compression.

    ``shade`` is a per-pixel light factor (float, the image's height and width), e.g.
    a cast shadow's; the other options are described by their classes. Each step is
    skipped when its option is None (or 0 for the blur).

    The noise power is set from the measured power of the image it is added to
    (mean of the squared pixel values, MATLAB's ``awgn(..., 'measured')``):
    sigma**2 = P / 10**(snr_db / 10), independently per pixel and channel.

    Examples
    --------
    >>> img = np.full((48, 64, 3), 120, np.uint8)
    >>> out = degrade(img, snr_db=20.0, rng=np.random.default_rng(0))
    >>> bool(18 < 10 * np.log10(120.0**2 / np.mean((out - 120.0) ** 2)) < 22)
    True
    """
    check_degradations(snr_db, blur_sigma_px, light, rng)
    check_extras(motion_blur, glare, exposure, jpeg_quality)
    if shade is not None and np.shape(shade) != clean.shape[:2]:
        raise ValueError(f"shade must be {clean.shape[:2]}, got {np.shape(shade)}")
    img = clean.astype(np.float32)  # always a copy: the caller's image stays as it was
    if light is not None:
        gain = light.gain_map(img.shape[1], img.shape[0])
        img *= gain[..., None] if img.ndim == 3 else gain
    if shade is not None:
        s = np.asarray(shade, np.float32)
        img *= s[..., None] if img.ndim == 3 else s
    if glare is not None:
        glare.add_to(img)
    if blur_sigma_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), float(blur_sigma_px), borderType=cv2.BORDER_REFLECT)
    if motion_blur is not None and motion_blur.length_px > 0:
        img = cv2.filter2D(img, -1, motion_blur.kernel(), borderType=cv2.BORDER_REFLECT)
    if exposure is not None:
        img *= np.float32(exposure.gain)
    if snr_db is not None:
        channels = img.shape[2] if img.ndim == 3 else 1
        power = float(np.mean(cv2.mean(cv2.multiply(img, img))[:channels]))
        sigma = math.sqrt(power / 10 ** (float(snr_db) / 10))
        noise = np.empty_like(img)
        # cv2.randn is ~4x faster than numpy's normal sampler; seeding it from the
        # caller's Generator keeps the frames reproducible (its RNG is per thread).
        cv2.setRNGSeed(int(rng.integers(1, 2**31 - 1)))
        cv2.randn(noise, (0.0,) * channels, (sigma,) * channels)
        img += noise
    np.clip(img, 0, 255, out=img)
    if exposure is not None and exposure.gamma != 1.0:
        img = (np.float32(255) * (img / np.float32(255)) ** np.float32(exposure.gamma)).astype(
            np.float32
        )
    img += 0.5
    out = img.astype(np.uint8)
    if jpeg_quality is not None:
        ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
        if not ok:  # pragma: no cover - OpenCV encodes any uint8 picture
            raise RuntimeError("JPEG encoding failed")
        flag = cv2.IMREAD_COLOR if out.ndim == 3 else cv2.IMREAD_GRAYSCALE
        out = cv2.imdecode(buf, flag)
    return out
