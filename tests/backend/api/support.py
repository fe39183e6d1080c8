"""Helpers for the API tests: settings for a fast stand-in, an in-process app, a live server."""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Callable, Iterator

import uvicorn
from fastapi.testclient import TestClient

from backend.app import SERVER_OPTIONS, create_app
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


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def in_process(settings: Settings) -> Iterator[TestClient]:
    """The app with its lifespan (the station runs), driven in-process."""
    with TestClient(create_app(settings)) as client:
        yield client


class LiveServer:
    """A real uvicorn server on a free loopback port, in a thread of this process."""

    def __init__(self, settings: Settings, *, send_buffer: int | None = None) -> None:
        self.app = create_app(settings)
        # Our own listening socket: accepted connections inherit its send buffer size,
        # so a small one makes a client that does not read push back within a second.
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if send_buffer is not None:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, send_buffer)
        self.sock.bind(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        config = uvicorn.Config(
            self.app,
            host="127.0.0.1",
            port=self.port,
            log_level="warning",
            lifespan="on",
            **SERVER_OPTIONS,  # type: ignore[arg-type]
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(
            target=self.server.run,
            kwargs={"sockets": [self.sock]},
            name="uvicorn-test",
            daemon=True,
        )

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/ws"

    @property
    def station(self):
        return self.app.state.station

    def __enter__(self) -> LiveServer:
        self.thread.start()
        wait_for(lambda: self.server.started or not self.thread.is_alive(), timeout=30)
        if not self.server.started:
            raise RuntimeError("uvicorn did not start")
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(20)
        self.sock.close()
        assert not self.thread.is_alive(), "uvicorn did not stop within 20 s"
