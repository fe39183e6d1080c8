"""Shared test setup."""

import os
import threading
import time
from collections.abc import Iterator

import pytest
from threadpoolctl import threadpool_limits

# Training a reference's pattern verifier takes minutes of CPU: the tests that are
# about it ask for it; the others, and the servers they start as subprocesses
# (which inherit this environment), go without.
os.environ.setdefault("VISLAND_VERIFIER_VIEWS", "0")
# The BLAS on one thread, here and in the servers started as subprocesses, as the
# station runs it (backend.__main__): on a busy machine its threads only wait on each other.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
threadpool_limits(1, user_api="blas")


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
