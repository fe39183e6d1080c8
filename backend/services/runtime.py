"""The settings the operator may change while the station runs (``PUT /api/settings``).

They start from the start-up settings, then what the operator set before (stored),
unless given explicitly at this start; changes are stored at once and logged, and told
to the parts that follow them (`RuntimeSettings.listen`).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from backend.frames import mount_rotation
from backend.services.events import EventLog
from backend.settings import Settings, check_mount
from backend.storage import Storage

log = logging.getLogger(__name__)

#: The settings that may change at run time.
RUNTIME_KEYS = ("view_requires_token", "record_frames", "jpeg_quality", "camera_mount_deg")
#: ... by the start-up setting each comes from, where its name differs.
_START_UP_NAME = {"camera_mount_deg": "camera_mount"}


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
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        values: dict[str, Any] = {
            k: getattr(settings, _START_UP_NAME.get(k, k)) for k in RUNTIME_KEYS
        }
        stored = storage.get_settings()
        for key in RUNTIME_KEYS:
            # What the operator set at run time persists, unless given explicitly now.
            if key in stored and _START_UP_NAME.get(key, key) not in settings.model_fields_set:
                values[key] = stored[key]
        try:
            values["camera_mount_deg"] = check_mount(tuple(values["camera_mount_deg"]))
        except (TypeError, ValueError) as exc:  # (a store edited by hand)
            log.warning("the stored camera mount is ignored: %s", exc)
            values["camera_mount_deg"] = settings.camera_mount
        self._values = values
        self._mount_rotation = mount_rotation(*self.camera_mount)

    @property
    def view_requires_token(self) -> bool:
        return bool(self._values["view_requires_token"])

    @property
    def record_frames(self) -> bool:
        return bool(self._values["record_frames"])

    @property
    def jpeg_quality(self) -> int:
        return int(self._values["jpeg_quality"])

    @property
    def camera_mount(self) -> tuple[float, float, float]:
        """The camera's mount as the station is told it (roll, pitch, yaw degrees)."""
        roll, pitch, yaw = self._values["camera_mount_deg"]
        return float(roll), float(pitch), float(yaw)

    @property
    def mount_rotation(self) -> np.ndarray:
        """... as a rotation (``R_body_cam``, `backend.frames.mount_rotation`)."""
        return self._mount_rotation

    def values(self) -> dict[str, Any]:
        return dict(self._values)

    def listen(self, listener: Callable[[dict[str, Any]], None]) -> None:
        """Call ``listener`` with each change's values (after they apply)."""
        self._listeners.append(listener)

    def update(self, changes: dict[str, Any]) -> dict[str, Any]:
        """Apply, store, log and tell ``changes``; ``ValueError`` for unknown keys or a
        mount that cannot be one (nothing changes then)."""
        unknown = set(changes) - set(RUNTIME_KEYS)
        if unknown:
            raise ValueError(f"unknown settings: {', '.join(sorted(unknown))}")
        if "camera_mount_deg" in changes:
            changes = {**changes, "camera_mount_deg": check_mount(changes["camera_mount_deg"])}
        with self._lock:
            self._storage.put_settings(changes)
            self._values = {**self._values, **changes}
            self._mount_rotation = mount_rotation(*self.camera_mount)
        for listener in self._listeners:
            try:
                listener(changes)
            except Exception:  # (one part's failure must not undo the change for the rest)
                log.exception("a part could not follow the settings' change")
        text = "settings changed"
        if "camera_mount_deg" in changes:
            mount = _angles(changes["camera_mount_deg"])
            text = f"the camera's mount is now roll, pitch, yaw {mount} degrees"
        self._events.emit("settings", text, {"changes": changes})
        return self.public()

    def public(self) -> dict[str, Any]:
        """What viewers see: the runtime values and the fixed facts of this start."""
        s = self._settings
        return {
            **self._values,
            "camera_mount_deg": list(self.camera_mount),
            "max_upload_bytes": s.max_upload_bytes,
            "max_upload_pixels": s.max_upload_pixels,
            "camera": s.camera,
            "mavlink": self.mavlink_url,
            "pad_size_m": s.pad_size,
            "pad_heading_deg": s.pad_heading_deg,
            "pad_north_m": s.pad_north,
            "pad_east_m": s.pad_east,
            "camera_hfov_deg": s.camera_hfov_deg,
            "camera_aspect": 4 / 3,
            "simulated_vehicle": s.mavlink is None,
        }


def _angles(angles: tuple[float, float, float]) -> str:
    return ", ".join(f"{a:g}" for a in angles)
