"""What the station refused at its edge, counted: never a crash, never a log flood.

HTTP requests refused for their Host, Origin or site (or a token in the URL), and
WebSockets closed for the same reasons, a missing or wrong token or garbage. The counts
are in the status (``rejected``); the reasons go to the log at most now and then.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

log = logging.getLogger(__name__)

#: At most one log line per this many seconds (a flood of bad requests stays one line).
LOG_EVERY_S = 10.0


class Rejections:
    """Thread-safe counters of refused requests and sockets, with the latest reason."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.requests = 0
        self.sockets = 0
        self.last_reason = ""
        self._logged_at = -LOG_EVERY_S

    def request(self, reason: str) -> None:
        self._count("requests", reason)

    def socket(self, reason: str) -> None:
        self._count("sockets", reason)

    def _count(self, kind: str, reason: str) -> None:
        now = time.monotonic()
        with self._lock:
            setattr(self, kind, getattr(self, kind) + 1)
            self.last_reason = reason
            quiet = now - self._logged_at < LOG_EVERY_S
            if not quiet:
                self._logged_at = now
            counts = (self.requests, self.sockets)
        if not quiet:
            log.warning("refused: %s (%d requests, %d sockets refused so far)", reason, *counts)

    def to_dict(self) -> dict[str, Any]:
        with self._lock:
            return {
                "requests": self.requests,
                "sockets": self.sockets,
                "last_reason": self.last_reason,
            }
