"""A parameter download (:meth:`backend.services.params.ParamService.refresh`) against a
scripted vehicle on a real TCP socket, in real MAVLink bytes: a list that loses some of
its PARAM_VALUEs is completed by asking for the missing ones by index; a slow list is
not cut off while it keeps coming; a parameter that never comes ends the download at
its timeout, said as incomplete.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import LinkState, VehicleLink
from backend.services.events import EventLog
from backend.services.params import ParamService
from tests.backend.link.conftest import MavPeer

N = 50


class ListingVehicle:
    """Plays a vehicle's parameter protocol on ``peer``: N parameters, a list that leaves
    out ``dropped`` (what a lossy radio does), reads by index answered unless ``deaf``;
    ``pace_s`` > 0 trickles the list from a thread of its own, one at a time."""

    def __init__(
        self, peer: MavPeer, *, dropped: frozenset[int] = frozenset(), pace_s: float = 0.0
    ) -> None:
        self.peer = peer
        self.dropped = dropped
        self.pace_s = pace_s
        self.deaf_to_index = False
        self.lists = 0
        self.index_reads: list[int] = []
        self._stop = threading.Event()
        peer.responder = self.respond

    @staticmethod
    def name(index: int) -> str:
        return f"TEST_P{index:02d}"

    def value_msg(self, index: int) -> Any:
        return mavlink2.MAVLink_param_value_message(
            self.name(index).encode(), float(index), mavlink2.MAV_PARAM_TYPE_REAL32, N, index
        )

    def respond(self, peer: MavPeer, msg: Any) -> bool:
        mtype = msg.get_type()
        if mtype == "PARAM_REQUEST_LIST":
            self.lists += 1
            sent = [i for i in range(N) if i not in self.dropped]
            if self.pace_s > 0:
                threading.Thread(target=self._trickle, args=(sent,), daemon=True).start()
            else:
                for i in sent:
                    peer.send(self.value_msg(i))
            return True
        if mtype == "PARAM_REQUEST_READ" and msg.param_index >= 0:
            self.index_reads.append(msg.param_index)
            if not self.deaf_to_index and msg.param_index < N:
                peer.send(self.value_msg(msg.param_index))
            return True
        return False

    def _trickle(self, indices: list[int]) -> None:
        for i in indices:
            # a slow radio's pace (the vehicle's side; nothing in the test waits on it)
            if self._stop.wait(self.pace_s):
                return
            self.peer.send(self.value_msg(i))

    def close(self) -> None:
        self._stop.set()


@pytest.fixture
def setup(
    peer: MavPeer, make_link: Callable[..., VehicleLink]
) -> Iterator[Callable[..., tuple[ListingVehicle, VehicleLink, ParamService]]]:
    made: list[ListingVehicle] = []

    def make(**kwargs: Any) -> tuple[ListingVehicle, VehicleLink, ParamService]:
        vehicle = ListingVehicle(peer, **kwargs)
        made.append(vehicle)
        # a loaded machine may hold the peer's heartbeats back: not a lost link here
        link = make_link(f"tcp:127.0.0.1:{peer.port}", heartbeat_timeout_s=5.0)
        assert link.wait_until(lambda t: t.state == LinkState.UP, 10.0)
        return vehicle, link, ParamService(link, EventLog(None), latency_ms=lambda: None)

    yield make
    for vehicle in made:
        vehicle.close()


def test_what_the_list_lost_is_asked_for_by_index(setup) -> None:
    lost = frozenset({0, 3, 17, 18, 41, N - 1})
    vehicle, link, params = setup(dropped=lost)
    listing = params.refresh()
    assert listing["complete"] and listing["received"] == listing["count"] == N
    assert link.missing_params() == ([], N)
    # only the missing ones, by index: the whole list was not asked for again
    assert set(vehicle.index_reads) == lost
    assert vehicle.lists == 1
    values = {p["name"]: p["value"] for p in listing["params"]}
    assert values[ListingVehicle.name(41)] == 41.0


def test_a_list_that_keeps_coming_is_not_cut_off_at_the_timeout(setup) -> None:
    # 16 parameters 0.3 s apart: ~5 s in all, with nothing new for at most 0.3 s
    vehicle, _, params = setup(dropped=frozenset(range(16, N)), pace_s=0.3)
    vehicle.deaf_to_index = True  # the 16 the list sends are all it gives
    started = time.monotonic()
    listing = params.refresh(timeout_s=2.0)
    took = time.monotonic() - started
    assert listing["received"] == 16 and listing["count"] == N
    assert not listing["complete"]  # said honestly
    # ended 2 s after the last one came, not 2 s after the start
    assert took >= 16 * 0.3 + 2.0


def test_a_parameter_that_never_comes_ends_the_download_at_its_timeout(setup) -> None:
    vehicle, link, params = setup(dropped=frozenset({7}))
    vehicle.deaf_to_index = True
    started = time.monotonic()
    listing = params.refresh(timeout_s=3.0)
    assert time.monotonic() - started < 30.0
    assert listing["received"] == N - 1 and listing["count"] == N
    assert not listing["complete"]
    assert link.missing_params() == ([7], N)
    # asked for again by index after each stall, never the whole list
    assert vehicle.index_reads and set(vehicle.index_reads) == {7}
    assert vehicle.lists == 1


def test_a_reboot_forgets_which_indices_came_but_keeps_the_values(setup, peer: MavPeer) -> None:
    _, link, params = setup()
    peer.send(mavlink2.MAVLink_system_time_message(0, 600_000))
    assert params.refresh()["complete"]
    peer.send(mavlink2.MAVLink_system_time_message(0, 200))  # the clock went back
    assert link.wait_until(lambda t: t.boots == 1, 10.0)
    assert link.missing_params() == (list(range(N)), N)
    assert params.value(ListingVehicle.name(5)) == 5.0
