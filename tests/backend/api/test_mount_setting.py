"""The camera's mount set while the station runs, on the whole station: the stand-in
vehicle, the simulated camera truly pitched 8 degrees ahead while the station is told
it looks straight down, the pipeline, the mount check, the settings route.

The check tells the operator the pixels lean off the attitude's level and which mount
they put the camera on; set so, the next detections' pixels lie level.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.backend.api.support import AUTH, in_process, make_settings, wait_for

PITCHED = (0.0, 8.0, 0.0)  # where the simulated camera truly looks
PAD = {"pad_north": 1.0, "pad_east": 0.5, "pad_heading_deg": 20.0}


@pytest.fixture(scope="module")
def client(tmp_path_factory) -> Iterator[TestClient]:
    settings = make_settings(
        tmp_path_factory.mktemp("mount"),
        sim_ready_after=0.05,
        sim_speedup=1.5,
        sim_camera_mount=PITCHED,
        **PAD,
    )
    with in_process(settings) as c:
        wait_for(lambda: c.get("/api/telemetry").json()["state"] == "up", timeout=10)
        yield c


def _median_lean_deg(client: TestClient, count: int, timeout: float) -> float:
    """The angle of the median lean rotation of the next ``count`` detections."""
    slot = client.app.state.station.results.subscribe("test-leans")
    leans: list[np.ndarray] = []
    deadline = time.monotonic() + timeout
    while len(leans) < count:
        assert time.monotonic() < deadline, f"{len(leans)} detections with a lean in {timeout} s"
        item = slot.take(timeout=1.0)
        pose = None if item is None else item.result.pose
        if pose is not None and pose.lean_rotation is not None:
            leans.append(np.asarray(pose.lean_rotation, float))
    return float(np.degrees(np.linalg.norm(np.median(leans, axis=0))))


def _still(telemetry: dict) -> bool:
    v, a = telemetry["velocity_ned"], telemetry["attitude"]
    if v is None or a is None:
        return False
    speed = float(np.linalg.norm([v["x"], v["y"], v["z"]]))
    turning = max(abs(a["rollspeed"]), abs(a["pitchspeed"]), abs(a["yawspeed"]))
    return speed < 0.05 and turning < 0.02


@pytest.mark.slow
def test_the_mount_the_pixels_suggest_set_while_hovering_levels_them(client):
    def ready() -> bool:
        t = client.get("/api/telemetry").json()
        return bool(t["prearm_ok"] and (t["ekf"] or {}).get("pos_horiz_ok"))

    wait_for(ready, timeout=30)
    assert client.get("/api/settings").json()["camera_mount_deg"] == [0.0, 0.0, 0.0]
    r = client.post("/api/missions/hover", json={"altitude_m": 3.0, "hold_s": 120}, headers=AUTH)
    assert r.status_code == 200, r.text
    storage = client.app.state.station.storage

    def warning() -> dict | None:
        said = [e for e in storage.recent_events(10_000) if e["kind"] == "vision"]
        return said[-1]["data"] if said else None

    told = wait_for(warning, timeout=90, step=0.5)
    assert isinstance(told, dict)
    roll, pitch, yaw = told["suggested_mount_deg"]
    assert abs(roll) < 1.5 and abs(pitch - PITCHED[1]) < 1.5 and yaw == 0.0, told
    # Not under a flying mission: it took the mount at its start.
    refused = client.put(
        "/api/settings", json={"camera_mount_deg": [roll, pitch, yaw]}, headers=AUTH
    )
    assert refused.status_code == 409 and "mission is running" in refused.json()["detail"]
    assert client.get("/api/settings").json()["camera_mount_deg"] == [0.0, 0.0, 0.0]
    before = _median_lean_deg(client, 20, timeout=60)
    assert before > 5.0  # (the pixels lean the pad by the mount's error)
    r = client.post("/api/missions/abort", headers=AUTH)
    assert r.status_code == 200, r.text  # (the vehicle holds over the pad)
    r = client.put("/api/settings", json={"camera_mount_deg": [roll, pitch, yaw]}, headers=AUTH)
    assert r.status_code == 200, r.text
    # (once it has stopped: braking, it leans a frame ahead of the attitude it reports)
    wait_for(lambda: _still(client.get("/api/telemetry").json()), timeout=30, step=0.2)
    after = _median_lean_deg(client, 40, timeout=60)
    # Under the check's WARN_DEG of 3 (0.4-1.1 seen in eight runs; frame to frame the
    # leans of this live loop spread over 0.3-6 degrees, so a median of 40 may stray).
    assert after < 2.5, (before, after)
