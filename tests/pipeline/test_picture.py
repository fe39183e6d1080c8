"""Pictures read from files as a user has them: transparent grounds, 16 bits, gray."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pipeline import Reference
from pipeline.picture import decode_picture, on_ground, read_picture
from pipeline.preprocess import check_image

SIDE = 400


def _h(paint: tuple[int, int, int], ground: tuple[int, int, int], alpha: int) -> np.ndarray:
    """An H of ``paint``, opaque, on a ground of ``ground`` whose alpha is ``alpha``."""
    image = np.zeros((SIDE, SIDE, 4), np.uint8)
    image[...] = (*ground, alpha)
    c, s, leg, bar = SIDE / 2, 0.3 * SIDE, 0.16 * SIDE, 0.07 * SIDE
    for x0, y0, x1, y1 in (
        (c - s, c - s, c - s + leg, c + s),
        (c + s - leg, c - s, c + s, c + s),
        (c - s, c - bar, c + s, c + bar),
    ):
        cv2.rectangle(image, (int(x0), int(y0)), (int(x1) - 1, int(y1) - 1), (*paint, 255), -1)
    return image


def _png(image: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", image)
    assert ok
    return buf.tobytes()


@pytest.mark.parametrize(
    "paint, hidden, seen_on, polarity",
    [
        ((20, 20, 20), (0, 0, 0), (255, 255, 255), "dark"),  # black H, black under the ground
        ((20, 20, 20), (255, 255, 255), (255, 255, 255), "dark"),
        ((250, 250, 250), (255, 255, 255), (0, 0, 0), "bright"),  # white H, white under it
        ((250, 250, 250), (0, 0, 0), (0, 0, 0), "bright"),
    ],
)
def test_an_h_on_a_transparent_ground_is_read_on_the_shade_it_contrasts_with(
    tmp_path, paint, hidden, seen_on, polarity
):
    # Read as colour alone, two of these are one shade all over, and no pad at all.
    path = tmp_path / "icon.png"
    path.write_bytes(_png(_h(paint, hidden, 0)))
    flat = cv2.imdecode(np.frombuffer(path.read_bytes(), np.uint8), cv2.IMREAD_COLOR)
    picture = read_picture(path)
    assert picture.shape == (SIDE, SIDE, 3) and picture.dtype == np.uint8
    assert np.array_equal(picture, _h(paint, seen_on, 255)[..., :3])
    reference = Reference.from_image(picture, 0.5)
    assert reference.polarity == polarity
    opaque = Reference.from_image(_h(paint, seen_on, 255)[..., :3], 0.5)
    assert np.allclose(reference.corners_m, opaque.corners_m)
    if hidden != seen_on:
        with pytest.raises(ValueError, match="no shape stands out"):
            Reference.from_image(flat, 0.5)
    # An array handed over with its alpha is read the same way.
    assert np.array_equal(check_image(_h(paint, hidden, 0)), picture)


def test_half_transparent_edges_are_blended_on_the_ground():
    image = _h((0, 0, 0), (0, 0, 0), 0)
    image[1, 1, 3] = 64
    out = on_ground(image)
    assert out[1, 1].tolist() == [191, 191, 191] and out[5, 5].tolist() == [255, 255, 255]


def test_an_opaque_picture_with_an_alpha_channel_is_its_colours():
    image = _h((20, 40, 200), (200, 180, 10), 255)
    assert np.array_equal(decode_picture(_png(image)), image[..., :3])


def test_sixteen_bit_and_gray_pictures_read_as_eight_bit_colour():
    image = _h((20, 20, 20), (0, 0, 0), 0)
    deep = image.astype(np.uint16) * 257
    assert np.array_equal(decode_picture(_png(deep)), decode_picture(_png(image)))
    gray = decode_picture(_png(image[..., 0]))
    assert gray.shape == (SIDE, SIDE, 3) and gray.dtype == np.uint8


def test_what_is_no_picture_is_a_clear_error(tmp_path):
    assert decode_picture(b"\x89PNG\r\n\x1a\n" + bytes(64)) is None
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a picture")
    with pytest.raises(ValueError, match=r"cannot read .* as a picture"):
        read_picture(bad)
    with pytest.raises(ValueError, match="cannot read"):
        read_picture(tmp_path / "missing.png")
