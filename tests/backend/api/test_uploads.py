"""Uploads on the real app: bombs get 413 from their header, garbage 4xx, never a 5xx."""

from __future__ import annotations

import random

import pytest

from bench.fuzz.images import FORMATS, bomb, random_upload
from tests.backend.api.support import AUTH


def upload(client, data: bytes, pad_size: str = "0.55"):
    return client.post(
        "/api/reference",
        files={"file": ("pad.bin", data, "application/octet-stream")},
        data={"pad_size_m": pad_size},
        headers=AUTH,
    )


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_100k_bomb_is_413_with_a_sentence_and_the_reference_stays(client, fmt):
    before = client.get("/api/reference").json()["id"]
    r = upload(client, bomb(fmt, 100_000, 100_000))
    assert r.status_code == 413, r.text
    detail = r.json()["detail"]
    assert "pixels" in detail and "over the limit of 40 MP" in detail
    assert client.get("/api/reference").json()["id"] == before


def test_a_real_bomb_is_refused_before_decoding(client):
    r = upload(client, bomb("png", 20_000, 20_000, real=True))
    assert r.status_code == 413 and "20000 x 20000" in r.json()["detail"]


@pytest.mark.parametrize("pad_size", ["nan", "inf", "-0", "1e999", "", "0x10"])
def test_the_pad_size_must_be_a_finite_positive_number(client, pad_size):
    ok = bomb("png", 300, 200, real=True)
    r = upload(client, ok, pad_size=pad_size)
    assert r.status_code == 422, r.text


def test_fuzzed_uploads_never_get_a_5xx(client):
    rng = random.Random(5)
    codes: dict[int, int] = {}
    for _ in range(150):
        code = upload(client, random_upload(rng)).status_code
        codes[code] = codes.get(code, 0) + 1
    # 201: a picture the vision measured (it takes some noise for an H: the vision's
    # business); everything else is refused with a 4xx.
    assert all(c == 201 or 400 <= c < 500 for c in codes), codes
    assert codes.get(415, 0) > 50 and codes.get(413, 0) > 5
