"""Waiting on what a background thread does (capture, board and link threads)."""

from __future__ import annotations

import time
from collections.abc import Callable


def wait_until(pred: Callable[[], object], timeout: float = 5.0) -> bool:
    """Poll ``pred`` until it is true or ``timeout`` s pass (threads need scheduling)."""
    deadline = time.monotonic() + timeout
    while not pred():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True
