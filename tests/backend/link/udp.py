"""Waiting for a UDP port to be bound (the link binds it on its own thread)."""

from __future__ import annotations

import socket
import time


def wait_udp_bound(port: int, timeout: float = 20.0) -> bool:
    """Wait until something has bound UDP ``port`` here (a bind of our own then fails)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                return True
        time.sleep(0.01)
    return False
