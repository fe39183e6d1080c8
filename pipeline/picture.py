"""Pictures as files hold them, made the 8-bit BGR that the pipeline reads.

A pad's picture taken from the web is often a PNG on a transparent ground, and the
colour stored under transparent pixels is arbitrary (mostly black, sometimes
white): read as colour alone, a black H on a transparent ground is a black
picture, and a white H stored over white is a white one. Transparent ground is
laid on the shade that contrasts with the pad's own rim (white under a dark rim,
black under a light one), as the pad would stand out from whatever it is printed
on or cut out against.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

OPAQUE = 128  # alpha from which a pixel counts as the picture's own (not ground)


def decode_picture(data: bytes) -> np.ndarray | None:
    """The picture in ``data`` (any format OpenCV reads) as BGR uint8, transparency
    laid on its ground (`on_ground`); None when it does not decode.

    >>> png = cv2.imencode(".png", np.zeros((20, 20, 4), np.uint8))[1].tobytes()
    >>> decode_picture(png).shape, decode_picture(b"not a picture") is None
    ((20, 20, 3), True)
    """
    buf = np.frombuffer(data, np.uint8)
    if not data.startswith(b"\xff\xd8"):  # (a JPEG holds no transparency)
        try:
            image = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
        except cv2.error:
            image = None
        if image is not None and image.ndim == 3 and image.shape[2] == 4:
            bgra = _eight_bit(image)
            if bgra is not None:
                return on_ground(bgra)
    # (read as colour: that applies the EXIF orientation a camera's photo may carry)
    try:
        return cv2.imdecode(buf, cv2.IMREAD_COLOR)
    except cv2.error:
        return None


def read_picture(path: str | Path) -> np.ndarray:
    """The picture file at ``path`` as `decode_picture` reads it; ValueError when it
    cannot be read as a picture."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror or exc}") from None
    image = decode_picture(data)
    if image is None or image.size == 0:
        raise ValueError(f"cannot read {path} as a picture")
    return image


def on_ground(bgra: np.ndarray) -> np.ndarray:
    """A BGRA uint8 picture laid on the ground that contrasts with its rim (the
    opaque pixels beside transparent ones): BGR uint8.

    >>> h = np.zeros((9, 9, 4), np.uint8); h[2:7, 2:7, 3] = 255  # black, on transparent black
    >>> int(on_ground(h)[0, 0, 0]), int(on_ground(h)[4, 4, 0])
    (255, 0)
    """
    alpha = bgra[..., 3]
    bgr = bgra[..., :3]
    if alpha.min() == 255:
        return bgr.copy()
    opaque = (alpha >= OPAQUE).astype(np.uint8)
    inner = cv2.erode(opaque, np.ones((3, 3), np.uint8), borderValue=1)
    rim = (opaque > 0) & (inner == 0)
    if not rim.any():  # (nothing opaque: nothing to contrast with)
        return bgr.copy()
    luma = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    ground = 255.0 if float(luma[rim].mean()) < 128.0 else 0.0
    a = alpha.astype(np.float32)[..., None] / 255.0
    out = bgr.astype(np.float32) * a + ground * (1.0 - a)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def _eight_bit(image: np.ndarray) -> np.ndarray | None:
    """A picture of 8 or 16 bits a channel as 8 bits (None for other depths)."""
    if image.dtype == np.uint8:
        return image
    if image.dtype == np.uint16:
        return (image >> 8).astype(np.uint8)
    return None
