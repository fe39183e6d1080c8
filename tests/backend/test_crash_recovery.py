"""SIGKILL mid-mission, then start again: nothing is left open, the database is sound.

A real ``python -m backend serve`` (real uvicorn, the stand-in vehicle, the simulated
camera) hovers over the pad, recording a flight; it is killed with SIGKILL, as a power
cut or the OOM killer would, then started again on the same data directory.
"""

from __future__ import annotations

import os
import signal
import sqlite3
import stat
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

from tests.backend.api.support import wait_for
from tests.serve import free_port, serve_command

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
TOKEN = "crash-test-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


@contextmanager
def serve(data_dir: Path, port: int) -> Iterator[subprocess.Popen]:
    env = {
        **os.environ,
        "VISLAND_TOKEN": TOKEN,
        "VISLAND_SIM_READY_AFTER": "0.1",
        "VISLAND_SIM_SPEEDUP": "2",
        "PYTHONUNBUFFERED": "1",
    }
    proc = subprocess.Popen(
        serve_command(port, 0, data_dir, "--log-level", "warning"),
        cwd=ROOT,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        wait_for(lambda: _health(port) or proc.poll() is not None, timeout=60, step=0.2)
        assert proc.poll() is None, "the station did not start"
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(10)


def _health(port: int) -> bool:
    try:
        return httpx.get(f"http://127.0.0.1:{port}/api/health", timeout=2).status_code == 200
    except httpx.TransportError:
        return False


def _get(port: int, path: str):
    return httpx.get(f"http://127.0.0.1:{port}{path}", timeout=10).json()


def test_sigkill_mid_mission_then_restart_leaves_nothing_open(tmp_path):
    port = free_port()
    db = tmp_path / "visland.db"
    with serve(tmp_path, port) as proc:
        base = f"http://127.0.0.1:{port}"

        def ready() -> bool:
            t = _get(port, "/api/telemetry")
            return bool(t["prearm_ok"] and (t["ekf"] or {}).get("pos_horiz_ok"))

        wait_for(ready, timeout=60, step=0.3)
        r = httpx.post(
            f"{base}/api/missions/hover", json={"altitude_m": 2.0, "hold_s": 300}, headers=AUTH
        )
        assert r.status_code == 200, r.text
        # Mid-mission: over the pad, a flight recording frames, the run's states stored.
        wait_for(
            lambda: (_get(port, "/api/missions/current") or {}).get("state") == "hold",
            timeout=90,
            step=0.3,
        )
        flight = _get(port, "/api/status")["flight"]
        assert flight is not None
        wait_for(lambda: len(_get(port, f"/api/flights/{flight['id']}/frames")) >= 5, timeout=30)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)

    con = sqlite3.connect(db)
    try:
        open_runs = con.execute("SELECT id FROM mission_runs WHERE ended IS NULL").fetchall()
        open_flights = con.execute("SELECT id FROM flights WHERE ended IS NULL").fetchall()
    finally:
        con.close()
    assert open_runs and open_flights == [(flight["id"],)]  # what the kill left open

    with serve(tmp_path, port):
        runs = _get(port, "/api/missions")
        assert runs and all(r["ended"] is not None and r["outcome"] for r in runs)
        killed = next(r for r in runs if r["id"] == open_runs[0][0])
        assert killed["outcome"] == "interrupted" and "station stopped" in killed["message"]
        detail = _get(port, f"/api/missions/{killed['id']}")["detail"]
        assert [s["state"] for s in detail["states"]][-1] == "hold"  # as far as it went
        flights = _get(port, "/api/flights")
        assert flights and all(f["ended"] is not None for f in flights)
        row = _get(port, f"/api/flights/{flight['id']}")
        assert row["end_reason"] == "interrupted" and row["frames"] >= 5
        frames = _get(port, f"/api/flights/{flight['id']}/frames")
        assert len(frames) >= 5
        tlog = httpx.get(f"http://127.0.0.1:{port}/api/flights/{flight['id']}/tlog", timeout=10)
        assert tlog.status_code == 200 and len(tlog.content) > 1000
        assert _get(port, "/api/missions/current") is None  # nothing running
    con = sqlite3.connect(db)
    try:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert (
            con.execute("SELECT count(*) FROM mission_runs WHERE ended IS NULL").fetchone()[0] == 0
        )
        assert con.execute("SELECT count(*) FROM flights WHERE ended IS NULL").fetchone()[0] == 0
    finally:
        con.close()
    # Everything the station wrote keeps to its owner: folders 0700, files 0600.
    modes = {p.relative_to(tmp_path): stat.S_IMODE(p.stat().st_mode) for p in tmp_path.rglob("*")}
    assert stat.S_IMODE(tmp_path.stat().st_mode) == 0o700
    loose = {str(p): oct(m) for p, m in modes.items() if m not in (0o600, 0o700)}
    assert not loose, loose
    assert any(p.suffix == ".jpg" for p in modes) and any(p.suffix == ".tlog" for p in modes)
