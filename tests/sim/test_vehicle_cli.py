"""`python -m sim.vehicle` as a real process: announces, serves, exits on signals."""

from __future__ import annotations

import select
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from pymavlink import mavutil

ROOT = Path(__file__).resolve().parents[2]


def _start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "sim.vehicle", *args],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _first_line(proc: subprocess.Popen[str], timeout: float = 15.0) -> str:
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    assert ready, "the stand-in printed nothing"
    return proc.stdout.readline().strip()


@pytest.fixture
def stand_in() -> Iterator[tuple[subprocess.Popen[str], str]]:
    proc = _start(
        "--mavlink",
        "tcp:127.0.0.1:0",
        "--ready-after",
        "0.05",
        "--speedup",
        "4",
        "--seed",
        "3",
        "--pad",
        "1,2,90",
        "--wind",
        "2",
        "--gusts",
        "0.5",
    )
    try:
        line = _first_line(proc)
        prefix = "stand-in ArduCopter listening on "
        assert line.startswith(prefix), line
        yield proc, line[len(prefix) :]
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(10)


def test_cli_serves_mavlink_and_exits_cleanly_on_sigterm(
    stand_in: tuple[subprocess.Popen[str], str],
) -> None:
    proc, address = stand_in
    m = mavutil.mavlink_connection(address, source_system=255, autoreconnect=False)
    try:
        hb = m.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
        assert hb is not None and hb.get_srcSystem() == 1
        m.mav.param_request_read_send(1, 1, b"SYSID_THISMAV", -1)
        value = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=10)
        assert value is not None and value.param_value == 1
    finally:
        m.close()
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(10) == 0


def test_cli_exits_on_sigint_too(stand_in: tuple[subprocess.Popen[str], str]) -> None:
    proc, _ = stand_in
    proc.send_signal(signal.SIGINT)
    assert proc.wait(10) == 0


@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["--mavlink", "bogus"], "url"),
        (["--mavlink", "tcp:127.0.0.1:0", "--signing-key", "zz"], "signing-key"),
        (["--mavlink", "tcp:127.0.0.1:0", "--signing-key", "00"], "signing_key"),
        (["--mavlink", "tcp:127.0.0.1:0", "--ready-after", "-1"], "ready_after_scale"),
        (["--mavlink", "tcp:127.0.0.1:0", "--home", "1,2"], "--home"),
        (["--mavlink", "/dev/does-not-exist"], "does not exist"),
    ],
)
def test_cli_rejects_bad_arguments(args: list[str], expect: str) -> None:
    proc = _start(*args)
    try:
        _, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 2
    assert expect in err


def test_cli_refuses_a_port_in_use() -> None:
    import socket

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(1)
    try:
        proc = _start("--mavlink", f"tcp:127.0.0.1:{s.getsockname()[1]}")
        _, err = proc.communicate(timeout=20)
        assert proc.returncode == 2 and "error" in err
    finally:
        s.close()
