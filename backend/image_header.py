"""A picture's size from its header, before anything decodes it.

A few hundred bytes of PNG can claim 100000 x 100000 pixels; decoding it would take
tens of gigabytes before any check of OpenCV's could object. So an upload's format and
size are read here from the header alone (PNG, JPEG, BMP, WebP, TIFF; anything else
is not accepted), and only a picture within the pixel budget is decoded. Every read is
bounds-checked: any byte sequence gives a header or :class:`BadHeader`, never another
exception.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass


class BadHeader(ValueError):
    """Not a picture of a format we accept, or its header is broken (HTTP 415)."""


@dataclass(frozen=True)
class ImageHeader:
    """What the header says: the format and the size (and, for TIFF, its tile size)."""

    format: str
    width: int
    height: int
    #: Pixels a decoder holds at once besides the picture (a TIFF tile), if more.
    tile_pixels: int = 0

    @property
    def pixels(self) -> int:
        return self.width * self.height

    @property
    def decode_pixels(self) -> int:
        """Pixels a decoder must hold: the picture's, or a larger tile's."""
        return max(self.pixels, self.tile_pixels)


FORMATS = "PNG, JPEG, BMP, WebP or TIFF"


def read_header(data: bytes) -> ImageHeader:
    """The format and size of the picture in ``data``, from its header alone.

    >>> import struct
    >>> png = b"\\x89PNG\\r\\n\\x1a\\n" + struct.pack(">I4sII", 13, b"IHDR", 100000, 100000)
    >>> read_header(png + b"\\x08\\x02\\x00\\x00\\x00")
    ImageHeader(format='png', width=100000, height=100000, tile_pixels=0)
    >>> read_header(b"GIF89a...")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    backend.image_header.BadHeader: The file is not a picture: expected PNG, JPEG, ...
    """
    try:
        if data.startswith(b"\x89PNG\r\n\x1a\n"):
            header = _png(data)
        elif data.startswith(b"\xff\xd8"):
            header = _jpeg(data)
        elif data.startswith(b"BM"):
            header = _bmp(data)
        elif data[:4] == b"RIFF" and data[8:12] == b"WEBP":
            header = _webp(data)
        elif data[:4] in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"):
            header = _tiff(data)
        else:
            raise BadHeader(f"The file is not a picture: expected {FORMATS}.")
    except (struct.error, IndexError) as exc:
        raise BadHeader("The picture's header is cut short or broken.") from exc
    if header.width <= 0 or header.height <= 0:
        raise BadHeader(
            f"The {header.format.upper()} header gives no size ({header.width} x {header.height})."
        )
    return header


def _png(data: bytes) -> ImageHeader:
    length, kind, width, height = struct.unpack_from(">I4sII", data, 8)
    if kind != b"IHDR" or length != 13:
        raise BadHeader("The PNG does not start with its IHDR header.")
    return ImageHeader("png", width, height)


# Start-of-frame markers: C0-CF except DHT (C4), JPG (C8) and DAC (CC).
_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
_STANDALONE = frozenset({0x01, *range(0xD0, 0xD9)})


def _jpeg(data: bytes) -> ImageHeader:
    pos, n = 2, len(data)
    while pos < n:
        if data[pos] != 0xFF:
            raise BadHeader("The JPEG's markers are broken before its frame header.")
        while pos < n and data[pos] == 0xFF:  # fill bytes
            pos += 1
        marker = data[pos]
        pos += 1
        if marker in _STANDALONE:
            continue
        if marker in (0xD9, 0xDA):  # end of image, or scan data, before any frame header
            break
        (length,) = struct.unpack_from(">H", data, pos)
        if length < 2:
            raise BadHeader("The JPEG has a segment of impossible length.")
        if marker in _SOF:
            height, width = struct.unpack_from(">HH", data, pos + 3)
            if height == 0:
                raise BadHeader("The JPEG gives its height only after the image (DNL).")
            return ImageHeader("jpeg", width, height)
        pos += length
    raise BadHeader("The JPEG has no frame header (no size).")


def _bmp(data: bytes) -> ImageHeader:
    (dib,) = struct.unpack_from("<I", data, 14)
    if dib == 12:  # OS/2 BITMAPCOREHEADER
        width, height = struct.unpack_from("<HH", data, 18)
    elif dib >= 16:
        width, height = struct.unpack_from("<ii", data, 18)
        height = abs(height)  # negative: rows stored top-down
    else:
        raise BadHeader("The BMP's header is of no known kind.")
    return ImageHeader("bmp", width, height)


def _webp(data: bytes) -> ImageHeader:
    chunk = data[12:16]
    if chunk == b"VP8 ":
        if data[23:26] != b"\x9d\x01\x2a":
            raise BadHeader("The WebP (lossy) frame header is broken.")
        width, height = struct.unpack_from("<HH", data, 26)
        return ImageHeader("webp", width & 0x3FFF, height & 0x3FFF)
    if chunk == b"VP8L":
        if data[20] != 0x2F:
            raise BadHeader("The WebP (lossless) header is broken.")
        (bits,) = struct.unpack_from("<I", data, 21)
        return ImageHeader("webp", (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1)
    if chunk == b"VP8X":
        if len(data) < 30:
            raise BadHeader("The WebP (extended) header is cut short.")
        width = int.from_bytes(data[24:27], "little") + 1
        height = int.from_bytes(data[27:30], "little") + 1
        return ImageHeader("webp", width, height)
    raise BadHeader("The WebP has no VP8, VP8L or VP8X chunk first.")


_TIFF_WIDTH, _TIFF_HEIGHT, _TIFF_TILE_W, _TIFF_TILE_H = 256, 257, 322, 323
_TIFF_BITS, _TIFF_SAMPLES = 258, 277
_TIFF_TAGS = frozenset(
    {_TIFF_WIDTH, _TIFF_HEIGHT, _TIFF_TILE_W, _TIFF_TILE_H, _TIFF_BITS, _TIFF_SAMPLES}
)
# TIFF field types whose first value fits the entry: SHORT, LONG, LONG8.
_TIFF_INT_TYPES = {3: ("H", 2), 4: ("I", 4), 16: ("Q", 8)}
_MAX_TIFF_ENTRIES = 4096


def _tiff(data: bytes) -> ImageHeader:
    order = "<" if data[:2] == b"II" else ">"
    big = data[2:4] in (b"+\x00", b"\x00+")
    # Classic TIFF: 2-byte entry count, 12-byte entries (4-byte value count and value);
    # BigTIFF: 8-byte count, 20-byte entries (8-byte value count and value).
    if big:
        (ifd,) = struct.unpack_from(order + "Q", data, 8)
        count_fmt, entry_size, count_size, inline = "Q", 20, 8, ("Q", 8)
    else:
        (ifd,) = struct.unpack_from(order + "I", data, 4)
        count_fmt, entry_size, count_size, inline = "H", 12, 2, ("I", 4)
    if not 8 <= ifd < len(data):
        raise BadHeader("The TIFF's first directory lies outside the file.")
    (entries,) = struct.unpack_from(order + count_fmt, data, ifd)
    if entries > _MAX_TIFF_ENTRIES:
        raise BadHeader("The TIFF's first directory is implausibly long.")
    tags: dict[int, int] = {}
    for i in range(int(entries)):
        at = ifd + count_size + i * entry_size
        tag, kind = struct.unpack_from(order + "HH", data, at)
        if tag not in _TIFF_TAGS:
            continue
        if kind not in _TIFF_INT_TYPES:
            raise BadHeader(f"The TIFF's tag {tag} has an unexpected type.")
        fmt, size = _TIFF_INT_TYPES[kind]
        (count,) = struct.unpack_from(order + inline[0], data, at + 4)
        value_at = at + 4 + inline[1]
        if count * size > inline[1]:  # the values are elsewhere: the entry holds where
            (value_at,) = struct.unpack_from(order + inline[0], data, value_at)
        (tags[tag],) = struct.unpack_from(order + fmt, data, value_at)
    if _TIFF_WIDTH not in tags or _TIFF_HEIGHT not in tags:
        raise BadHeader("The TIFF's first directory gives no size.")
    if tags.get(_TIFF_BITS, 8) > 16 or tags.get(_TIFF_SAMPLES, 1) > 4:
        raise BadHeader("The TIFF's samples are over 16 bits or 4 channels: not accepted.")
    tile = tags.get(_TIFF_TILE_W, 0) * tags.get(_TIFF_TILE_H, 0)
    return ImageHeader("tiff", tags[_TIFF_WIDTH], tags[_TIFF_HEIGHT], tile)
