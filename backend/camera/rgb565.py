"""CMUcam4 pixel formats: RGB565 frames sent column by column, and the SD-card BMP dumps.

Pure functions, no I/O except the two BMP helpers that read or write one file.

The camera sends ``SF`` frames one *column* per packet (x = 0 first), each column top to
bottom, two bytes a pixel, low byte first: ``value = b0 | (b1 << 8)``, red = bits 15..11,
green = 10..5, blue = 4..0. Five- and six-bit channels are widened to eight bits by bit
replication (``r8 = r5 << 3 | r5 >> 2``) so that 0 maps to 0 and full scale to 255.

Examples
--------
>>> import numpy as np
>>> img = np.zeros((2, 3, 3), np.uint8); img[0, 0] = (255, 0, 0)  # blue, BGR
>>> data = encode_rgb565(img)
>>> data[:2]  # column 0, row 0: blue = 0x001F, low byte first
b'\\x1f\\x00'
>>> bool((decode_rgb565(data, 3, 2) == img).all())
True
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

#: The 16 picture sizes of ``SF h v`` / ``DF h v``: (640 >> h, 480 >> v).
RESOLUTIONS: tuple[tuple[int, int], ...] = tuple(
    (640 >> h, 480 >> v) for h in range(4) for v in range(4)
)


def sf_resolution(h: int, v: int) -> tuple[int, int]:
    """Picture size (width, height) of ``SF h v``."""
    if not (isinstance(h, int) and 0 <= h <= 3):
        raise ValueError(f"h must be an integer 0..3, got {h!r}")
    if not (isinstance(v, int) and 0 <= v <= 3):
        raise ValueError(f"v must be an integer 0..3, got {v!r}")
    return 640 >> h, 480 >> v


def resolution_to_hv(width: int, height: int) -> tuple[int, int]:
    """The ``(h, v)`` arguments of ``SF`` for a picture size, e.g. 160x120 -> (2, 2)."""
    sizes = {640 >> i: i for i in range(4)}
    hs = {480 >> i: i for i in range(4)}
    if width not in sizes or height not in hs:
        raise ValueError(
            f"resolution must be one of 640/320/160/80 x 480/240/120/60, got {width}x{height}"
        )
    return sizes[width], hs[height]


def parse_resolution(text: str) -> tuple[int, int]:
    """Parse ``"160x120"`` into ``(160, 120)``; only CMUcam4 sizes are accepted."""
    try:
        w_s, h_s = str(text).lower().split("x")
        width, height = int(w_s), int(h_s)
    except ValueError:
        raise ValueError(f"resolution must look like 160x120, got {text!r}") from None
    resolution_to_hv(width, height)
    return width, height


def decode_rgb565(data: bytes, width: int, height: int) -> np.ndarray:
    """Decode a column-major RGB565 (low byte first) picture into a BGR ``uint8`` image.

    Parameters
    ----------
    data : bytes
        ``2 * width * height`` bytes: column 0 top to bottom, then column 1, ...
    width, height : int
        Picture size.
    """
    if width <= 0 or height <= 0:
        raise ValueError(f"width and height must be positive, got {width}x{height}")
    if len(data) != 2 * width * height:
        raise ValueError(
            f"data must hold 2*{width}*{height} = {2 * width * height} bytes, got {len(data)}"
        )
    values = np.frombuffer(data, dtype="<u2").reshape(width, height).T  # rows = y
    return rgb565_to_bgr(values)


def rgb565_to_bgr(values: np.ndarray) -> np.ndarray:
    """Turn an array of 16-bit RGB565 values (any 2-D shape) into BGR ``uint8``."""
    v = np.asarray(values).astype(np.uint16)
    r5 = (v >> 11) & 0x1F
    g6 = (v >> 5) & 0x3F
    b5 = v & 0x1F
    out = np.empty((*v.shape, 3), np.uint8)
    out[..., 0] = (b5 << 3) | (b5 >> 2)
    out[..., 1] = (g6 << 2) | (g6 >> 4)
    out[..., 2] = (r5 << 3) | (r5 >> 2)
    return out


def bgr_to_rgb565(image: np.ndarray) -> np.ndarray:
    """Quantise a BGR ``uint8`` image (H x W x 3) into 16-bit RGB565 values (H x W)."""
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(f"image must be a BGR uint8 HxWx3 array, got {img.dtype} {img.shape}")
    b = img[..., 0].astype(np.uint16) >> 3
    g = img[..., 1].astype(np.uint16) >> 2
    r = img[..., 2].astype(np.uint16) >> 3
    return (r << 11) | (g << 5) | b


def encode_rgb565(image: np.ndarray) -> bytes:
    """Encode a BGR image the way ``SF`` sends it: column-major RGB565, low byte first."""
    values = bgr_to_rgb565(image)
    return np.ascontiguousarray(values.T).astype("<u2").tobytes()


def encode_column(image: np.ndarray, x: int) -> bytes:
    """The pixel bytes of one ``SF`` column (top to bottom, low byte first)."""
    values = bgr_to_rgb565(image[:, x : x + 1])
    return values[:, 0].astype("<u2").tobytes()


# --- SD-card dumps (DF) ------------------------------------------------------------------

_BMP_MASKS = (0xF800, 0x07E0, 0x001F)


def write_dump_bmp(path: str | Path, image: np.ndarray) -> None:
    """Write ``image`` the way the CMUcam4's ``DF`` does (used by the stand-in board).

    A 16-bit BMP with bit-field masks 0xF800/0x07E0/0x001F, width = picture height,
    height = picture width, stored bottom-up with one camera column per BMP row
    (column 0 first in the file): the stored picture is turned 90 degrees anticlockwise.
    """
    values = bgr_to_rgb565(image)  # H x W
    height, width = values.shape
    row_bytes = 2 * height
    pad = (-row_bytes) % 4
    rows = b"".join(
        values[:, x].astype("<u2").tobytes() + b"\0" * pad for x in range(width)
    )  # BMP row i (from the bottom) = camera column i
    header_size = 14 + 40 + 12
    info = struct.pack("<IiiHHIIiiII", 40, height, width, 1, 16, 3, len(rows), 2835, 2835, 0, 0)
    masks = struct.pack("<III", *_BMP_MASKS)
    file_header = struct.pack("<2sIHHI", b"BM", header_size + len(rows), 0, 0, header_size)
    Path(path).write_bytes(file_header + info + masks + rows)


def read_dump_bmp(path: str | Path) -> np.ndarray:
    """Read a ``DF`` dump (16-bit bit-field BMP) and turn it right: a BGR camera picture.

    Handles the CMUcam4's own layout (masks 0xF800/0x07E0/0x001F, bottom-up, turned
    anticlockwise) and also top-down BMPs (negative height). Raises ``ValueError`` naming
    the file when it is not such a BMP.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"path: cannot read {path}: {exc.strerror or exc}") from exc
    if len(data) < 54 or data[:2] != b"BM":
        raise ValueError(f"path: {path} is not a BMP file")
    (offset,) = struct.unpack_from("<I", data, 10)
    _hsize, bw, bh, planes, bpp, compression = struct.unpack_from("<IiiHHI", data, 14)
    if bpp != 16 or compression not in (0, 3) or planes != 1 or bw <= 0 or bh == 0:
        raise ValueError(
            f"path: {path} is not a 16-bit CMUcam4 dump (bpp={bpp}, compression={compression})"
        )
    if compression == 3:
        # The masks follow a 40-byte info header, or sit at the same place inside V4/V5.
        masks = struct.unpack_from("<III", data, 14 + 40)
        if masks != _BMP_MASKS:
            raise ValueError(f"path: {path} uses bit masks {masks}, expected RGB565")
    else:
        raise ValueError(f"path: {path} is RGB555, not the CMUcam4's RGB565")
    top_down = bh < 0
    rows_n = abs(bh)
    row_bytes = 2 * bw + ((-2 * bw) % 4)
    if offset + rows_n * row_bytes > len(data):
        raise ValueError(f"path: {path} is truncated")
    raw = np.frombuffer(data, np.uint8, rows_n * row_bytes, offset).reshape(rows_n, row_bytes)
    stored = raw[:, : 2 * bw].copy().view("<u2")  # file row order
    # Displayed BMP: file row 0 is the bottom row unless stored top-down.
    displayed = stored if top_down else stored[::-1]
    # The stored picture is the camera picture turned anticlockwise; turn it back
    # (clockwise): camera[y, x] = displayed[W - 1 - x, y].
    camera = displayed[::-1].T
    return rgb565_to_bgr(np.ascontiguousarray(camera))
