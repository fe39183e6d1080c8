"""A reference from a perspective photo through the API: upload, suggested outline,
preview (nothing active yet), activate; errors say why and keep the active reference."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from tests.backend.api.support import AUTH, in_process, make_settings
from tests.pipeline.test_rectify import TRUTH, rendered_photo

PHOTOS = Path(__file__).resolve().parents[3].parent / "shared" / "photos"


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    """A station that takes a phone's photo (a few MB)."""
    settings = make_settings(tmp_path_factory.mktemp("perspective"), max_upload_bytes=8_000_000)
    with in_process(settings) as c:
        yield c


def png(image: np.ndarray) -> bytes:
    ok, data = cv2.imencode(".png", image)
    assert ok
    return data.tobytes()


def upload(client, image: np.ndarray, name: str = "pad-on-floor.png"):
    return client.post(
        "/api/reference/perspective",
        files={"file": (name, png(image), "image/png")},
        headers=AUTH,
    )


def test_photo_preview_then_activate(client):
    before = client.get("/api/reference").json()
    answer = upload(client, rendered_photo(TRUTH[0], 0))
    assert answer.status_code == 201, answer.text
    photo = answer.json()
    assert photo["outline"]["kind"] == "quad"
    assert np.abs(np.asarray(photo["outline"]["quad"]) - TRUTH[0]).max() < 4
    assert client.get(photo["photo"]).headers["content-type"] == "image/png"

    preview = client.post(
        f"/api/reference/perspective/{photo['id']}/preview",
        json={"corners": photo["outline"]["quad"], "pad_size_m": 0.55},
        headers=AUTH,
    )
    assert preview.status_code == 200, preview.text
    body = preview.json()
    assert body["h_corners"] == 12
    rectified = cv2.imdecode(
        np.frombuffer(client.get(body["image"]).content, np.uint8), cv2.IMREAD_COLOR
    )
    assert rectified.shape[:2] == (600, 600)
    # a preview changes nothing
    assert client.get("/api/reference").json()["id"] == before["id"]

    url = f"/api/reference/perspective/{photo['id']}/previews/{body['id']}/activate"
    assert client.post(url).status_code == 401
    active = client.post(url, headers=AUTH)
    assert active.status_code == 201, active.text
    assert active.json()["name"] == "pad-on-floor.png (rectified)"
    assert client.get("/api/reference").json()["id"] == active.json()["id"] != before["id"]


def test_errors_are_sentences_and_the_active_reference_stays(client):
    before = client.get("/api/reference").json()["id"]
    photo = upload(client, rendered_photo(TRUTH[1], 1)).json()
    base = f"/api/reference/perspective/{photo['id']}/preview"
    crossed = [[100, 200], [600, 300], [400, 150], [50, 450]]
    answer = client.post(base, json={"corners": crossed, "pad_size_m": 0.55}, headers=AUTH)
    assert answer.status_code == 422
    assert answer.json()["detail"].startswith("The four corners must go round the pad in order")
    off_pad = [[0, 0], [60, 0], [60, 60], [0, 60]]  # a corner of floor, no H there
    answer = client.post(base, json={"corners": off_pad, "pad_size_m": 0.55}, headers=AUTH)
    assert answer.status_code == 422
    assert "(on the rectified picture; adjust the corners)" in answer.json()["detail"]
    far = [[-9000, 0], [60, 0], [60, 60], [0, 60]]
    answer = client.post(base, json={"corners": far, "pad_size_m": 0.55}, headers=AUTH)
    assert (
        answer.json()["detail"] == "The corners lie far outside the photo; drag them onto the pad."
    )
    missing = client.post(
        "/api/reference/perspective/0123456789ab/preview",
        json={"corners": off_pad, "pad_size_m": 0.55},
        headers=AUTH,
    )
    assert missing.status_code == 404
    assert (
        missing.json()["detail"] == "No photo 0123456789ab; it may have expired: upload it again."
    )
    junk = client.post(
        "/api/reference/perspective",
        files={"file": ("notes.png", b"not a picture", "image/png")},
        headers=AUTH,
    )
    assert junk.status_code == 415
    assert client.get("/api/reference").json()["id"] == before


@pytest.mark.skipif(not (PHOTOS / "manifest.json").is_file(), reason="../shared/photos is absent")
def test_a_real_photo_of_a_round_pad_becomes_a_reference(client):
    manifest = json.loads((PHOTOS / "manifest.json").read_text())
    item = next(i for i in manifest["items"] if i["file"].endswith("acbchiella_frame-0080.jpg"))
    data = (PHOTOS / item["file"]).read_bytes()
    answer = client.post(
        "/api/reference/perspective",
        files={"file": ("frame-0080.jpg", data, "image/jpeg")},
        headers=AUTH,
    )
    assert answer.status_code == 201, answer.text
    photo = answer.json()
    assert photo["outline"]["kind"] == "ellipse"
    preview = client.post(
        f"/api/reference/perspective/{photo['id']}/preview",
        json={"corners": photo["outline"]["ellipse"], "pad_size_m": 1.1},
        headers=AUTH,
    )
    assert preview.status_code == 200, preview.text
    assert preview.json()["h_corners"] == 12
