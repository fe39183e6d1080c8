"""The whole ground station on a real uvicorn server on a loopback port.

The stand-in ArduCopter (readiness scaled down), the simulated camera, the pipeline,
real HTTP and real WebSockets. The tests run in file order: the refused arm needs a
vehicle that is not ready yet, and the link-lost test stops the stand-in, so it is last.
"""

from __future__ import annotations

import base64
import json
import os
import socket
import time

import cv2
import httpx
import numpy as np
import pytest
from pymavlink import mavutil
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from backend.api.messages import (
    BinaryFrameHeader,
    FrameMessage,
    HelloMessage,
    StatusMessage,
    TelemetryMessage,
)
from backend.encoder import unpack_binary
from backend.loopback import LoopbackServer
from tests.backend.api.support import AUTH, make_settings, wait_for

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    settings = make_settings(tmp_path_factory.mktemp("live"), sim_ready_after=0.2)
    # Small socket send buffers: a client that does not read pushes back at once.
    with LoopbackServer(settings, send_buffer=8192) as server:
        yield server


@pytest.fixture(scope="module")
def http(live):
    with httpx.Client(base_url=live.url, timeout=10) as client:
        yield client


def recv_until(ws, predicate, timeout: float = 10.0):
    """Messages until one satisfies ``predicate``; returns it (binary messages as bytes)."""
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            raise AssertionError("no matching WebSocket message in time")
        msg = ws.recv(timeout=left)
        parsed = msg if isinstance(msg, bytes) else json.loads(msg)
        if predicate(parsed):
            return parsed


def test_arm_refused_before_ready_passes_the_reasons_verbatim(live, http):
    wait_for(lambda: http.get("/api/status").json()["link"]["state"] == "up", timeout=15)
    r = http.post("/api/vehicle/arm", headers=AUTH)
    assert r.status_code == 409, r.text
    body = r.json()
    assert body["ok"] is False and body["command"] == "arm" and body["result_name"] == "FAILED"
    assert body["reasons"], body
    assert all(x.startswith(("PreArm:", "Arm:")) for x in body["reasons"]), body
    texts = {
        t[2] if isinstance(t, list) else t["text"]
        for t in http.get("/api/telemetry").json()["statustexts"]
    }
    assert set(body["reasons"]) <= texts  # word for word what the vehicle said
    assert http.get("/api/telemetry").json()["armed"] is False


def test_health_and_status(http, live):
    assert http.get("/api/health").json()["ok"] is True
    status = http.get("/api/status").json()
    assert status["link"]["url"] == live.station.mavlink_url
    assert status["link"]["heartbeat_age_s"] is not None


def test_telemetry_moves(http):
    first = http.get("/api/telemetry").json()
    second = wait_for(lambda: (t := http.get("/api/telemetry").json()) != first and t, timeout=5)
    assert second["state"] == "up"
    assert second["msgs_per_s"] > 0


def test_upload_list_activate(http):
    from pipeline.render import make_pad_image

    _ok, buf = cv2.imencode(".png", make_pad_image(400))
    r = http.post(
        "/api/reference",
        files={"file": ("p.png", buf.tobytes())},
        data={"pad_size_m": "0.55"},
        headers=AUTH,
    )
    assert r.status_code == 201, r.text
    new = r.json()["id"]
    refs = http.get("/api/references").json()
    assert refs[0]["id"] == new and refs[0]["active"]
    old = refs[1]["id"]
    assert http.post(f"/api/references/{old}/activate", headers=AUTH).json()["active"]
    assert http.get("/api/reference").json()["id"] == old


def test_ws_hello_telemetry_frames_and_jpeg(live, http):
    # The hello reports the link as it is: up, once the stand-in has answered (the module's
    # first test waits for that too, but this one may run alone).
    wait_for(lambda: http.get("/api/status").json()["link"]["state"] == "up", timeout=15)
    with connect(live.ws_url, open_timeout=5) as ws:
        hello = json.loads(ws.recv(timeout=5))
        assert hello["type"] == "hello" and hello["telemetry"]["state"] == "up"
        HelloMessage.model_validate(hello)  # every message holds to the typed contract
        telemetry = recv_until(ws, lambda m: isinstance(m, dict) and m["type"] == "telemetry")
        assert "armed" in telemetry
        TelemetryMessage.model_validate(telemetry)
        frame = recv_until(ws, lambda m: isinstance(m, dict) and m["type"] == "frame")
        FrameMessage.model_validate(frame)
        assert set(frame["overlay"]) == {"reference_corners", "axes", "target"}
        assert frame["width"] == 640 and frame["height"] == 480
        assert {"detected", "corners_px", "hu", "pose"} <= set(frame["result"])
        binary = recv_until(ws, lambda m: isinstance(m, bytes))
        header, jpeg = unpack_binary(binary)
        BinaryFrameHeader.model_validate(header)
        assert header["kind"] == "camera" and header["seq"] >= frame["seq"]
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert image.shape == (header["height"], header["width"], 3)
        status = recv_until(ws, lambda m: isinstance(m, dict) and m["type"] == "status")
        assert status["pipeline"]["processed"] > 0
        StatusMessage.model_validate(status)


def test_ws_threshold_frames_only_when_asked(live):
    with connect(live.ws_url, open_timeout=5) as ws:
        ws.send(json.dumps({"type": "subscribe", "threshold": True}))
        binary = recv_until(
            ws, lambda m: isinstance(m, bytes) and unpack_binary(m)[0]["kind"] == "threshold"
        )
        header, jpeg = unpack_binary(binary)
        mask = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
        assert mask.shape == (header["height"], header["width"])


def test_ws_garbage_closes_with_1003_and_reconnect_gets_hello(live):
    with connect(live.ws_url, open_timeout=5) as ws:
        assert json.loads(ws.recv(timeout=5))["type"] == "hello"
        ws.send("}}} definitely not json")
        with pytest.raises(ConnectionClosed) as info:
            while True:
                ws.recv(timeout=5)
        assert info.value.rcvd.code == 1003 and "JSON" in info.value.rcvd.reason
    with connect(live.ws_url, open_timeout=5) as again:
        assert json.loads(again.recv(timeout=5))["type"] == "hello"  # the state at once


def _raw_ws_that_never_reads(port: int) -> socket.socket:
    sock = socket.socket()
    # A tiny receive window: the server's sends to this client back up at once.
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 2048)
    sock.settimeout(5)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            "Sec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    assert head.startswith(b"HTTP/1.1 101"), head
    return sock


def test_a_client_that_does_not_read_slows_nothing(live, http):
    hub = live.app.state.hub
    slow = _raw_ws_that_never_reads(live.port)
    try:
        processed_before = http.get("/api/status").json()["pipeline"]["processed"]
        seqs = []
        with connect(live.ws_url, open_timeout=5) as ws:
            deadline = time.monotonic() + 4.0
            while time.monotonic() < deadline:
                msg = ws.recv(timeout=5)
                if isinstance(msg, str) and '"type":"frame"' in msg.replace(" ", ""):
                    seqs.append(json.loads(msg)["seq"])
        processed_after = http.get("/api/status").json()["pipeline"]["processed"]
        stuck = min(hub.stats(), key=lambda c: c["sent"])
    finally:
        slow.close()
    # The reading client kept getting fresh frames, the pipeline kept going, and the
    # slow client's slots were overwritten (latest only) instead of queueing up.
    assert len(seqs) >= 10 and seqs == sorted(seqs)
    assert processed_after - processed_before >= 10
    assert stuck["replaced"] >= 10 and stuck["sent"] < len(seqs)
    assert http.get("/api/health").status_code == 200


def test_takeoff_after_guided_and_arm(live, http):
    def accepted(path, body=None):
        r = http.post(path, json=body, headers=AUTH)
        assert r.status_code in (200, 409), r.text
        return r.status_code == 200

    wait_for(lambda: accepted("/api/vehicle/mode", {"mode": "GUIDED"}), timeout=25, step=0.5)
    wait_for(lambda: accepted("/api/vehicle/arm"), timeout=25, step=0.5)
    r = http.post("/api/vehicle/takeoff", json={"altitude_m": 1.5}, headers=AUTH)
    assert r.status_code == 200, r.text
    assert r.json()["ok"] is True and r.json()["result_name"] == "ACCEPTED"
    wait_for(lambda: (http.get("/api/telemetry").json()["relative_alt_m"] or 0) > 0.8, timeout=15)
    flight = wait_for(lambda: http.get("/api/status").json()["flight"], timeout=3)
    # The flight began at arming and is being recorded: its tlog and results are there.

    def heartbeat_senders() -> set[int]:
        tlog = http.get(f"/api/flights/{flight['id']}/tlog")
        assert tlog.status_code == 200
        assert tlog.headers["content-type"] == "application/octet-stream"
        path = live.station.data_dir / "check.tlog"
        path.write_bytes(tlog.content)
        conn = mavutil.mavlink_connection(str(path))
        senders = set()
        while (msg := conn.recv_match(type="HEARTBEAT", blocking=False)) is not None:
            senders.add(msg.get_srcSystem())
        conn.close()
        return senders

    # The link flushes its log every second; the flight's copy fills in as it goes.
    wait_for(lambda: {1, 255} <= heartbeat_senders(), timeout=8, step=0.5)  # both ways
    # LAND: the vehicle descends, disarms by itself, and the flight ends with it.
    r = http.post("/api/vehicle/land", headers=AUTH)
    assert r.status_code == 200, r.text
    wait_for(lambda: http.get("/api/telemetry").json()["armed"] is False, timeout=30, step=0.2)
    wait_for(lambda: http.get("/api/status").json()["flight"] is None, timeout=5)
    listed = http.get("/api/flights").json()
    assert listed[0]["id"] == flight["id"] and listed[0]["ended"] is not None
    assert listed[0]["reason"] == "armed" and listed[0]["end_reason"] == "disarmed"
    results = http.get(f"/api/flights/{flight['id']}/results")
    lines = [json.loads(x) for x in results.text.splitlines()]
    assert lines and all({"seq", "t_capture", "t_unix", "result"} <= set(x) for x in lines)
    assert listed[0]["frames"] == len(lines)
    frames = http.get(f"/api/flights/{flight['id']}/frames").json()
    assert frames and http.get(frames[0]["url"]).headers["content-type"] == "image/jpeg"
    assert {1, 255} <= heartbeat_senders()  # the final log holds the whole flight


def test_link_lost_shows_when_the_stand_in_stops(live, http):
    with connect(live.ws_url, open_timeout=5) as ws:
        json.loads(ws.recv(timeout=5))
        live.station.stand_in.stop()
        event = recv_until(
            ws,
            lambda m: isinstance(m, dict) and m["type"] == "event" and m["kind"] == "link_lost",
            timeout=10,
        )
        assert event["text"]
    assert http.get("/api/status").json()["link"]["state"] == "lost"
    r = http.post("/api/vehicle/disarm", headers=AUTH)
    assert r.status_code == 503 and r.json()["result_name"] == "LINK_DOWN"
