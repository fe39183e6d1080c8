"""Fixtures: genuine ArduCopter SITL, skipped when ``../shared/sitl`` is absent.

One booted SITL is shared by the tests that can undo what they change (``flight``);
tests about the boot itself get their own (``fresh_flight``). Each SITL is stopped
with its process group when its fixture ends, whatever the test did.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.sitl.support import SITL_DIR, Flight, running_flight


@pytest.fixture
def fresh_flight() -> Iterator[Flight]:
    """A SITL of its own, from a fresh eeprom, the link connected first."""
    if SITL_DIR is None:
        pytest.skip("no ArduCopter SITL")
    with running_flight() as flight:
        yield flight


@pytest.fixture(scope="session")
def shared_flight() -> Iterator[Flight]:
    if SITL_DIR is None:
        pytest.skip("no ArduCopter SITL")
    with running_flight() as flight:
        flight.wait_ready()
        yield flight


@pytest.fixture
def flight(shared_flight: Flight) -> Iterator[Flight]:
    """The shared SITL, ready and disarmed; what the test changed is undone after it."""
    shared_flight.reset()
    yield shared_flight
    shared_flight.reset()
