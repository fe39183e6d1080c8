"""Uploaded pictures: what format they are, decoding them, marking the H's corners."""

from __future__ import annotations

import cv2
import numpy as np


class UnsupportedImage(ValueError):
    """The upload is not a picture we can decode (HTTP 415)."""


_MAGIC = (
    (b"\x89PNG\r\n\x1a\n", "png"),
    (b"\xff\xd8\xff", "jpeg"),
    (b"BM", "bmp"),
    (b"II*\x00", "tiff"),
    (b"MM\x00*", "tiff"),
)


def sniff_image(data: bytes) -> str | None:
    """The picture format by its magic bytes (png, jpeg, bmp, tiff, webp) or ``None``.

    >>> sniff_image(b"\\x89PNG\\r\\n\\x1a\\n..."), sniff_image(b"GIF89a")
    ('png', None)
    """
    for magic, kind in _MAGIC:
        if data.startswith(magic):
            return kind
    if len(data) >= 12 and data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return "webp"
    return None


def decode_image(data: bytes) -> np.ndarray:
    """Decode an uploaded picture to BGR; :class:`UnsupportedImage` when it is not one."""
    kind = sniff_image(data)
    if kind is None:
        raise UnsupportedImage("The file is not a picture: expected PNG, JPEG, BMP, TIFF or WebP.")
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if image is None or image.size == 0:
        raise UnsupportedImage(f"The file looks like {kind.upper()} but cannot be decoded.")
    return np.asarray(image)


def draw_corners(image_bgr: np.ndarray, corners_px: np.ndarray) -> np.ndarray:
    """The picture with the H's corners marked and numbered in their order."""
    out = image_bgr.copy()
    scale = max(out.shape[:2]) / 800.0
    pts = np.asarray(corners_px, float).reshape(-1, 2)
    cv2.polylines(
        out, [np.round(pts).astype(np.int32)], True, (0, 200, 255), max(1, round(2 * scale))
    )
    for i, (x, y) in enumerate(pts):
        c = (round(x), round(y))
        cv2.circle(out, c, max(3, round(7 * scale)), (0, 0, 255), -1)
        cv2.putText(
            out,
            str(i),
            (c[0] + round(8 * scale), c[1] - round(8 * scale)),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.8 * scale,
            (0, 255, 0),
            max(1, round(2 * scale)),
            cv2.LINE_AA,
        )
    return out
