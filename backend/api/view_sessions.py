"""View cookies: what lets a dashboard's pictures and 3D view in when viewing needs the token.

An ``<img>`` or an ``<iframe>`` cannot send an ``Authorization`` header, and the token
never goes in a URL. So a dashboard that has the token asks ``POST /api/session``
(with the token) for a view cookie: a random value, not the token, ``HttpOnly`` (no
script reads it) and ``SameSite=Strict`` (no other site's page sends it). It lets
its holder view (GET routes, the 3D view), never command. The values live in memory:
a restart ends every session.
"""

from __future__ import annotations

import secrets
import threading
from collections import OrderedDict

VIEW_COOKIE = "visland_view"
#: Sessions kept; the oldest is forgotten beyond this (each browser makes one per load).
MAX_SESSIONS = 256


class ViewSessions:
    """The view cookies this process issued (newest :data:`MAX_SESSIONS`)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._values: OrderedDict[str, None] = OrderedDict()

    def new(self) -> str:
        value = secrets.token_urlsafe(32)
        with self._lock:
            self._values[value] = None
            while len(self._values) > MAX_SESSIONS:
                self._values.popitem(last=False)
        return value

    def valid(self, value: str | None) -> bool:
        if not value:
            return False
        with self._lock:
            return value in self._values

    def drop(self, value: str | None) -> None:
        with self._lock:
            self._values.pop(value or "", None)
