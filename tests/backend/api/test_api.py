"""The API in-process (TestClient, the station running with the stand-in vehicle)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from pymavlink import mavutil
from starlette.websockets import WebSocketDisconnect

from backend.frames import DOWN_MOUNT, mount_rotation
from pipeline import Reference
from pipeline.render import make_pad_image
from tests.backend.api.support import AUTH, TOKEN, in_process, make_settings, wait_for
from tests.pads import h_in_a_ring, helipad

COMMANDS = ["arm", "disarm", "force-disarm", "land", "rtl"]


def png(image: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", image)
    assert ok
    return buf.tobytes()


def upload(client, data: bytes, pad_size="0.55", name="pad.png", headers=AUTH):
    return client.post(
        "/api/reference",
        files={"file": (name, data, "application/octet-stream")},
        data={"pad_size_m": pad_size},
        headers=headers,
    )


def active_id(client) -> int:
    return client.get("/api/reference").json()["id"]


def assert_sentence(response, status: int, *words: str) -> None:
    assert response.status_code == status, response.text
    detail = response.json()["detail"]
    assert isinstance(detail, str) and len(detail) > 10, detail
    for word in words:
        assert word.lower() in detail.lower(), detail


# --- basics ------------------------------------------------------------------------------
def test_health(client):
    r = client.get("/api/health")
    assert r.status_code == 200
    assert r.json()["ok"] is True and isinstance(r.json()["version"], str)


def test_status_has_every_part(client):
    status = client.get("/api/status").json()
    assert set(status) >= {
        "link",
        "camera",
        "pipeline",
        "mission",
        "reference",
        "flight",
        "viser_url",
    }
    assert status["link"]["url"].startswith("tcp:127.0.0.1:")
    assert status["link"]["state"] in ("connecting", "up", "lost", "closed")
    assert set(status["pipeline"]) >= {"fps", "latency_ms", "processed", "dropped", "detected_rate"}
    assert status["camera"]["name"]
    assert status["reference"]["name"] == "default pad" and status["reference"]["active"]


def test_telemetry_comes_from_the_link(client):
    wait_for(lambda: client.get("/api/telemetry").json()["state"] == "up", timeout=15)
    tel = client.get("/api/telemetry").json()
    assert tel["armed"] is False and tel["mode"] == "STABILIZE"


def test_pipeline_processes_sim_camera_frames(client):
    wait_for(lambda: client.get("/api/status").json()["pipeline"]["processed"] > 3, timeout=20)
    status = client.get("/api/status").json()
    assert status["camera"]["frames"] > 0
    assert status["pipeline"]["latency_ms"] is not None


def test_openapi_docs(client):
    assert client.get("/docs").status_code == 200
    paths = client.get("/openapi.json").json()["paths"]
    for path in (
        "/api/health",
        "/api/status",
        "/api/reference",
        "/api/vehicle/arm",
        "/api/vehicle/takeoff",
        "/api/flights",
        "/api/settings",
    ):
        assert path in paths


# --- the token ---------------------------------------------------------------------------
@pytest.mark.parametrize("command", COMMANDS)
def test_commands_need_the_token(client, command):
    assert_sentence(client.post(f"/api/vehicle/{command}"), 401, "token")
    bad = {"Authorization": "Bearer not-the-token"}
    assert_sentence(client.post(f"/api/vehicle/{command}", headers=bad), 401, "wrong")
    basic = {"Authorization": f"Basic {TOKEN}"}
    assert_sentence(client.post(f"/api/vehicle/{command}", headers=basic), 401, "Bearer")


def test_nothing_reaches_the_vehicle_without_the_token(client):
    station = client.app.state.station
    wait_for(lambda: station.link.telemetry.state == "up", timeout=15)
    for _ in range(3):
        assert client.post("/api/vehicle/arm").status_code == 401
        r = client.post("/api/vehicle/takeoff", json={"altitude_m": 2})
        assert r.status_code == 401
        assert client.post("/api/vehicle/mode", json={"mode": "GUIDED"}).status_code == 401
    assert upload(client, b"x", headers={}).status_code == 401
    assert client.put("/api/settings", json={"record_frames": False}).status_code == 401
    assert station.link.telemetry.armed is False
    assert station.link.telemetry.mode == "STABILIZE"
    # The link's own log of what it sent holds no arming, mode or take-off command.
    station.link.flush_tlog()
    conn = mavutil.mavlink_connection(str(station.link.tlog_path))
    sent = []
    while (msg := conn.recv_match(blocking=False)) is not None:
        if msg.get_srcSystem() == 255 and msg.get_type() in ("COMMAND_LONG", "SET_MODE"):
            sent.append((msg.get_type(), getattr(msg, "command", None)))
    conn.close()
    forbidden = {400, 176, 22}  # ARM_DISARM, DO_SET_MODE, NAV_TAKEOFF
    assert not [s for s in sent if s[0] == "SET_MODE" or s[1] in forbidden], sent


# --- validation: 422 with a sentence, 404 for unknown ids, never a 500 ---------------------
@pytest.mark.parametrize(
    ("path", "body", "words"),
    [
        ("/api/vehicle/takeoff", "{not json", ["not valid JSON"]),
        ("/api/vehicle/takeoff", '{"altitude_m": "high"}', ["altitude_m", "number"]),
        ("/api/vehicle/takeoff", '{"altitude_m": -2}', ["altitude_m", "greater than or equal"]),
        ("/api/vehicle/takeoff", '{"altitude_m": 1e-300}', ["altitude_m", "greater than or equal"]),
        # Strict: a boolean or a string is not a number, and nothing is not finite.
        ("/api/vehicle/takeoff", '{"altitude_m": true}', ["altitude_m", "number"]),
        ("/api/vehicle/takeoff", '{"altitude_m": "5"}', ["altitude_m", "number"]),
        ("/api/vehicle/takeoff", '{"altitude_m": NaN}', ["altitude_m", "finite"]),
        ("/api/vehicle/takeoff", '{"altitude_m": 1e400}', ["altitude_m", "finite"]),
        ("/api/vehicle/mode", '{"mode": "\\ud800"}', ["mode", "string"]),
        ("/api/vehicle/takeoff", '{"altitude_m": 500}', ["altitude_m", "less than"]),
        ("/api/vehicle/takeoff", "{}", ["altitude_m", "required"]),
        ("/api/vehicle/takeoff", "", ["body"]),
        ("/api/vehicle/takeoff", "[1, 2]", ["object"]),
        ("/api/vehicle/takeoff", '{"altitude_m": 2, "x": 1}', ["x", "not permitted"]),
        ("/api/vehicle/mode", '{"mode": "WARP"}', ["unknown mode", "GUIDED"]),
        ("/api/vehicle/mode", '{"mode": 4}', ["mode", "string"]),
        ("/api/vehicle/mode", '{"mode": "NO_SUCH_8"}', ["unknown mode"]),
    ],
)
def test_bad_command_input_is_422_with_a_sentence(client, path, body, words):
    r = client.post(path, content=body, headers={**AUTH, "Content-Type": "application/json"})
    assert_sentence(r, 422, *words)


@pytest.mark.parametrize("body", ["{not json", '{"altitude_m": true}', "[" * 5000, ""])
def test_without_the_token_a_body_is_not_even_read(client, body):
    r = client.post(
        "/api/vehicle/takeoff", content=body, headers={"Content-Type": "application/json"}
    )
    assert_sentence(r, 401, "token")


@pytest.mark.parametrize(
    ("method", "path", "status"),
    [
        ("post", "/api/references/9999/activate", 404),
        ("get", "/api/references/9999/image/original", 404),
        ("get", "/api/references/1/image/bogus", 422),
        ("post", "/api/references/abc/activate", 422),
        ("get", "/api/flights/9999", 404),
        ("get", "/api/flights/9999/tlog", 404),
        ("get", "/api/flights/9999/results", 404),
        ("get", "/api/flights/9999/frames", 404),
        ("get", "/api/flights/9999/frames/1.jpg", 404),
        ("get", "/api/flights/9999/frames/abc.jpg", 422),
        ("get", "/api/flights/9999/frames/12.png", 422),
        ("post", "/api/references/99999999999999999999999/activate", 422),
        ("get", "/api/references/-1/image/original", 422),
        ("get", "/api/flights/99999999999999999999999", 422),
        ("get", "/api/flights/0/frames", 422),
        ("get", "/api/nothing-here", 404),
        ("post", "/api/flights/stop", 409),
    ],
)
def test_unknown_ids_and_bad_paths(client, method, path, status):
    r = getattr(client, method)(path, headers=AUTH)
    assert r.status_code == status, r.text
    assert isinstance(r.json()["detail"], str) and r.json()["detail"]


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ({"jpeg_quality": "high"}, ["jpeg_quality"]),
        ({"jpeg_quality": 3}, ["jpeg_quality", "greater"]),
        ({"record_frames": "yes"}, ["record_frames", "boolean"]),
        ({"colour": "red"}, ["colour", "not permitted"]),
        ({"camera_mount_deg": [0, 60, 0]}, ["camera_mount_deg", "within 45 degrees"]),
        ({"camera_mount_deg": [0, 0, 200]}, ["camera_mount_deg", "-180..180"]),
        ({"camera_mount_deg": [0, 8]}, ["camera_mount_deg"]),
        ({"camera_mount_deg": "0,8,0"}, ["camera_mount_deg"]),
        ({"camera_mount_deg": [0, "ahead", 0]}, ["camera_mount_deg"]),
    ],
)
def test_bad_settings_are_refused(client, body, words):
    before = client.get("/api/settings").json()
    assert_sentence(client.put("/api/settings", json=body, headers=AUTH), 422, *words)
    assert client.get("/api/settings").json() == before  # (nothing changed)


def test_settings_change_and_show(client):
    before = client.get("/api/settings").json()
    assert before["record_frames"] is True and before["view_requires_token"] is False
    assert before["camera_mount_deg"] == [0.0, 0.0, 0.0]  # (straight down, as not told)
    r = client.put("/api/settings", json={"jpeg_quality": 60}, headers=AUTH)
    assert r.status_code == 200 and r.json()["jpeg_quality"] == 60
    assert client.get("/api/settings").json()["jpeg_quality"] == 60


@pytest.mark.parametrize("raw", ["[NaN, 0, 0]", "[0, Infinity, 0]", "[0, 0, -1e400]"])
def test_a_mount_of_no_finite_angles_is_refused(client, raw):
    # (JSON as Python reads it takes these words; no mount is made of them)
    headers = {**AUTH, "Content-Type": "application/json"}
    r = client.put("/api/settings", content=f'{{"camera_mount_deg": {raw}}}', headers=headers)
    assert_sentence(r, 422, "camera_mount_deg", "finite")
    assert client.get("/api/settings").json()["camera_mount_deg"] == [0.0, 0.0, 0.0]


def test_the_camera_mount_is_set_while_running_and_every_viewer_told(client):
    station = client.app.state.station
    with client.websocket_connect("/ws") as ws:
        assert ws.receive_json()["settings"]["camera_mount_deg"] == [0.0, 0.0, 0.0]
        r = client.put("/api/settings", json={"camera_mount_deg": [-2, 8.5, 90]}, headers=AUTH)
        assert r.status_code == 200, r.text
        assert r.json()["camera_mount_deg"] == [-2.0, 8.5, 90.0]
        told = _next_event(ws, "settings")
    try:
        assert told["changes"] == {"camera_mount_deg": [-2.0, 8.5, 90.0]}
        assert "roll, pitch, yaw -2, 8.5, 90 degrees" in told["text"]
        assert client.get("/api/settings").json()["camera_mount_deg"] == [-2.0, 8.5, 90.0]
        # What the hints and the next mission take the camera's turn from.
        assert np.allclose(station.runtime.mount_rotation, mount_rotation(-2.0, 8.5, 90.0))
        assert np.allclose(
            station.vehicle.land_config().mount.rotation, mount_rotation(-2, 8.5, 90)
        )
        bad = client.put("/api/settings", json={"camera_mount_deg": [0, 46, 0]}, headers=AUTH)
        assert bad.status_code == 422
        assert client.get("/api/settings").json()["camera_mount_deg"] == [-2.0, 8.5, 90.0]
    finally:
        client.put("/api/settings", json={"camera_mount_deg": [0, 0, 0]}, headers=AUTH)
    assert np.allclose(station.vehicle.land_config().mount.rotation, DOWN_MOUNT)


def test_a_mount_set_while_running_is_kept_unless_one_is_given_at_start(tmp_path):
    settings = make_settings(tmp_path)
    with in_process(settings) as first:
        r = first.put("/api/settings", json={"camera_mount_deg": [0, 7, 0]}, headers=AUTH)
        assert r.status_code == 200
    with in_process(settings) as second:
        assert second.get("/api/settings").json()["camera_mount_deg"] == [0.0, 7.0, 0.0]
        assert np.allclose(second.app.state.station.runtime.mount_rotation, mount_rotation(0, 7, 0))
    with in_process(make_settings(tmp_path, camera_mount=(1.0, 2.0, 3.0))) as third:
        assert third.get("/api/settings").json()["camera_mount_deg"] == [1.0, 2.0, 3.0]


def _next_event(ws, kind: str) -> dict:
    for _ in range(200):
        raw = ws.receive()
        if "text" not in raw:
            continue  # a camera or threshold picture (binary), sent whenever one is ready
        msg = json.loads(raw["text"])
        if msg["type"] == "event" and msg["kind"] == kind:
            return msg
    raise AssertionError(f"no {kind} event")


def test_viewing_can_require_the_token(client):
    r = client.put("/api/settings", json={"view_requires_token": True}, headers=AUTH)
    assert r.status_code == 200
    try:
        assert_sentence(client.get("/api/status"), 401, "token")
        assert client.get("/api/status", headers=AUTH).status_code == 200
        assert client.get("/api/health").status_code == 200  # liveness stays open
        with client.websocket_connect("/ws") as ws, pytest.raises(WebSocketDisconnect) as info:
            ws.send_text('{"type": "auth", "token": "wrong-token"}')
            ws.receive_json()
        assert info.value.code == 4401
        # The token never goes in a URL: refused before the socket opens.
        with pytest.raises(WebSocketDisconnect), client.websocket_connect(f"/ws?token={TOKEN}"):
            pass
        with client.websocket_connect("/ws") as ws:
            ws.send_text(f'{{"type": "auth", "token": "{TOKEN}"}}')
            assert ws.receive_json()["type"] == "hello"
    finally:
        client.put("/api/settings", json={"view_requires_token": False}, headers=AUTH)
    assert client.get("/api/status").status_code == 200


def test_flights_on_demand(client):
    assert client.post("/api/flights/start").status_code == 401
    started = client.post("/api/flights/start", headers=AUTH)
    assert started.status_code == 200
    flight = started.json()
    assert client.get("/api/status").json()["flight"] == flight
    again = client.post("/api/flights/start", headers=AUTH).json()
    assert again == flight  # one flight at a time
    wait_for(lambda: client.get(f"/api/flights/{flight['id']}/frames").json(), timeout=10)
    stopped = client.post("/api/flights/stop", headers=AUTH)
    assert stopped.status_code == 200 and stopped.json()["id"] == flight["id"]
    row = client.get(f"/api/flights/{flight['id']}").json()
    assert row["reason"] == "operator" and row["end_reason"] == "operator" and row["ended"]
    assert row["frames"] >= 1
    assert client.get(f"/api/flights/{flight['id']}/tlog").status_code == 200
    lines = client.get(f"/api/flights/{flight['id']}/results").text.splitlines()
    assert len(lines) == row["frames"]
    assert_sentence(client.post("/api/flights/stop", headers=AUTH), 409, "no flight")


# --- references ----------------------------------------------------------------------------
def test_upload_list_activate_and_pictures(client):
    default_id = active_id(client)
    r = upload(client, png(make_pad_image(600)), pad_size="1.0", name="big pad.png")
    assert r.status_code == 201, r.text
    summary = r.json()
    assert summary["active"] and summary["pad_size_m"] == 1.0 and summary["name"] == "big pad.png"
    assert len(summary["corners_m"]) == 12 and len(summary["hu"]) == 7
    assert summary["image_size"] == [600, 600] and summary["symmetric"] is True
    assert active_id(client) == summary["id"]
    for kind, url in summary["images"].items():
        pic = client.get(url)
        assert pic.status_code == 200 and pic.headers["content-type"] == "image/png", kind
        image = cv2.imdecode(np.frombuffer(pic.content, np.uint8), cv2.IMREAD_UNCHANGED)
        assert image.shape[:2] == (600, 600), kind
    listed = client.get("/api/references").json()
    assert [x["id"] for x in listed][:2] == [summary["id"], default_id]
    assert [x["active"] for x in listed][:2] == [True, False]
    r = client.post(f"/api/references/{default_id}/activate", headers=AUTH)
    assert r.status_code == 200 and r.json()["active"] and active_id(client) == default_id
    assert client.post(f"/api/references/{summary['id']}/activate").status_code == 401
    assert active_id(client) == default_id


def _magenta_pixels(client, summary: dict) -> np.ndarray:
    """Where the reference's corners picture shows a smaller H told apart (magenta)."""
    pic = client.get(summary["images"]["corners"])
    image = cv2.imdecode(np.frombuffer(pic.content, np.uint8), cv2.IMREAD_COLOR)
    return np.argwhere(np.all(image == (255, 0, 255), axis=2))


def test_the_summary_says_what_the_reference_learned_and_the_corners_picture_shows_it(client):
    r = upload(client, png(helipad()), pad_size="1.0", name="helipad.png")
    assert r.status_code == 201, r.text
    summary = r.json()
    assert summary["letter_hs"] == 1 and summary["marks"] >= 7  # (the board's rim, the letters)
    magenta = _magenta_pixels(client, summary)
    assert len(magenta) > 100  # the letter H's outline, under the H: HELIPAD's first letter
    assert magenta[:, 0].min() > 640 and magenta[:, 1].max() < 240, magenta.min(axis=0)
    assert summary["outline_share"] == pytest.approx(1.0) and summary["slant_deg"] < 0.1
    r = upload(client, png(make_pad_image(600)), name="plain.png")
    assert r.json()["letter_hs"] == 0 and r.json()["marks"] == 3  # (its rim, two side bars)
    assert len(_magenta_pixels(client, r.json())) == 0
    # The same pad with ground around it: its outer edge spans 600 / 720 of the picture.
    picture = np.full((720, 720, 3), (60, 120, 70), np.uint8)
    picture[60:660, 60:660] = make_pad_image(600)
    r = upload(client, png(picture), name="uncropped.png")
    assert r.json()["outline_share"] == pytest.approx(600 / 720, abs=0.01)


def test_an_h_run_into_its_ring_is_refused_with_the_reason(client):
    before = active_id(client)
    assert_sentence(
        upload(client, png(h_in_a_ring("crossed"))), 422, "runs into another mark of its paint"
    )
    assert active_id(client) == before


def test_a_pad_on_a_transparent_ground_is_taken(client):
    # A black H on a transparent ground stored as black (as many pictures from the web
    # are): read as colour alone, a black picture with no pad.
    icon = np.zeros((400, 400, 4), np.uint8)
    for x0, y0, x1, y1 in ((80, 80, 143, 319), (256, 80, 319, 319), (80, 172, 319, 227)):
        icon[y0 : y1 + 1, x0 : x1 + 1] = (20, 20, 20, 255)
    r = upload(client, png(icon), name="icon.png")
    assert r.status_code == 201, r.text
    assert r.json()["active"] and len(r.json()["corners_m"]) == 12


def test_oversized_upload_is_413_and_nothing_changes(client):
    before = active_id(client)
    big = b"\x89PNG\r\n\x1a\n" + np.random.default_rng(0).bytes(1_200_000)
    assert_sentence(upload(client, big), 413, "limit")
    assert active_id(client) == before


def test_chunked_oversized_upload_is_cut_off_with_413(client):
    before = active_id(client)

    def body():  # no Content-Length: the server counts as the bytes come
        yield b'--xyz\r\nContent-Disposition: form-data; name="pad_size_m"\r\n\r\n0.55\r\n'
        yield (
            b'--xyz\r\nContent-Disposition: form-data; name="file"; filename="a.png"\r\n'
            b"Content-Type: image/png\r\n\r\n\x89PNG\r\n\x1a\n"
        )
        for _ in range(40):
            yield b"\x00" * 65536
        yield b"\r\n--xyz--\r\n"

    r = client.post(
        "/api/reference",
        content=body(),
        headers={**AUTH, "content-type": "multipart/form-data; boundary=xyz"},
    )
    assert r.request.headers.get("transfer-encoding") == "chunked"
    assert_sentence(r, 413, "limit")
    assert active_id(client) == before


@pytest.mark.parametrize(
    "data",
    [
        b"hello, this is text and not a picture at all",
        b"\x89PNG\r\n\x1a\n" + b"\x00" * 500,
        b"\xff\xd8\xff" + b"junk" * 100,
        b"GIF89a" + b"\x00" * 100,
    ],
    ids=["text", "broken-png", "broken-jpeg", "gif"],
)
def test_non_image_is_415_and_nothing_changes(client, data):
    before = active_id(client)
    assert_sentence(upload(client, data), 415)
    assert active_id(client) == before


def test_empty_file_is_415(client):
    assert_sentence(upload(client, b""), 415, "empty")


def test_picture_without_h_is_422_with_the_pipelines_reason(client):
    before = active_id(client)
    image = np.zeros((300, 300, 3), np.uint8)
    cv2.circle(image, (150, 150), 80, (255, 255, 255), -1)
    with pytest.raises(ValueError) as reason:
        Reference.from_image(image, 0.55)
    r = upload(client, png(image))
    assert r.status_code == 422 and r.json()["detail"] == str(reason.value)
    assert active_id(client) == before


@pytest.mark.parametrize(
    ("pad", "words"),
    [
        ("0", ["pad_size_m", "greater than 0"]),
        ("-1", ["pad_size_m"]),
        ("abc", ["pad_size_m"]),
        ("25", ["pad_size_m", "less than"]),
        ("nan", ["pad_size_m"]),
    ],
)
def test_bad_pad_size_is_422(client, pad, words):
    before = active_id(client)
    assert_sentence(upload(client, png(make_pad_image(300)), pad_size=pad), 422, *words)
    assert active_id(client) == before


def test_missing_file_is_422(client):
    r = client.post("/api/reference", data={"pad_size_m": "0.55"}, headers=AUTH)
    assert_sentence(r, 422, "file", "required")


def test_references_persist_across_restart(tmp_path):
    settings = make_settings(tmp_path)
    with in_process(settings) as first:
        default_id = active_id(first)
        r = upload(first, png(make_pad_image(500)), pad_size="0.8")
        assert r.status_code == 201
        uploaded = r.json()["id"]
        assert (
            first.put("/api/settings", json={"record_frames": False}, headers=AUTH).status_code
            == 200
        )
    with in_process(settings) as second:
        assert active_id(second) == uploaded
        ids = [x["id"] for x in second.get("/api/references").json()]
        assert ids == [uploaded, default_id]
        assert second.get("/api/settings").json()["record_frames"] is False
        r = second.post(f"/api/references/{default_id}/activate", headers=AUTH)
        assert r.status_code == 200 and active_id(second) == default_id
        assert second.get(f"/api/references/{uploaded}/image/corners").status_code == 200


def test_a_stored_reference_that_no_longer_loads_is_told_and_the_default_pad_taken(tmp_path):
    settings = make_settings(tmp_path)
    with in_process(settings) as first:
        r = upload(first, png(make_pad_image(500)), pad_size="0.8", name="mine.png")
        assert r.status_code == 201
        stored = r.json()["id"]
    # Its picture, replaced by one of an H run into a ring (refused since stop 52).
    (picture,) = tmp_path.rglob(f"references/{stored}/original.png")
    assert cv2.imwrite(str(picture), h_in_a_ring("crossed"))
    with in_process(settings) as second:
        active = second.get("/api/reference").json()
        assert active["id"] != stored and active["name"] == "default pad"
        with second.websocket_connect("/ws") as ws:
            events = ws.receive_json()["events"]
        told = [e["text"] for e in events if e["kind"] == "reference"]
        assert any(
            f"reference {stored} (mine.png)" in t and "runs into another mark" in t for t in told
        ), told


# --- the WebSocket in-process --------------------------------------------------------------
def test_ws_hello_at_once_and_ping(client):
    with client.websocket_connect("/ws") as ws:
        hello = ws.receive_json()
        assert hello["type"] == "hello"
        assert set(hello) >= {"status", "telemetry", "reference", "settings"}
        assert hello["reference"]["id"] == active_id(client)
        kinds = [e["kind"] for e in hello["events"]]
        assert "link_up" in kinds and all(e["type"] == "event" for e in hello["events"])
        ws.send_json({"type": "ping"})
        for _ in range(200):
            msg = ws.receive()
            if "text" in msg and '"pong"' in msg["text"]:
                break
        else:
            pytest.fail("no pong")


@pytest.mark.parametrize(
    ("send", "words"),
    [
        ("this is not json", "JSON"),
        ('{"type": "launch-missiles"}', "Unknown message type"),
        ("[1, 2, 3]", "JSON objects"),
        ('{"no_type": 1}', "type"),
        ('{"type": "subscribe", "threshold": "yes"}', "bool"),
        (b"\x00\x01binary", "Binary"),
    ],
)
def test_ws_garbage_closes_politely(client, send, words):
    with client.websocket_connect("/ws") as ws:
        assert ws.receive_json()["type"] == "hello"
        if isinstance(send, bytes):
            ws.send_bytes(send)
        else:
            ws.send_text(send)
        for _ in range(1000):
            msg = ws.receive()
            if msg["type"] == "websocket.close":
                break
        else:
            pytest.fail("the server did not close the connection")
        assert msg["code"] == 1003
        assert words.lower() in (msg.get("reason") or "").lower()
