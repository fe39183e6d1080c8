"""``python -m backend serve`` as a newcomer runs it: a subprocess, its output, a clean exit."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from tests.serve import free_port, serve_command

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_serve_prints_urls_runs_and_stops_on_sigint(tmp_path):
    port, viser_port = free_port(), free_port()
    env = {**os.environ, "VISLAND_SIM_READY_AFTER": "0.1", "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        serve_command(port, viser_port, tmp_path),
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        lines = [proc.stdout.readline() for _ in range(5)]
        text = "".join(lines)
        token = (tmp_path / "token").read_text().strip()
        assert f"dashboard  http://127.0.0.1:{port}" in text
        assert f"3D view    http://127.0.0.1:{port}/view3d/" in text
        # Into a pipe (a log, a service's journal) the token is not printed: only where.
        assert token not in text and str(tmp_path / "token") in text
        deadline = time.monotonic() + 30
        while True:
            try:
                r = httpx.get(f"http://127.0.0.1:{port}/api/health", timeout=2)
                break
            except httpx.TransportError:
                assert time.monotonic() < deadline, "the server did not come up"
                assert proc.poll() is None, proc.stdout.read()
                time.sleep(0.2)
        assert r.json()["ok"] is True
        status = httpx.get(f"http://127.0.0.1:{port}/api/status", timeout=5).json()
        assert status["viser_url"] == "/view3d/"
        assert httpx.get(f"http://127.0.0.1:{port}/view3d/", timeout=5).status_code == 200
        r = httpx.post(f"http://127.0.0.1:{port}/api/vehicle/arm", timeout=5)
        assert r.status_code == 401
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
            raise
    assert proc.returncode == 0


def test_a_busy_port_is_a_one_line_error(tmp_path):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        out = subprocess.run(
            serve_command(port, None, tmp_path),
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert out.returncode == 2
    assert out.stderr.strip() == f"error: 127.0.0.1:{port} is in use: choose another with --port"


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--pad-size", "-1"], "pad_size"),
        (["--camera", "webcam"], "camera must be"),
        (["--port", "99999"], "port"),
    ],
)
def test_bad_flags_are_refused_before_anything_starts(tmp_path, args, words):
    out = subprocess.run(
        [sys.executable, "-m", "backend", "serve", "--data-dir", str(tmp_path), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 2 and words in out.stderr
    assert not (tmp_path / "visland.db").exists()


def test_the_token_is_shown_only_on_a_terminal(tmp_path, monkeypatch):
    from backend.__main__ import _token_line

    path = tmp_path / "token"
    monkeypatch.setattr(sys.stdout, "isatty", lambda: True)
    assert _token_line("s3cret-token-value", path).startswith("s3cret-token-value")
    monkeypatch.setattr(sys.stdout, "isatty", lambda: False)
    line = _token_line("s3cret-token-value", path)
    assert "s3cret" not in line and str(path) in line
