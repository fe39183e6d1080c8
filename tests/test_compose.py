"""docker-compose.yml and the Dockerfile: parsed, and the promises they make checked."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

yaml = pytest.importorskip("yaml", reason="PyYAML is needed to parse docker-compose.yml")

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def test_gcs_service_builds_this_repo_and_publishes_loopback_only(compose):
    gcs = compose["services"]["gcs"]
    assert gcs["build"]["context"] == "." and gcs["build"]["dockerfile"] == "Dockerfile"
    assert (ROOT / gcs["build"]["dockerfile"]).is_file()
    assert "profiles" not in gcs  # `docker compose up` starts it
    # one port: the 3D view comes through the station (/view3d/), not a port of its own
    assert sorted(gcs["ports"]) == ["127.0.0.1:8000:8000"]
    for service in compose["services"].values():
        for port in service.get("ports", []):
            assert str(port).startswith("127.0.0.1:"), f"{port} would be reachable from the LAN"


def test_gcs_environment_and_data_volume(compose):
    gcs = compose["services"]["gcs"]
    env = gcs["environment"]
    assert env["VISLAND_DATA_DIR"] == "/data"
    assert env["VISLAND_HOST"] == "0.0.0.0"  # inside the container; published on loopback
    assert env["VISLAND_MAVLINK"] == "${VISLAND_MAVLINK:-}"  # empty: the built-in stand-in
    # blank unless given: what the operator sets at run time is kept across restarts
    for key in ("VISLAND_CAMERA_MOUNT", "VISLAND_VIEW_REQUIRES_TOKEN"):
        assert env[key] == f"${{{key}:-}}", key
    assert "visland-data:/data" in gcs["volumes"]
    assert "visland-data" in compose["volumes"]
    assert all(k.startswith("VISLAND_") for k in env)
    test = " ".join(gcs["healthcheck"]["test"])
    assert "/api/health" in test


def test_optional_sitl_service_and_the_gcs_pointing_at_it(compose):
    services = compose["services"]
    sitl = services["sitl"]
    assert sitl["profiles"] == ["sitl"]
    assert "5760" in [str(p) for p in sitl["expose"]]
    assert "ports" not in sitl
    inline = sitl["build"]["dockerfile_inline"]
    assert "Copter-4.5.6" in inline and "./waf copter" in inline
    gcs_sitl = services["gcs-sitl"]
    assert gcs_sitl["profiles"] == ["sitl"]
    assert gcs_sitl["environment"]["VISLAND_MAVLINK"] == "tcp:sitl:5760"
    assert "sitl" in gcs_sitl["depends_on"]
    assert gcs_sitl["build"] == services["gcs"]["build"]


def test_compose_documents_both_ways_to_start(compose):
    text = (ROOT / "docker-compose.yml").read_text()
    assert "docker compose up --build" in text
    assert "docker compose --profile sitl up --build gcs-sitl" in text


def test_dockerfile_runs_the_server_and_exposes_its_ports():
    text = (ROOT / "Dockerfile").read_text()
    assert re.search(r'^CMD \["python", "-m", "backend", "serve"\]', text, re.M)
    assert re.search(r"^EXPOSE 8000$", text, re.M)
    assert "torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu" in text
    assert "npm run build" in text and "frontend/dist" in text
    assert re.search(r"^USER visland$", text, re.M)  # not root
    # numba's cache beside the installed package is root's: the user's own instead
    assert re.search(r"^ENV NUMBA_CACHE_DIR=/home/visland/", text, re.M)
