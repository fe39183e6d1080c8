"""The station's event log: stored in SQLite, the recent ones kept in memory, fanned out.

Events come from many threads (the link's event thread, missions, the recorder, the
routes' worker threads); :meth:`EventLog.emit` stores each one and passes it to the
listeners (the WebSocket hub), which must hand it over without blocking. New viewers
get the recent events from memory: nothing on the event loop reads the database.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from backend.storage import Storage, StorageClosed

log = logging.getLogger(__name__)

#: Events a new viewer gets (the events panel's history).
RECENT = 50

EventListener = Callable[[dict[str, Any]], None]


def event_message(kind: str, text: str, t: float, data: dict[str, Any] | None) -> dict[str, Any]:
    """An event as the WebSocket sends it; the data's keys never override the message's.

    >>> event_message("mission", "hover: hold", 1.0, {"kind": "x", "state": "hold"})
    {'kind': 'mission', 'state': 'hold', 'type': 'event', 'text': 'hover: hold', 't': 1.0}
    """
    return {**(data or {}), "type": "event", "kind": kind, "text": text, "t": t}


class EventLog:
    """Store events, remember the recent ones, tell the listeners."""

    def __init__(self, storage: Storage | None) -> None:
        self._storage = storage
        self._lock = threading.Lock()
        self._listeners: tuple[EventListener, ...] = ()
        self._before: tuple[Callable[[], object], ...] = ()
        self._recent: deque[dict[str, Any]] = deque(maxlen=RECENT)
        if storage is not None:
            for e in storage.recent_events(RECENT):
                self._recent.append(event_message(e["kind"], e["text"], e["t"], e["data"]))

    def listen(self, listener: EventListener) -> Callable[[], None]:
        """Call ``listener(event)`` for every event from now on; returns the remover."""
        with self._lock:
            self._listeners = (*self._listeners, listener)

        def remove() -> None:
            with self._lock:
                self._listeners = tuple(x for x in self._listeners if x is not listener)

        return remove

    def before_each(self, hook: Callable[[], object]) -> None:
        """Call ``hook()`` before each event goes out (the status service refreshes its
        snapshot, so whoever sees an event then reads a status that shows it)."""
        self._before = (*self._before, hook)

    def emit(self, kind: str, text: str, data: dict[str, Any] | None = None) -> dict[str, Any]:
        """Store an event and pass it to the listeners; returns the event message."""
        for hook in self._before:
            try:
                hook()
            except Exception:
                log.exception("an event hook failed")
        t = time.time()
        event = event_message(kind, text, t, data)
        if self._storage is not None:
            try:
                self._storage.add_event(kind, text, data, t)
            except StorageClosed:
                # A part's last words while the station stops (a link's thread that
                # outlived its join timeout on a loaded machine): kept in the log.
                log.warning("event after the database closed, not stored: %s: %s", kind, text)
            except Exception:
                log.exception("could not store an event")
        with self._lock:
            self._recent.append(event)
            listeners = self._listeners
        for listener in listeners:
            try:
                listener(event)
            except Exception:
                log.exception("an event listener failed")
        return event

    def recent(self, limit: int = RECENT) -> list[dict[str, Any]]:
        """The last events, oldest first, shaped like the WebSocket's event messages."""
        with self._lock:
            events = list(self._recent)
        return events[-limit:] if limit > 0 else []
