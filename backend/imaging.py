"""Uploaded pictures: what format they are, decoding them, drawing what a reference learned."""

from __future__ import annotations

import cv2
import numpy as np

from backend.image_header import BadHeader, ImageHeader, read_header
from pipeline.picture import decode_picture
from pipeline.reference import Reference


class UnsupportedImage(ValueError):
    """The upload is not a picture we can decode (HTTP 415)."""


class TooManyPixels(ValueError):
    """The picture's header claims more pixels than the budget (HTTP 413)."""


#: The default pixel budget (the ``max_upload_pixels`` setting's default): 40 MP.
DEFAULT_MAX_PIXELS = 40_000_000


def sniff_image(data: bytes) -> str | None:
    """The picture format by its header (png, jpeg, bmp, tiff, webp) or ``None``.

    >>> import cv2, numpy as np
    >>> sniff_image(cv2.imencode(".png", np.zeros((4, 4), np.uint8))[1].tobytes())
    'png'
    >>> sniff_image(b"GIF89a") is None
    True
    """
    try:
        return read_header(data).format
    except BadHeader:
        return None


def decode_image(data: bytes, *, max_pixels: int = DEFAULT_MAX_PIXELS) -> np.ndarray:
    """Decode an uploaded picture to BGR (a transparent ground laid on the shade its
    pad contrasts with: `pipeline.picture.on_ground`).

    The size is read from the header first (:func:`backend.image_header.read_header`):
    over ``max_pixels`` raises :class:`TooManyPixels` without decoding anything, so a
    decompression bomb costs nothing. :class:`UnsupportedImage` when it is not a
    picture we accept or does not decode.
    """
    try:
        header = read_header(data)
    except BadHeader as exc:
        raise UnsupportedImage(str(exc)) from None
    if header.decode_pixels > max_pixels:
        raise TooManyPixels(_over_budget(header, max_pixels))
    name = header.format.upper()
    image = decode_picture(data)
    if image is None or image.size == 0:
        raise UnsupportedImage(f"The file looks like {name} but cannot be decoded.")
    if image.shape[0] * image.shape[1] != header.pixels:
        raise UnsupportedImage(f"The {name} decodes to another size than its header says.")
    return np.asarray(image)


def _over_budget(header: ImageHeader, max_pixels: int) -> str:
    limit = f"the limit of {max_pixels / 1e6:g} MP"
    if header.tile_pixels > header.pixels:
        return f"The TIFF's tiles are larger than {limit}."
    mp = header.pixels / 1e6
    size = f"{mp:,.0f}" if mp >= 100 else f"{mp:.3g}"
    return (
        f"The picture is {header.width} x {header.height} pixels ({size} MP), over {limit}: "
        "scale it down (the pad needs far fewer)."
    )


MARK_BGR = (255, 200, 0)  # the pad's other marks (rings, rims, bars)
LETTER_BGR = (255, 0, 255)  # smaller H's in the H's paint, told apart from it


def draw_reference(reference: Reference) -> np.ndarray:
    """The reference's picture with what it learned drawn on it: its other marks, the
    smaller H's it tells apart from its own (a "HELIPAD"'s letter), and the H's
    corners numbered in their order."""
    out = reference.image.copy()
    width = max(2, round(3 * max(out.shape[:2]) / 800.0))
    # (pad metres -> picture pixels: the affine map that carries the H's corners)
    m_h = np.column_stack([reference.corners_m, np.ones(len(reference.corners_m))])
    to_px, *_ = np.linalg.lstsq(m_h, np.asarray(reference.corners_px, float), rcond=None)
    polygons = [(m.corners_m, MARK_BGR) for m in reference.marks]
    polygons += [(c, LETTER_BGR) for c in reference.lesser_hs]
    for corners_m, colour in polygons:
        px = np.column_stack([corners_m, np.ones(len(corners_m))]) @ to_px
        cv2.polylines(out, [np.round(px).astype(np.int32)], True, colour, width, cv2.LINE_AA)
    return draw_corners(out, reference.corners_px)


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
