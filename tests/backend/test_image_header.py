"""Picture sizes from headers: every accepted format, bombs, and any byte sequence."""

from __future__ import annotations

import contextlib
import random

import cv2
import numpy as np
import pytest

from backend.image_header import BadHeader, read_header
from backend.imaging import TooManyPixels, UnsupportedImage, decode_image
from bench.fuzz.images import FORMATS, bomb, mutants, random_upload, tiff_bomb, valid

EXT = {"png": ".png", "jpeg": ".jpg", "bmp": ".bmp", "webp": ".webp", "tiff": ".tiff"}


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("channels", [1, 3, 4])
def test_the_header_gives_the_size_opencv_decodes(fmt, channels):
    rng = np.random.default_rng(3)
    shape = (37, 53) if channels == 1 else (37, 53, channels)
    image = rng.integers(0, 256, shape, np.uint8)
    ok, buf = cv2.imencode(EXT[fmt], image)
    if not ok:
        pytest.skip(f"OpenCV cannot write {channels}-channel {fmt}")
    header = read_header(buf.tobytes())
    assert (header.format, header.width, header.height) == (fmt, 53, 37)
    assert decode_image(buf.tobytes()).shape == (37, 53, 3)


def test_lossless_webp_and_progressive_jpeg():
    image = np.random.default_rng(1).integers(0, 256, (20, 30, 3), np.uint8)
    webp = cv2.imencode(".webp", image, [cv2.IMWRITE_WEBP_QUALITY, 101])[1].tobytes()
    jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1])[1].tobytes()
    assert read_header(webp).width == 30 and read_header(jpeg).height == 20


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("side", [30_000, 40_000, 100_000])
def test_bombs_are_refused_from_the_header(fmt, side):
    data = bomb(fmt, side, side)
    assert len(data) < 2000  # a few hundred bytes claiming gigapixels
    header = read_header(data)
    assert header.width == min(side, 65535 if fmt == "jpeg" else side)
    with pytest.raises(TooManyPixels, match="over the limit of 40 MP"):
        decode_image(data)


def test_a_real_bomb_that_would_decode_is_refused_before_decoding():
    data = bomb("png", 20_000, 20_000, real=True)  # 400 MP of zeros in about 50 KB
    assert len(data) < 100_000
    with pytest.raises(TooManyPixels, match="20000 x 20000"):
        decode_image(data)
    # the same picture within a budget big enough is a real picture
    small = bomb("png", 300, 200, real=True)
    assert decode_image(small, max_pixels=60_000).shape == (200, 300, 3)


def test_tiff_tiles_count_against_the_budget():
    with pytest.raises(TooManyPixels, match="tiles"):
        decode_image(tiff_bomb(64, 64, tile=60_000))


def test_every_prefix_and_mutant_of_a_picture_is_a_header_or_bad_header():
    rng = random.Random(7)
    for fmt in FORMATS:
        data = valid(fmt, rng)
        for end in range(len(data) + 1):
            with contextlib.suppress(BadHeader):
                read_header(data[:end])
        for _ in range(50):
            for mutant in mutants(data, rng):
                with contextlib.suppress(UnsupportedImage, TooManyPixels):
                    decode_image(mutant)


def test_random_uploads_never_raise_anything_else():
    rng = random.Random(11)
    for _ in range(500):
        with contextlib.suppress(UnsupportedImage, TooManyPixels):
            decode_image(random_upload(rng))
