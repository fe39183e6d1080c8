"""The frame bus: each result published once, every consumer at its own pace.

A :class:`FrameBus` hands each published item to every subscriber's :class:`Slot`.
A slot holds only the newest item: a consumer that is slower than the producer
misses the items in between (counted as ``replaced``), never queues them, and never
makes the producer wait. A consumer thread waits on its slot (``take``); an asyncio
consumer passes ``on_put`` to be called (from the producer's thread) when an item
arrives. ``wanted`` says whether a consumer wants items now: a producer with costly
work (the encoder) skips it when no slot wants it.

>>> bus: FrameBus[int] = FrameBus("numbers")
>>> slot = bus.subscribe("reader")
>>> bus.publish(1)
>>> bus.publish(2)
>>> slot.take(timeout=0.0), slot.replaced
(2, 1)
>>> slot.take(timeout=0.0) is None
True
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

log = logging.getLogger(__name__)

T = TypeVar("T")


class Slot(Generic[T]):
    """One consumer's latest-value slot on a :class:`FrameBus`."""

    def __init__(
        self,
        name: str,
        *,
        wanted: Callable[[], bool] | None = None,
        on_put: Callable[[], None] | None = None,
    ) -> None:
        self.name = name
        self._wanted = wanted
        self._on_put = on_put
        self._cond = threading.Condition()
        self._item: T | None = None
        self._closed = False
        self._nudged = False
        self.received = 0
        self.replaced = 0

    @property
    def wanted(self) -> bool:
        """Whether the consumer wants items now (True unless it said otherwise)."""
        if self._wanted is None:
            return True
        try:
            return bool(self._wanted())
        except Exception:
            log.exception("slot %s: its wanted() failed", self.name)
            return False

    def put(self, item: T) -> None:
        """Hold ``item``, replacing an unread one (never blocks)."""
        with self._cond:
            if self._closed:
                return
            if self._item is not None:
                self.replaced += 1
            self._item = item
            self.received += 1
            self._cond.notify_all()
        if self._on_put is not None:
            try:
                self._on_put()
            except Exception:
                log.exception("slot %s: its on_put callback failed", self.name)

    def take(self, timeout: float | None = None) -> T | None:
        """The newest unread item (and forget it); ``None`` after ``timeout`` s or on close."""
        deadline = None if timeout is None else time.monotonic() + max(0.0, timeout)
        with self._cond:
            while self._item is None and not self._closed and not self._nudged:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    return None
                self._cond.wait(left)
            self._nudged = False
            item, self._item = self._item, None
            return item

    def nudge(self) -> None:
        """Wake a waiting ``take`` now, without an item (it returns ``None``)."""
        with self._cond:
            self._nudged = True
            self._cond.notify_all()

    def clear(self) -> None:
        """Forget an unread item (a consumer starting afresh wants only newer ones)."""
        with self._cond:
            self._item = None

    def close(self) -> None:
        """Wake a waiting consumer for good: ``take`` returns ``None`` from now on."""
        with self._cond:
            self._closed = True
            self._item = None
            self._cond.notify_all()

    @property
    def closed(self) -> bool:
        return self._closed


class FrameBus(Generic[T]):
    """Publishes each item once to every subscribed slot."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._slots: tuple[Slot[T], ...] = ()
        self._lock = threading.Lock()
        self.published = 0

    def subscribe(
        self,
        name: str,
        *,
        wanted: Callable[[], bool] | None = None,
        on_put: Callable[[], None] | None = None,
    ) -> Slot[T]:
        """A new slot that gets every item published from now on."""
        slot: Slot[T] = Slot(f"{self.name}/{name}", wanted=wanted, on_put=on_put)
        with self._lock:
            self._slots = (*self._slots, slot)
        return slot

    def unsubscribe(self, slot: Slot[T]) -> None:
        """Stop delivering to ``slot`` and close it."""
        with self._lock:
            self._slots = tuple(s for s in self._slots if s is not slot)
        slot.close()

    @property
    def slots(self) -> tuple[Slot[T], ...]:
        return self._slots

    def wanted(self) -> bool:
        """Whether any subscriber wants items now."""
        return any(slot.wanted for slot in self._slots)

    def publish(self, item: T) -> None:
        """Hand ``item`` to every slot (each put is a few microseconds, never a wait)."""
        self.published += 1
        for slot in self._slots:
            slot.put(item)

    def close(self) -> None:
        """Close every slot (their consumers wake up and stop)."""
        with self._lock:
            slots, self._slots = self._slots, ()
        for slot in slots:
            slot.close()
