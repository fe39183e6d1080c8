"""GCS-guided landing asks for LAND once: the mode in telemetry comes with the 1 Hz
HEARTBEAT, so it still reads GUIDED for up to a second after the vehicle took LAND.

A recording link stands in for the vehicle here (the flights against the stand-in are
in test_land.py); what is checked is what the mission sends, step by step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from backend.link import CommandResult, LinkState, Telemetry
from backend.link.telemetry import Attitude, Vec3
from backend.missions import LandConfig, LandMission


@dataclass
class RecordingLink:
    telemetry: Telemetry
    sent: list[tuple[str, tuple]] = field(default_factory=list)

    def set_mode(self, name: str) -> CommandResult:
        self.sent.append(("set_mode", (name,)))
        return CommandResult(True, f"set_mode {name}", 0, "ACCEPTED", (), "accepted")

    def set_velocity_ned(self, *args, **kwargs) -> CommandResult:
        self.sent.append(("velocity", args))
        return CommandResult(True, "set_velocity_ned", None, "SENT", (), "sent")

    def latest(self, _name: str) -> None:
        return None


def test_guided_final_sends_land_once_while_telemetry_still_says_guided():
    tel = Telemetry(
        state=LinkState.UP,
        armed=True,
        mode="GUIDED",
        attitude=Attitude(0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        position_ned=Vec3(0.0, 0.0, -0.05),  # below the touchdown height
        velocity_ned=Vec3(0.0, 0.0, 0.0),
    )
    link = RecordingLink(tel)
    mission = LandMission(link, LandConfig(strategy="guided"), now=0.0)
    mission.state = "final"
    mission.state_since = 0.0
    mission.pad_est = (0.0, 0.0, 0.0)
    for i in range(1, 30):  # 30 frames: a second at the camera's rate
        mission.step(i / 30)
    lands = [s for s in link.sent if s == ("set_mode", ("LAND",))]
    assert len(lands) == 1, link.sent
