"""Fixtures shared by the backend tests."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest


@pytest.fixture
def no_leftover_threads() -> Iterator[None]:
    """Every test must stop the capture and board threads it started."""
    yield
    deadline = time.monotonic() + 2.0
    names = ("camera-", "cmucam4-board")
    while time.monotonic() < deadline:
        alive = [t.name for t in threading.enumerate() if t.name.startswith(names)]
        if not alive:
            return
        time.sleep(0.02)
    pytest.fail(f"threads left running: {alive}")
