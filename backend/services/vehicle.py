"""The vehicle as the routes see it: commands by name, telemetry, the mission settings.

Commands block the calling thread until the vehicle's COMMAND_ACK or a timeout
(the routes run them on worker threads).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from backend.link import CommandResult, LinkState, Telemetry, VehicleLink
from backend.missions import LandConfig, Mount
from backend.settings import Settings

#: The commands the API offers, by route name.
COMMANDS = ("arm", "disarm", "force-disarm", "land", "rtl", "takeoff", "mode")


class VehicleService:
    """One vehicle over ``link`` (``url``: what it is connected to)."""

    def __init__(
        self,
        link: VehicleLink,
        settings: Settings,
        *,
        url: str,
        approach_alt: Callable[[], float | None] = lambda: None,
        mount: Callable[[], Mount] = Mount,
    ) -> None:
        self.link = link
        self.url = url
        self._settings = settings
        self._approach_alt = approach_alt
        self._mount = mount  # (the camera on the vehicle as now set, for the missions)

    @property
    def telemetry(self) -> Telemetry:
        return self.link.telemetry

    @property
    def link_up(self) -> bool:
        return self.link.state == LinkState.UP

    def approach_altitude_m(self) -> float | None:
        """Where missions look for the pad from by default: a margin under the height
        up to which the active pad is reliably found with this camera."""
        return self._approach_alt()

    def command(self, name: str, *args: Any) -> CommandResult:
        """Run one command of :data:`COMMANDS` (blocks until ACK or timeout)."""
        link = self.link
        method: dict[str, Callable[..., CommandResult]] = {
            "arm": link.arm,
            "disarm": link.disarm,
            "force-disarm": link.force_disarm,
            "land": link.land,
            "rtl": link.rtl,
            "takeoff": link.takeoff,
            "mode": link.set_mode,
        }
        return method[name](*args)

    def land_config(self, **changes: Any) -> LandConfig:
        """Mission settings for this station's pad (its place and heading from settings).

        Without an ``approach_alt_m`` the pad is looked for from where it is still
        reliably found with this pad and camera (`approach_altitude_m`).
        """
        s = self._settings
        if changes.get("approach_alt_m") is None:
            changes.pop("approach_alt_m", None)
            alt = self.approach_altitude_m()
            if alt is not None:
                changes["approach_alt_m"] = alt
        return LandConfig(
            pad_north_m=s.pad_north,
            pad_east_m=s.pad_east,
            pad_heading_deg=s.pad_heading_deg,
            mount=self._mount(),
            **changes,
        )
