"""The missions API on the whole station (stand-in vehicle, simulated camera, pipeline).

Real HTTP routes in-process, real WebSocket messages, the mission thread in real time
against the stand-in running a few times faster than real time.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from tests.backend.api.support import AUTH, in_process, make_settings, wait_for

PAD = {"pad_north": 2.0, "pad_east": 1.0, "pad_heading_deg": 30.0}


@pytest.fixture(scope="module")
def client(tmp_path_factory) -> Iterator[TestClient]:
    settings = make_settings(
        tmp_path_factory.mktemp("missions"), sim_ready_after=0.05, sim_speedup=1.5, **PAD
    )
    with in_process(settings) as c:
        wait_for(lambda: c.get("/api/telemetry").json()["state"] == "up", timeout=10)
        yield c


def current(client: TestClient) -> dict | None:
    return client.get("/api/missions/current").json()


def test_commands_need_the_operator_token(client):
    for path in ("/api/missions/hover", "/api/missions/land", "/api/missions/abort"):
        r = client.post(path)
        assert r.status_code == 401, path
        assert "operator token" in r.json()["detail"]


def test_nothing_to_abort_is_a_conflict(client):
    r = client.post("/api/missions/abort", headers=AUTH)
    assert r.status_code == 409 and "No mission" in r.json()["detail"]


@pytest.mark.parametrize(
    ("path", "body", "word"),
    [
        ("/api/missions/land", {"strategy": "autoland"}, "strategy"),
        ("/api/missions/land", {"approach_alt_m": -2}, "approach_alt_m"),
        ("/api/missions/land", {"surprise": 1}, "surprise"),
        ("/api/missions/hover", {"altitude_m": 500}, "altitude_m"),
        # The cases: a tiny height is no height, a boolean is not a number.
        ("/api/missions/hover", {"altitude_m": 1e-300}, "altitude_m"),
        ("/api/missions/hover", {"altitude_m": True}, "altitude_m"),
        ("/api/missions/hover", {"hold_s": "20"}, "hold_s"),
        ("/api/missions/land", {"approach_alt_m": 0.5}, "approach_alt_m"),
        ("/api/missions/land", {"search_s": None}, "search_s"),
        ("/api/missions/hover", {"abort_mode": "LAND"}, "abort_mode"),
    ],
)
def test_bad_bodies_are_refused_with_the_field_named(client, path, body, word):
    r = client.post(path, json=body, headers=AUTH)
    assert r.status_code == 422
    assert word in r.text


def test_unknown_run_is_404(client):
    assert client.get("/api/missions/999999").status_code == 404
    assert client.get("/api/missions/0").status_code == 422


def test_land_on_the_ground_fails_and_is_recorded_and_broadcast(client):
    with client.websocket_connect("/ws") as ws:
        assert ws.receive_json()["type"] == "hello"
        r = client.post("/api/missions/land", json={"strategy": "guided"}, headers=AUTH)
        assert r.status_code == 200, r.text
        body = r.json()
        assert body["ok"] is True and body["result_name"] == "STARTED"
        assert body["mission"]["kind"] == "land" and body["mission"]["strategy"] == "guided"
        deadline = time.monotonic() + 10
        live = None
        while time.monotonic() < deadline:
            raw = ws.receive()
            if "text" not in raw:
                continue  # a camera or threshold picture (binary)
            msg = json.loads(raw["text"])
            mission = msg.get("mission") if msg["type"] == "status" else None
            if mission and mission["state"] == "failed":
                live = mission
                break
        assert live is not None, "no mission state over the WebSocket"
        assert "must be flying" in live["message"]
    # Stored when the mission thread finishes, a moment after the last state change.
    runs = wait_for(
        lambda: (runs := client.get("/api/missions").json()) and runs[0]["outcome"] and runs,
        timeout=5,
    )
    assert runs[0]["kind"] == "land" and runs[0]["outcome"] == "failed"
    assert runs[0]["strategy"] == "guided"
    full = client.get(f"/api/missions/{runs[0]['id']}").json()
    assert [s["state"] for s in full["detail"]["states"]] == ["check", "failed"]
    events = client.get("/api/status").json()
    assert events["mission"]["state"] == "failed"


@pytest.mark.slow
def test_hover_then_abort_then_land_by_vision(client):
    def ready() -> bool:
        t = client.get("/api/telemetry").json()
        return bool(t["prearm_ok"] and (t["ekf"] or {}).get("pos_horiz_ok"))

    wait_for(ready, timeout=30)  # GUIDED needs a position estimate
    r = client.post("/api/missions/hover", json={"altitude_m": 3.0, "hold_s": 60}, headers=AUTH)
    assert r.status_code == 200, r.text
    # One at a time.
    again = client.post("/api/missions/land", headers=AUTH)
    assert again.status_code == 409 and "running" in again.json()["detail"]
    # Over the pad, seeing it, centring on it.
    wait_for(lambda: (current(client) or {}).get("state") == "hold", timeout=30, step=0.2)
    wait_for(lambda: current(client)["detections"] > 10, timeout=15, step=0.2)
    snap = current(client)
    assert snap["fix"] is not None and snap["image_size"] == [640, 480]
    r = client.post("/api/missions/abort", headers=AUTH)
    assert r.status_code == 200, r.text
    assert r.json()["mission"]["state"] == "aborted"
    assert r.json()["mission"]["outcome"] == "aborted"
    # No RC transmitter on the stand-in: LOITER would sink, so the abort holds in GUIDED.
    assert "not LOITER" in r.json()["mission"]["message"]
    wait_for(lambda: client.get("/api/telemetry").json()["mode"] == "GUIDED", timeout=5)
    # Land from the hover, by GCS guidance (precision landing needs PLND_* set).
    r = client.post(
        "/api/missions/land", json={"strategy": "guided", "approach_alt_m": 3.0}, headers=AUTH
    )
    assert r.status_code == 200, r.text
    done = wait_for(
        lambda: (m := current(client)) and m["state"] in ("landed", "failed", "aborted") and m,
        timeout=90,
        step=0.5,
    )
    assert done["state"] == "landed", done
    wait_for(lambda: current(client)["stored"], timeout=5)
    # A whole flight of the stand-in's telemetry, and nothing of it impossible.
    telemetry = client.get("/api/telemetry").json()
    assert telemetry["implausible"] == 0, telemetry["last_implausible"]
    touchdown = done["touchdown"]
    assert touchdown["source"] == "telemetry"
    assert touchdown["error_m"] < 0.15
    runs = client.get("/api/missions").json()
    assert [r["outcome"] for r in runs[:2]] == ["landed", "aborted"]
    assert runs[0]["touchdown"]["error_m"] == touchdown["error_m"]
    # The camera is on the mount the station was told: through the whole flight (its
    # moves, the attitude a frame late), the pad's pixels never leant it off the
    # attitude's level enough for the mount check to say otherwise.
    stored = client.app.state.station.storage.recent_events(10_000)
    said = [e for e in stored if e["kind"] == "vision"]
    assert said == []
