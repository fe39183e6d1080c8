"""The GPS-denied landing through the station: the external-navigation set-up (operator
token, parameters, reboot), then hover, land with the ``extnav`` strategy, GPS switched off
over the pad (SIM_GPS_DISABLE = 1): it lands on vision.

The whole station in-process (stand-in vehicle a little faster than real time, the
simulated camera rendered from the stand-in's true pose, the real pipeline).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from tests.backend.api.support import AUTH, in_process, make_settings, wait_for

PAD = {"pad_north": 2.0, "pad_east": 1.0, "pad_heading_deg": 30.0}


@pytest.fixture(scope="module")
def client(tmp_path_factory) -> Iterator[TestClient]:
    settings = make_settings(
        tmp_path_factory.mktemp("extnav"), sim_ready_after=0.05, sim_speedup=1.5, **PAD
    )
    with in_process(settings) as c:
        wait_for(lambda: c.get("/api/telemetry").json()["state"] == "up", timeout=10)
        yield c


def current(client: TestClient) -> dict:
    return client.get("/api/missions/current").json() or {}


def params(client: TestClient, *names: str) -> dict[str, float]:
    listing = client.get(f"/api/params?names={','.join(names)}").json()
    return {p["name"]: p["value"] for p in listing["params"]}


def test_setup_needs_the_operator_token(client):
    r = client.post("/api/params/extnav-setup")
    assert r.status_code == 401 and "operator token" in r.json()["detail"]


def test_extnav_landing_refused_before_the_setup(client):
    r = client.post("/api/missions/land", json={"strategy": "extnav"}, headers=AUTH)
    assert r.status_code == 200, r.text
    done = wait_for(lambda: (m := current(client)) and m.get("outcome") and m, timeout=15)
    assert done["outcome"] == "failed"
    assert "external navigation is not set up" in done["message"]
    assert "VISO_TYPE = 1 (now 0)" in done["message"]


@pytest.mark.slow
def test_gps_lost_over_the_pad_lands_on_vision_through_the_station(client):
    r = client.post("/api/params/extnav-setup", headers=AUTH)
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["ok"] and body["reboot"]["ok"]
    written = {w["name"]: w["value"] for w in body["writes"]}
    assert written["VISO_TYPE"] == 1 and written["EK3_SRC2_POSXY"] == 6
    assert written["ARMING_CHECK"] == 1835006  # every check but the vision's
    # back from the reboot with the parameters kept, and a position again
    wait_for(lambda: params(client, "VISO_TYPE").get("VISO_TYPE") == 1, timeout=30, step=0.5)

    def ready() -> bool:
        t = client.get("/api/telemetry").json()
        return bool(t["state"] == "up" and t["prearm_ok"] and (t["ekf"] or {}).get("pos_horiz_ok"))

    wait_for(ready, timeout=60, step=0.2)
    r = client.post("/api/missions/hover", json={"altitude_m": 3.0, "hold_s": 60}, headers=AUTH)
    assert r.status_code == 200, r.text
    wait_for(lambda: current(client).get("state") == "hold", timeout=60, step=0.2)
    wait_for(lambda: current(client)["detections"] > 10, timeout=20, step=0.2)
    assert client.post("/api/missions/abort", headers=AUTH).status_code == 200
    r = client.post(
        "/api/missions/land", json={"strategy": "extnav", "approach_alt_m": 3.0}, headers=AUTH
    )
    assert r.status_code == 200, r.text
    assert r.json()["mission"]["strategy"] == "extnav"
    # on vision over the pad: GPS goes
    wait_for(
        lambda: current(client).get("state") in ("settle", "descend", "landed", "failed"),
        timeout=60,
        step=0.1,
    )
    assert current(client)["state"] in ("settle", "descend"), current(client)
    r = client.put("/api/params/SIM_GPS_DISABLE", json={"value": 1}, headers=AUTH)
    assert r.status_code == 200, r.text
    wait_for(
        lambda: (client.get("/api/telemetry").json()["gps"] or {}).get("fix_type", 9) <= 1,
        timeout=10,
    )
    done = wait_for(lambda: (m := current(client)) and m.get("outcome") and m, timeout=90, step=0.5)
    assert done["outcome"] == "landed", done
    assert "on vision navigation (ExternalNav)" in done["message"]
    # measured from telemetry here (the vehicle's own vision-fed estimate, not the truth):
    # the precision against the truth is test_land_extnav's (lockstep) and bench.sitl_gpsdenied's
    assert done["touchdown"]["source"] == "telemetry"
    assert done["touchdown"]["error_m"] < 0.30
    wait_for(lambda: current(client)["stored"], timeout=5)
    run = client.get(f"/api/missions/{client.get('/api/missions').json()[0]['id']}").json()
    states = [s["state"] for s in run["detail"]["states"]]
    assert {"switch", "settle", "descend", "landed"} <= set(states), states
    assert any("source set 2" in n for n in run["detail"]["notes"])
    assert any(t[1] == "vision_position" for t in run["detail"]["targets"])
