"""Camera degradations: uneven light, blur, sensor noise, in the dissertation's order."""

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


def degrade(
    clean: np.ndarray,
    *,
    light: Lighting | None = None,
    blur_sigma_px: float = 0.0,
    snr_db: float | None = None,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """Lighting, then Gaussian blur, then white Gaussian noise, then clipping to uint8.

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
    img = clean.astype(np.float32)  # always a copy: the caller's image stays as it was
    if light is not None:
        gain = light.gain_map(img.shape[1], img.shape[0])
        img *= gain[..., None] if img.ndim == 3 else gain
    if blur_sigma_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), float(blur_sigma_px), borderType=cv2.BORDER_REFLECT)
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
    img += 0.5
    return img.astype(np.uint8)
