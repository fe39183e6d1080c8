"""Link state and the events a :class:`~backend.link.vehicle_link.VehicleLink` publishes."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any


class LinkState(StrEnum):
    """Where the link to the vehicle stands.

    ``CONNECTING`` until the first vehicle HEARTBEAT, ``UP`` while heartbeats arrive,
    ``LOST`` after ``heartbeat_timeout_s`` without one (or when the transport drops),
    back to ``UP`` by itself when heartbeats return, ``CLOSED`` after ``close()``.
    """

    CONNECTING = "connecting"
    UP = "up"
    LOST = "lost"
    CLOSED = "closed"


#: Event kinds: link state changes, vehicle state changes, texts and command results.
EVENT_KINDS = frozenset(
    {
        "link_connecting",
        "link_up",
        "link_lost",
        "link_closed",
        "statustext",
        "mode_changed",
        "armed",
        "disarmed",
        "command",
    }
)


@dataclass(frozen=True)
class LinkEvent:
    """One thing that happened on the link, delivered to subscribers.

    Attributes
    ----------
    kind : str
        One of :data:`EVENT_KINDS`.
    data : dict
        JSON-serialisable details (the reason a link was lost, the text, the result).
    time : float
        UNIX time of the event.
    """

    kind: str
    data: dict[str, Any] = field(default_factory=dict)
    time: float = field(default_factory=time.time)

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable form."""
        return {"kind": self.kind, "time": self.time, "data": dict(self.data)}
