"""Frame preprocessing: input checks, subsampling, the reference's channel, thresholding.

Frames are turned into one channel in which the reference's H is bright (its
learned colour projection, ``pipeline.colour``: plain BT.601 gray for the
seed's white H on a dark board, inverted gray for a dark H on paper, a colour
axis for a white H on an orange disc). Five thresholding methods, all selectable:

``"seed"``
    The dissertation's chain (section 4.1.1): BT.601 gray, a 3x3 Laplacian
    added back to the gray image, a 3x3 average of that, added to the gray
    image again, then a global threshold at 85 % of full scale. It breaks when
    the light changes: measured in ``python -m pipeline.bench``.
``"otsu"``
    Gaussian smoothing (for the sensor noise) and Otsu's global threshold,
    which adapts to exposure but not to light that changes across the frame.
``"shadow"``
    The local mean threshold on the logarithm of the light: a shadow scales
    the light, which the logarithm turns into an offset the local mean takes
    out, so the H stays whole across a shadow's edge. ``process_frame`` tries
    it when the default finds nothing.
``"tophat"``
    The logarithm of the light against its opening (a 41 px square): the
    opening keeps the board, the floor and a shadow of any width, and takes
    away paint narrower than the square, so what stands 41 % above it is
    paint, in the sun or in the shade alike. A local mean does not: a shadow
    band narrower than its block darkens the mean around it, marking the sunlit
    floor along the band and losing the stroke inside it. ``process_frame``
    tries it after "shadow".
``"adaptive"``
    Gaussian smoothing and a local mean threshold (41 px blocks): only what is
    clearly brighter than its surroundings, like paint on a dark board, stays
    white, whatever the light gradient. The default: on ``python -m
    pipeline.bench`` it detected the most pads (200/200 against 198/200 for
    Otsu and 197/200 for the seed's) with the same accuracy, and it is the
    fastest, since a textured floor leaves fewer regions to examine.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.colour import GRAY, Projection
from pipeline.picture import on_ground

METHODS = ("adaptive", "otsu", "seed", "shadow", "tophat")
DEFAULT_METHOD = "adaptive"
WORK_WIDTH = 640  # the seed's working resolution: 640 x 480
# "tophat": the opening's square (as wide as "adaptive"'s block), and how far above it
# paint stands, in `log_light` levels (46 an e-fold): 16 is 41 % brighter. On the
# bench's views with a shadow across the pad (10 designs, 160 views), tried after
# "shadow", 135 pads were found against 121; 12 and 22 found 132 and 134, squares
# of 31 and 61 px 136 and 132.
TOPHAT_SIDE_PX, TOPHAT_RISE = 41, 16
# A pad whose paint stands out less (faded paint, `tophat_rise`) is looked for at this
# share of its own rise on its picture, down to the least rise above the noise.
TOPHAT_SHARE, MIN_TOPHAT_RISE = 0.4, 5.0


def check_image(image: object, name: str = "image_bgr") -> np.ndarray:
    """Return ``image`` as a BGR uint8 array (from BGR, gray, or BGRA laid on the
    ground its rim contrasts with: `pipeline.picture.on_ground`), or raise ValueError
    naming ``name``."""
    if image is None:
        raise ValueError(f"{name} is None; expected an H x W x 3 uint8 BGR image")
    if not isinstance(image, np.ndarray):
        raise ValueError(f"{name} must be a numpy array, got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise ValueError(f"{name} must have dtype uint8, got {image.dtype}")
    if image.ndim == 2:
        image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    elif image.ndim == 3 and image.shape[2] == 4:
        image = on_ground(image)  # (what lies under transparent pixels is no colour)
    elif not (image.ndim == 3 and image.shape[2] == 3):
        raise ValueError(
            f"{name} must be H x W x 3 (BGR), H x W x 4 (BGRA) or H x W, got shape {image.shape}"
        )
    if image.shape[0] < 16 or image.shape[1] < 16:
        raise ValueError(f"{name} is too small ({image.shape[1]}x{image.shape[0]}); need >= 16x16")
    return image


def border_pixels(image: np.ndarray, width: int) -> np.ndarray:
    """The values of the band ``width`` pixels wide along the image's edge (corners twice)."""
    w = max(1, int(width))
    return np.concatenate(
        [image[:w].ravel(), image[-w:].ravel(), image[:, :w].ravel(), image[:, -w:].ravel()]
    )


def subsample(image: np.ndarray, max_width: int = WORK_WIDTH) -> tuple[np.ndarray, float]:
    """Shrink ``image`` to at most ``max_width`` columns (`shrink`).

    Returns the image and the scale factor (work pixels per input pixel).
    """
    width = image.shape[1]
    if width <= max_width:
        return image, 1.0
    scale = max_width / width
    height = max(1, round(image.shape[0] * scale))
    return shrink(image, (max_width, height)), scale


Halvings = list[tuple[np.ndarray, bool]]
"""An image halved once, twice, ... by `shrink`, each with whether it was padded."""


def shrink(
    image: np.ndarray, size: tuple[int, int], halvings: Halvings | None = None
) -> np.ndarray:
    """``image`` resized down to ``size`` (width, height), pixel centres kept as
    cv2.resize keeps them: halved (the mean of each 2 x 2 block) while it is still at
    least twice the size, then the rest (under a factor 2) interpolated linearly.
    ``halvings``: those of ``image`` made before, taken and added to (a frame's
    views of 640 and 320 px share its halving, 0.5 ms of a 1920 x 1080 frame).

    Area interpolation does the same in one step, but at a factor that is not a
    whole number it cost 3 ms on a 1000 px square crop of a 1920 x 1080 frame; the
    halvings and the last step, 0.5 ms."""
    w, h = size
    img, factor, padded = image, 1, False
    level = 0
    while img.shape[1] >= 2 * w and img.shape[0] >= 2 * h:
        if halvings is not None and level < len(halvings):
            img, padded = halvings[level]
        else:
            rows, cols = img.shape[:2]
            if rows % 2 or cols % 2:  # (a whole block at the far edge: its copy)
                img = cv2.copyMakeBorder(img, 0, rows % 2, 0, cols % 2, cv2.BORDER_REPLICATE)
                padded = True
            size_2 = (img.shape[1] // 2, img.shape[0] // 2)
            img = cv2.resize(img, size_2, interpolation=cv2.INTER_AREA)
            if halvings is not None:
                halvings.append((img, padded))
        level += 1
        factor *= 2
    if not padded:
        return cv2.resize(img, size, interpolation=cv2.INTER_LINEAR)
    # The halved image reaches past the image's far edge: map its pixels explicitly.
    sx, sy = factor * w / image.shape[1], factor * h / image.shape[0]
    M = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5]])
    return cv2.warpAffine(img, M, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def to_gray(image_bgr: np.ndarray) -> np.ndarray:
    """BT.601 luma (0.299 R + 0.587 G + 0.114 B), as cv2.cvtColor computes it."""
    return cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)


@dataclass(frozen=True, eq=False)
class Binarized:
    """A frame ready for shape analysis: smoothed gray (for sub-pixel edges) and mask."""

    gray: np.ndarray
    smooth: np.ndarray
    mask: np.ndarray
    threshold: float


def seed_enhance(gray: np.ndarray) -> np.ndarray:
    """The seed's Laplacian + average enhancement (MATLAB fspecial defaults), float32."""
    g = gray.astype(np.float32)
    # fspecial('laplacian', 0.2): centre -10/3, edges 2/3, diagonals 1/6.
    lap_kernel = np.array([[1, 4, 1], [4, -20, 4], [1, 4, 1]], np.float32) / 6.0
    lap = cv2.filter2D(g, -1, lap_kernel, borderType=cv2.BORDER_REPLICATE)
    # The centre is negative, so the sharpened image is gray - Laplacian.
    sharp = np.clip(g - lap, 0, 255)
    smoothed = cv2.blur(sharp, (3, 3), borderType=cv2.BORDER_REPLICATE)
    # MATLAB adds uint8 images with saturation: gray + smoothed, clipped at 255.
    return np.clip(g + smoothed, 0, 255)


def has_colour(image_bgr: np.ndarray) -> bool:
    """Whether the picture's channels differ (a gray camera repeats one channel)."""
    sample = image_bgr[::7, ::7]
    return bool(
        np.any(sample[..., 0] != sample[..., 1]) or np.any(sample[..., 1] != sample[..., 2])
    )


def to_channel(image_bgr: np.ndarray, projection: Projection = GRAY) -> np.ndarray:
    """The frame on the reference's channel (uint8): its H bright, its board dark."""
    if image_bgr.ndim == 2:
        return projection.apply_gray(image_bgr)
    # (luma is the same whether or not the picture has colour: no need to look)
    if projection.is_gray or has_colour(image_bgr):
        return projection.apply(image_bgr)
    return projection.apply_gray(image_bgr[..., 0].copy())


def smooth_channel(image_bgr: np.ndarray, projection: Projection = GRAY) -> np.ndarray:
    """The frame on ``projection``'s channel, smoothed for the sensor noise (as
    `binarize` smooths it before thresholding)."""
    return smooth(to_channel(image_bgr, projection))


def log_light(channel: np.ndarray, dark: bool) -> np.ndarray:
    """The channel on a log scale of the light (uint8); ``dark``: the channel is
    inverted luma (a dark H made bright), whose light is 255 minus it."""
    return cv2.LUT(channel, _LOG_DARK if dark else _LOG_LIGHT)


def _log_table(dark: bool) -> np.ndarray:
    scale = 255.0 / np.log(256.0)
    v = np.arange(256, dtype=np.float32)
    if dark:
        return (255.0 - scale * np.log1p(255.0 - v)).astype(np.uint8)
    return (scale * np.log1p(v)).astype(np.uint8)


_LOG_LIGHT, _LOG_DARK = _log_table(False), _log_table(True)


def smooth(channel: np.ndarray) -> np.ndarray:
    """A channel smoothed for the sensor noise (as `binarize_channel` smooths it)."""
    return cv2.GaussianBlur(channel, (5, 5), 1.0)


def chroma_levels(image_bgr: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """A BGR picture read on a chroma's weights (`pipeline.reference.Reference.board_chroma`),
    as float32 levels smoothed for the sensor noise (`smooth`): signed, unscaled, so that
    a board's chroma keeps its full step against a grey floor (fitted to the uint8 range
    over the colour cube, a blue board's step on grass came to two thirds of it, its
    blurred edge under the drop an edge needs).

    >>> img = np.zeros((8, 8, 3), np.uint8); img[:, 4:] = (200, 100, 0)
    >>> w = np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)
    >>> [round(float(v), 1) for v in chroma_levels(img, w)[4, [0, 7]]]
    [0.0, 141.4]
    """
    if image_bgr.size == 0:  # (a box beyond the picture)
        return np.zeros(image_bgr.shape[:2], np.float32)
    levels = cv2.transform(
        image_bgr.astype(np.float32), np.asarray(weights, np.float32).reshape(1, 3)
    )
    return smooth(levels.reshape(image_bgr.shape[:2]))


def above_local_mean(channel: np.ndarray, block: int, by: int) -> np.ndarray:
    """255 where a uint8 channel is more than ``by`` (>= 0) above its mean over the
    ``block`` x ``block`` square around it (the border replicated), else 0: what
    ``cv2.adaptiveThreshold(channel, 255, ADAPTIVE_THRESH_MEAN_C, THRESH_BINARY, block,
    -by)`` gives, pixel for pixel, in two thirds of its time (its comparison is a table
    lookup per pixel; these are vector passes)."""
    mean = cv2.boxFilter(
        channel, -1, (block, block), borderType=cv2.BORDER_REPLICATE | cv2.BORDER_ISOLATED
    )
    # (mean + by saturates at 255, where no pixel can be above it: as OpenCV's; in
    # place: a fresh frame-sized array is memory to fetch, the mean's is in cache)
    cv2.add(mean, by, dst=mean)
    return cv2.compare(channel, mean, cv2.CMP_GT, dst=mean)


def binarize(
    image_bgr: np.ndarray, method: str = DEFAULT_METHOD, projection: Projection = GRAY
) -> Binarized:
    """Threshold a BGR frame on ``projection``'s channel: the H's paint -> 255, the rest -> 0."""
    return binarize_channel(to_channel(image_bgr, projection), method)


def tophat_rise(light_contrast: float) -> float:
    """The rise of "tophat" for a pad whose paint stands ``light_contrast`` above its
    board on its picture (`log_light` levels).

    On a probe pad of faded paint (gray 140 on 95: 18 levels), 15 of 30 views of the
    bench's real-world mix were found at 5-7 against 11 at 16: the four more, each
    with a shadow's edge or band across the pad, which every threshold lost the H
    in at 16. The ten designs' and the photos' references stand 54-107 above their
    boards: their rise stays 16."""
    return max(MIN_TOPHAT_RISE, min(TOPHAT_RISE, TOPHAT_SHARE * light_contrast))


def binarize_channel(
    gray: np.ndarray,
    method: str = DEFAULT_METHOD,
    *,
    dark: bool = False,
    rise: float = TOPHAT_RISE,
) -> Binarized:
    """Threshold one channel (uint8) in which the marks to find are bright.

    ``dark``: the channel is inverted luma (for "shadow" and "tophat", which work on
    the light). ``rise``: "tophat"'s, how far paint stands above the ground around it
    (`tophat_rise`).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    smoothed = smooth(gray)
    if method == "otsu":
        t, mask = cv2.threshold(smoothed, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    elif method == "adaptive":
        mask = above_local_mean(smoothed, 41, 12)
        t = float("nan")
    elif method == "shadow":
        mask = above_local_mean(log_light(smoothed, dark), 41, 8)
        t = float("nan")
    elif method == "tophat":
        light = log_light(smoothed, dark)
        square = cv2.getStructuringElement(cv2.MORPH_RECT, (TOPHAT_SIDE_PX, TOPHAT_SIDE_PX))
        ground = cv2.morphologyEx(light, cv2.MORPH_OPEN, square)
        _, mask = cv2.threshold(cv2.subtract(light, ground), rise, 255, cv2.THRESH_BINARY)
        t = float("nan")
    else:
        enhanced = seed_enhance(gray)
        t = 0.85 * 255.0
        mask = np.where(enhanced > t, 255, 0).astype(np.uint8)
    return Binarized(gray=gray, smooth=smoothed, mask=mask, threshold=float(t))
