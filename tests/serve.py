"""For the tests that start the station in its own process: a free loopback port and
``python -m backend serve``'s command line."""

from __future__ import annotations

import socket
import sys
from pathlib import Path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def serve_command(port: int, viser_port: int | None, data_dir: Path, *extra: str) -> list[str]:
    """``python -m backend serve`` on these ports (``viser_port`` None: its default) and
    data directory, then ``extra``."""
    viser = [] if viser_port is None else ["--viser-port", str(viser_port)]
    return [
        sys.executable,
        "-m",
        "backend",
        "serve",
        "--port",
        str(port),
        *viser,
        "--data-dir",
        str(data_dir),
        *extra,
    ]
