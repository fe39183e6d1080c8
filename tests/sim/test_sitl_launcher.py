"""The SITL launcher: instances side by side, clean stops, readiness, bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sim.sitl import (
    ENV_DIR,
    Sitl,
    SitlError,
    SitlObserver,
    find_sitl_dir,
    ned_from_global,
    running_sitl,
    wait_ready,
)
from tests.sitl.support import requires_sitl


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie still answers kill(0): look at its state
    with open(f"/proc/{pid}/stat") as fh:
        return fh.read().rsplit(")", 1)[1].split()[0] != "Z"


def test_find_sitl_dir_honours_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(ENV_DIR, str(tmp_path))
    assert find_sitl_dir() is None  # nothing there
    (tmp_path / "arducopter").write_text("#!/bin/sh\n")
    (tmp_path / "arducopter").chmod(0o755)
    (tmp_path / "copter.parm").write_text("")
    assert find_sitl_dir() == tmp_path.resolve()


def test_bad_arguments_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="speedup"):
        Sitl(speedup=0, sitl_dir=tmp_path)
    with pytest.raises(ValueError, match="start_timeout_s"):
        Sitl(speedup=1, sitl_dir=tmp_path, start_timeout_s=-1)
    with pytest.raises(SitlError, match="sitl_dir"):
        Sitl(speedup=1, sitl_dir=tmp_path)
    with pytest.raises(ValueError, match="url"):
        SitlObserver("udp:127.0.0.1:5760")


def test_ned_from_global_is_metres_from_the_origin() -> None:
    n, e, d = ned_from_global(-35.0 + 1e-5, 149.0, 590.0, (-35.0, 149.0, 584.0))
    assert n == pytest.approx(1.113, abs=0.01) and e == pytest.approx(0.0) and d == -6.0


@pytest.mark.sitl
@requires_sitl
def test_two_at_once_on_their_own_ports_and_stopped_with_their_children() -> None:
    with running_sitl(speedup=10) as a, running_sitl(speedup=10) as b:
        assert a.instance != b.instance and a.url != b.url
        assert a.pid is not None and b.pid is not None
        workdirs = [a.workdir, b.workdir]
        pids = [a.pid, b.pid]
        assert all(w is not None and w.is_dir() for w in workdirs)
    assert not any(_alive(pid) for pid in pids)
    assert not any(w is not None and w.exists() for w in workdirs)


@pytest.mark.sitl
@requires_sitl
def test_a_failing_test_still_stops_it() -> None:
    pid = None
    with pytest.raises(RuntimeError, match="boom"), running_sitl(speedup=10) as sitl:
        pid = sitl.pid
        raise RuntimeError("boom")
    assert pid is not None and not _alive(pid)


@pytest.mark.sitl
@requires_sitl
def test_readiness_is_the_firmwares_own() -> None:
    with running_sitl(speedup=10) as sitl, SitlObserver(sitl.url) as obs:
        ready = wait_ready(obs, timeout=120)
        assert ready.boot_at_using_gps_s is not None and 35 < ready.boot_at_using_gps_s < 50
        assert ready.origin_set_s < ready.using_gps_s <= ready.local_position_s
        truth = obs.truth()
        assert truth is not None and abs(truth.position_ned[2]) < 1.0
        assert "EKF3 IMU0 is using GPS" in ready.texts


@pytest.mark.sitl
@requires_sitl
def test_the_command_line_probe_prints_json() -> None:
    env = {**os.environ, "VISLAND_SITL_SPEEDUP": "10"}
    out = subprocess.run(
        [sys.executable, "-m", "sim.sitl", "--probe", "--timeout", "120"],
        capture_output=True,
        text=True,
        timeout=180,
        env=env,
        check=True,
    )
    data = json.loads(out.stdout)
    assert data["speedup"] == 10.0 and data["url"].startswith("tcp:127.0.0.1:")
    assert 35 < data["readiness"]["boot_at_using_gps_s"] < 50
