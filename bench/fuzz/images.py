"""Pictures that lie: decompression bombs and malformed files, for the upload's tests.

:func:`bomb` makes a small file whose header claims ``width x height`` pixels, in each
format the station accepts; ``real=True`` (PNG) makes one that truly decodes to that
size (a zlib stream of zeros: 20000 x 20000 in about 50 KB). :func:`mutants` turns a
valid picture into broken ones (cut short, bytes flipped, header fields garbled).
"""

from __future__ import annotations

import random
import struct
import zlib
from collections.abc import Iterator

import cv2
import numpy as np

FORMATS = ("png", "jpeg", "bmp", "webp", "tiff")


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def png_bomb(width: int, height: int, *, real: bool = False) -> bytes:
    """A 1-bit greyscale PNG of ``width x height``; ``real``: its zeros are all there."""
    ihdr = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    if real:
        row = b"\x00" * (1 + (width + 7) // 8)
        packer = zlib.compressobj(9)
        idat = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    else:
        idat = zlib.compress(b"\x00" * 4096, 9)  # the start of the rows, then nothing
    return (
        b"\x89PNG\r\n\x1a\n"
        + _png_chunk(b"IHDR", ihdr)
        + _png_chunk(b"IDAT", idat)
        + _png_chunk(b"IEND", b"")
    )


def jpeg_bomb(width: int, height: int) -> bytes:
    """A baseline JPEG header (from a real 8 x 8 JPEG) with its frame size replaced
    (JPEG's largest is 65535 x 65535: larger sides are cut to that)."""
    width, height = min(width, 65535), min(height, 65535)
    _ok, buf = cv2.imencode(".jpg", np.zeros((8, 8, 3), np.uint8))
    data = bytearray(buf.tobytes())
    pos = data.find(b"\xff\xc0")
    struct.pack_into(">HH", data, pos + 5, height, width)
    return bytes(data)


def bmp_bomb(width: int, height: int) -> bytes:
    """A 24-bit BMP header for ``width x height`` with a few bytes of pixels."""
    info = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, 0, 2835, 2835, 0, 0)
    pixels = b"\x00" * 64
    head = struct.pack("<2sIHHI", b"BM", 14 + len(info) + len(pixels), 0, 0, 14 + len(info))
    return head + info + pixels


def webp_bomb(width: int, height: int) -> bytes:
    """An extended (VP8X) WebP whose canvas is ``width x height``."""
    vp8x = struct.pack("<B3s", 0, b"\x00\x00\x00") + (width - 1).to_bytes(3, "little")
    vp8x += (height - 1).to_bytes(3, "little")
    _ok, buf = cv2.imencode(".webp", np.zeros((8, 8, 3), np.uint8))
    inner = buf.tobytes()[12:]  # its VP8/VP8L chunk
    body = b"WEBP" + b"VP8X" + struct.pack("<I", len(vp8x)) + vp8x + inner
    return b"RIFF" + struct.pack("<I", len(body)) + body


def tiff_bomb(width: int, height: int, *, tile: int = 0) -> bytes:
    """A little-endian TIFF whose first directory says ``width x height`` (``tile``:
    also tiles of ``tile x tile``)."""
    entries = [
        (256, 4, 1, width),
        (257, 4, 1, height),
        (258, 3, 1, 8),
        (259, 3, 1, 1),
        (262, 3, 1, 1),
        (273, 4, 1, 8),
        (277, 3, 1, 1),
        (278, 4, 1, height),
        (279, 4, 1, 64),
    ]
    if tile:
        entries += [(322, 4, 1, tile), (323, 4, 1, tile)]
    entries.sort()
    ifd = struct.pack("<H", len(entries))
    for tag, kind, count, value in entries:
        packed = struct.pack("<H", value) + b"\x00\x00" if kind == 3 else struct.pack("<I", value)
        ifd += struct.pack("<HHI", tag, kind, count) + packed
    ifd += struct.pack("<I", 0)
    pixels = b"\x00" * 64
    return b"II*\x00" + struct.pack("<I", 8 + len(pixels)) + pixels + ifd


def bomb(fmt: str, width: int, height: int, *, real: bool = False) -> bytes:
    """A ``fmt`` file claiming ``width x height`` pixels (see the module docstring)."""
    if fmt == "png":
        return png_bomb(width, height, real=real)
    if real:
        raise ValueError("only PNG bombs are made real")
    makers = {"jpeg": jpeg_bomb, "bmp": bmp_bomb, "webp": webp_bomb, "tiff": tiff_bomb}
    return makers[fmt](width, height)


def valid(fmt: str, rng: random.Random, size: int = 48) -> bytes:
    """A small valid picture in ``fmt``, of random content."""
    ext = {"jpeg": ".jpg"}.get(fmt, f".{fmt}")
    image = np.random.default_rng(rng.randrange(1 << 30)).integers(
        0, 256, (size, size + 7, 3), np.uint8
    )
    _ok, buf = cv2.imencode(ext, image)
    return buf.tobytes()


def mutants(data: bytes, rng: random.Random) -> Iterator[bytes]:
    """Broken versions of ``data``: cut short, flipped bytes, garbled header fields."""
    n = len(data)
    yield data[: rng.randrange(max(1, n))]
    flipped = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        flipped[rng.randrange(n)] ^= 1 << rng.randrange(8)
    yield bytes(flipped)
    head = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        head[rng.randrange(min(n, 64))] = rng.randrange(256)
    yield bytes(head)
    at = rng.randrange(n)
    yield data[:at] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 32))) + data[at:]


def random_upload(rng: random.Random) -> bytes:
    """One fuzzed upload: a bomb, a mutant of a valid picture, or random bytes."""
    roll = rng.random()
    fmt = rng.choice(FORMATS)
    if roll < 0.15:
        side = rng.choice((30_000, 40_000, 65_535, 100_000))
        return bomb(fmt, side, rng.choice((side, 1, 7)))
    if roll < 0.75:
        return rng.choice(list(mutants(valid(fmt, rng), rng)))
    if roll < 0.9:
        magic = rng.choice((b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff", b"BM", b"RIFF", b"II*\x00"))
        return magic + rng.randbytes(rng.randrange(0, 300))
    return rng.randbytes(rng.randrange(0, 2000))
