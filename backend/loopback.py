"""The station's app on a real uvicorn server, on a free loopback port, from a thread of
this process: for the benches and tests that talk to a live station over real sockets."""

from __future__ import annotations

import socket
import threading
import time
from typing import Any, Self

import uvicorn

from backend.app import SERVER_OPTIONS, create_app
from backend.settings import Settings

START_TIMEOUT_S = 60.0
STOP_TIMEOUT_S = 20.0


class LoopbackServer:
    """``with LoopbackServer(settings) as s:`` the station runs at ``s.url`` until the
    block ends. ``send_buffer``: the listening socket's send buffer (bytes)."""

    def __init__(
        self, settings: Settings, *, send_buffer: int | None = None, name: str = "uvicorn-loopback"
    ) -> None:
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
            target=self.server.run, kwargs={"sockets": [self.sock]}, name=name, daemon=True
        )

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def ws_url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/ws"

    @property
    def station(self) -> Any:
        return self.app.state.station

    def __enter__(self) -> Self:
        self.thread.start()
        # (uvicorn tells it has started by a flag alone)
        deadline = time.monotonic() + START_TIMEOUT_S
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > deadline:
                self._stop()
                raise RuntimeError("uvicorn did not start")
            time.sleep(0.05)
        return self

    def __exit__(self, *exc: object) -> None:
        if not self._stop():
            raise RuntimeError(f"uvicorn did not stop within {STOP_TIMEOUT_S:g} s")

    def _stop(self) -> bool:
        """Ask the server to stop; whether it did within ``STOP_TIMEOUT_S``."""
        self.server.should_exit = True
        self.thread.join(STOP_TIMEOUT_S)
        self.sock.close()
        return not self.thread.is_alive()
