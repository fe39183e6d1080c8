"""The settings the operator may change while the station runs (``PUT /api/settings``).

They start from the start-up settings, then what the operator set before (stored),
unless given explicitly at this start; changes are stored at once and logged.
"""

from __future__ import annotations

import threading
from typing import Any

from backend.services.events import EventLog
from backend.settings import Settings
from backend.storage import Storage

#: The settings that may change at run time.
RUNTIME_KEYS = ("view_requires_token", "record_frames", "jpeg_quality")


class RuntimeSettings:
    """The live values of :data:`RUNTIME_KEYS` plus the fixed facts viewers may see."""

    def __init__(
        self, settings: Settings, storage: Storage, events: EventLog, *, mavlink_url: str
    ) -> None:
        self._settings = settings
        self._storage = storage
        self._events = events
        self._lock = threading.Lock()
        self.mavlink_url = mavlink_url
        values: dict[str, Any] = {k: getattr(settings, k) for k in RUNTIME_KEYS}
        stored = storage.get_settings()
        for key in RUNTIME_KEYS:
            # What the operator set at run time persists, unless given explicitly now.
            if key in stored and key not in settings.model_fields_set:
                values[key] = stored[key]
        self._values = values

    @property
    def view_requires_token(self) -> bool:
        return bool(self._values["view_requires_token"])

    @property
    def record_frames(self) -> bool:
        return bool(self._values["record_frames"])

    @property
    def jpeg_quality(self) -> int:
        return int(self._values["jpeg_quality"])

    def values(self) -> dict[str, Any]:
        return dict(self._values)

    def update(self, changes: dict[str, Any]) -> dict[str, Any]:
        """Apply, store and log ``changes``; ``ValueError`` for unknown keys."""
        unknown = set(changes) - set(RUNTIME_KEYS)
        if unknown:
            raise ValueError(f"unknown settings: {', '.join(sorted(unknown))}")
        with self._lock:
            self._values = {**self._values, **changes}
            self._storage.put_settings(changes)
        self._events.emit("settings", "settings changed", {"changes": changes})
        return self.public()

    def public(self) -> dict[str, Any]:
        """What viewers see: the runtime values and the fixed facts of this start."""
        s = self._settings
        return {
            **self._values,
            "max_upload_bytes": s.max_upload_bytes,
            "max_upload_pixels": s.max_upload_pixels,
            "camera": s.camera,
            "mavlink": self.mavlink_url,
            "pad_size_m": s.pad_size,
            "pad_heading_deg": s.pad_heading_deg,
            "pad_north_m": s.pad_north,
            "pad_east_m": s.pad_east,
            "camera_hfov_deg": s.camera_hfov_deg,
            "camera_mount_deg": list(s.camera_mount),
            "camera_aspect": 4 / 3,
            "simulated_vehicle": s.mavlink is None,
        }
