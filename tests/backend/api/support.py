"""Helpers for the API tests: settings for a fast stand-in, an in-process app (a live
server: `backend.loopback.LoopbackServer`)."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator

from fastapi.testclient import TestClient

from backend.app import create_app
from backend.settings import Settings

TOKEN = "test-operator-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


def make_settings(data_dir, **overrides) -> Settings:
    """Settings for tests: no 3D view, a stand-in that is ready within a few seconds."""
    values = {
        "data_dir": data_dir,
        "token": TOKEN,
        "viser_port": 0,
        "sim_ready_after": 0.08,
        "sim_speedup": 1.0,
        # the station's own default: a loaded machine may hold the stand-in's
        # heartbeats back for more than a second, which is no lost link
        "link_timeout_s": 3.0,
        "command_timeout_s": 3.0,
        # Starlette's TestClient names the server "testserver".
        "allowed_hosts": ["testserver"],
    }
    values.update(overrides)
    return Settings(**values)


def wait_for(predicate: Callable[[], object], timeout: float, step: float = 0.05) -> object:
    """Poll ``predicate`` until it returns something truthy; fail after ``timeout``."""
    deadline = time.monotonic() + timeout
    last = None
    while time.monotonic() < deadline:
        last = predicate()
        if last:
            return last
        time.sleep(step)
    raise AssertionError(f"condition not met within {timeout} s (last value {last!r})")


@contextlib.contextmanager
def in_process(settings: Settings) -> Iterator[TestClient]:
    """The app with its lifespan (the station runs), driven in-process."""
    with TestClient(create_app(settings)) as client:
        yield client
