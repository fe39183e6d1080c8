"""RGB565 decoding (exact values), SF sizes and the DF BMP read-back."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from backend.camera.rgb565 import (
    RESOLUTIONS,
    decode_rgb565,
    encode_column,
    encode_rgb565,
    parse_resolution,
    read_dump_bmp,
    resolution_to_hv,
    sf_resolution,
    write_dump_bmp,
)


def test_known_pixels_decode_exactly() -> None:
    # 2 columns x 3 rows, column-major, low byte first.
    values = [
        0xF800,  # (x0, y0) pure red
        0x07E0,  # (x0, y1) pure green
        0x001F,  # (x0, y2) pure blue
        0xFFFF,  # (x1, y0) white
        0x0000,  # (x1, y1) black
        0x8410,  # (x1, y2) r=16, g=32, b=16
    ]
    data = b"".join(v.to_bytes(2, "little") for v in values)
    img = decode_rgb565(data, 2, 3)
    assert img.shape == (3, 2, 3)
    assert img[0, 0].tolist() == [0, 0, 255]
    assert img[1, 0].tolist() == [0, 255, 0]
    assert img[2, 0].tolist() == [255, 0, 0]
    assert img[0, 1].tolist() == [255, 255, 255]
    assert img[1, 1].tolist() == [0, 0, 0]
    # 5-bit 16 -> 16<<3 | 16>>2 = 132; 6-bit 32 -> 32<<2 | 32>>4 = 130
    assert img[2, 1].tolist() == [132, 130, 132]


def test_low_byte_first() -> None:
    # 0x001F sent as 1F 00 is blue; swapped (00 1F) it would read 0x1F00: r=3, g=56.
    assert decode_rgb565(b"\x1f\x00", 1, 1)[0, 0].tolist() == [255, 0, 0]
    assert decode_rgb565(b"\x00\x1f", 1, 1)[0, 0].tolist() == [0, 227, 24]


def test_round_trip_is_quantisation_only() -> None:
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (120, 160, 3), dtype=np.uint8)
    out = decode_rgb565(encode_rgb565(img), 160, 120)
    # Top bits survive exactly: 5 for red/blue, 6 for green.
    assert np.array_equal(out[..., 0] >> 3, img[..., 0] >> 3)
    assert np.array_equal(out[..., 1] >> 2, img[..., 1] >> 2)
    assert np.array_equal(out[..., 2] >> 3, img[..., 2] >> 3)
    # Decoding is idempotent on already-quantised pictures.
    assert np.array_equal(decode_rgb565(encode_rgb565(out), 160, 120), out)


def test_column_major_layout() -> None:
    img = np.zeros((4, 3, 3), np.uint8)
    img[1, 2] = 255  # row 1, column 2
    data = encode_rgb565(img)
    offset = 2 * (2 * 4 + 1)  # column 2, row 1
    assert data[offset : offset + 2] == b"\xff\xff"
    assert sum(data) == 0xFF * 2
    assert encode_column(img, 2) == data[2 * 8 : 2 * 12]


def test_decode_rejects_bad_sizes() -> None:
    with pytest.raises(ValueError, match="data must hold"):
        decode_rgb565(b"\0" * 5, 1, 3)
    with pytest.raises(ValueError, match="width and height"):
        decode_rgb565(b"", 0, 3)
    with pytest.raises(ValueError, match="image must be"):
        encode_rgb565(np.zeros((2, 2), np.uint8))


def test_resolutions() -> None:
    assert len(RESOLUTIONS) == 16
    assert sf_resolution(2, 2) == (160, 120)
    assert sf_resolution(0, 3) == (640, 60)
    assert resolution_to_hv(80, 480) == (3, 0)
    assert parse_resolution("320X240") == (320, 240)
    for bad in ("100x100", "160", "axb"):
        with pytest.raises(ValueError, match="resolution"):
            parse_resolution(bad)
    with pytest.raises(ValueError, match="h must be"):
        sf_resolution(4, 0)
    with pytest.raises(ValueError, match="v must be"):
        sf_resolution(0, -1)


@pytest.mark.parametrize("size", [(160, 120), (80, 60), (640, 60)])
def test_dump_bmp_is_turned_right(tmp_path, size) -> None:
    w, h = size
    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    img[:10, :10] = (0, 0, 255)  # a red top-left corner to see the orientation
    path = tmp_path / "00000BM.BMP"
    write_dump_bmp(path, img)
    back = read_dump_bmp(path)
    expected = decode_rgb565(encode_rgb565(img), w, h)
    assert np.array_equal(back, expected)
    # Independent oracle: OpenCV reads the stored (anticlockwise) picture; its decoder
    # widens by shifting only, so compare the significant bits.
    stored = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert stored.shape == (w, h, 3)  # turned: width and height swapped
    assert stored[-5, 5].tolist() == [0, 0, 248]  # our top-left is the stored bottom-left
    turned = cv2.rotate(stored, cv2.ROTATE_90_CLOCKWISE)
    assert np.array_equal(turned >> 3, expected >> 3)


def test_read_dump_bmp_rejects_other_files(tmp_path) -> None:
    png = tmp_path / "x.BMP"
    cv2.imwrite(str(tmp_path / "x.png"), np.zeros((4, 4, 3), np.uint8))
    png.write_bytes((tmp_path / "x.png").read_bytes())
    with pytest.raises(ValueError, match="not a BMP"):
        read_dump_bmp(png)
    bmp24 = tmp_path / "y.bmp"
    cv2.imwrite(str(bmp24), np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(ValueError, match="16-bit"):
        read_dump_bmp(bmp24)
    with pytest.raises(ValueError, match="cannot read"):
        read_dump_bmp(tmp_path / "missing.bmp")
    good = tmp_path / "z.bmp"
    write_dump_bmp(good, np.zeros((60, 80, 3), np.uint8))
    good.write_bytes(good.read_bytes()[:-100])
    with pytest.raises(ValueError, match="truncated"):
        read_dump_bmp(good)
