"""The extnav mission's own logic, step by step against a recording link (the flights
against the stand-in are in test_land_extnav.py, against SITL in tests/sitl)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import pytest

from backend.link import CommandResult, LinkState, Telemetry
from backend.link.telemetry import Attitude, GpsStatus, Vec3
from backend.missions import LandConfig, LandMission, VisionSample
from backend.missions.extnav import (
    ARMING_CHECK_ALL_BUT_VISION,
    ExtNavLandMission,
    VisionVelocity,
    extnav_missing,
    land_mission,
)
from backend.missions.mission import AMBIGUOUS_NOTE
from pipeline import Camera, FrameResult, Pose

PAD = (2.0, 1.0, 0.0)


@dataclass
class RecordingLink:
    telemetry: Telemetry
    params: dict[str, float] = field(default_factory=lambda: {"VISO_TYPE": 1, "EK3_SRC2_POSXY": 6})
    source_set_result: CommandResult = field(
        default_factory=lambda: CommandResult(True, "set_ekf_source_set 2", 0, "ACCEPTED")
    )
    sent: list[tuple[str, tuple]] = field(default_factory=list)

    def get_param(self, name: str, **_: object) -> float | None:
        return self.params.get(name)

    def set_mode(self, name: str) -> CommandResult:
        self.sent.append(("set_mode", (name,)))
        return CommandResult(True, f"set_mode {name}", 0, "ACCEPTED", (), "accepted")

    def set_ekf_source_set(self, number: int) -> CommandResult:
        self.sent.append(("source_set", (number,)))
        return self.source_set_result

    def _unacked(self, kind: str, *args: object) -> CommandResult:
        self.sent.append((kind, args))
        return CommandResult(True, kind, None, "SENT", (), "sent")

    def set_velocity_ned(self, *args: object, **kwargs: object) -> CommandResult:
        return self._unacked("velocity", *args)

    def goto_local_ned(self, *args: object, **kwargs: object) -> CommandResult:
        return self._unacked("goto", *args)

    def send_vision_position(self, *args: object, time_usec: int, **_: object) -> CommandResult:
        return self._unacked("vision_position", *args, time_usec)

    def send_vision_speed(self, *args: object, time_usec: int, **_: object) -> CommandResult:
        return self._unacked("vision_speed", *args, time_usec)

    def latest(self, _name: str) -> None:
        return None


def telemetry(north: float, east: float, alt: float = 4.0) -> Telemetry:
    return Telemetry(
        state=LinkState.UP,
        armed=True,
        mode="GUIDED",
        attitude=Attitude(0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        position_ned=Vec3(north, east, -alt),
        velocity_ned=Vec3(0.0, 0.0, 0.0),
        gps=GpsStatus(6, 12, 0.8),
        state_confirmed=True,  # a HEARTBEAT since the last accepted command
    )


CAMERA = Camera.from_fov(640, 480, 60)


def sample(vehicle: tuple[float, float, float], t: float) -> VisionSample:
    """What the camera sees from ``vehicle`` (NED) over the pad, level, heading north."""
    rel = np.array(vehicle) - np.array(PAD)
    # pad frame: x east (picture right, heading 0), y north, z up; looking straight down
    position = np.array([rel[1], rel[0], -rel[2]])
    R = np.diag([1.0, -1.0, -1.0])
    result = FrameResult(
        detected=True,
        corners_px=np.zeros((0, 2)),
        hu=(),
        orientation_deg=0.0,
        eccentricity=0.0,
        pose=Pose(position, R, 0.5, True),
        timings_ms={},
    )
    return VisionSample(result, CAMERA, t, round(t * 1e6) + 1)


def fly_to_switch(mission: ExtNavLandMission, link: RecordingLink) -> float:
    t = 0.0
    for _ in range(40):
        t += 0.05
        mission.step(t, sample((PAD[0], PAD[1], -4.0), t))
        if mission.state != "align" and mission.state not in ("check", "approach"):
            break
    return t


def test_the_setup_checks_and_the_factory():
    assert extnav_missing({"VISO_TYPE": 1, "EK3_SRC2_POSXY": 6}) == []
    assert extnav_missing({"VISO_TYPE": 0, "EK3_SRC2_POSXY": 3}) == [
        "VISO_TYPE = 1 (now 0)",
        "EK3_SRC2_POSXY = 6 (now 3)",
    ]
    assert ARMING_CHECK_ALL_BUT_VISION == 1835006 and not ARMING_CHECK_ALL_BUT_VISION & (1 << 18)
    link = RecordingLink(telemetry(*PAD[:2]))
    assert type(land_mission(link, LandConfig(strategy="extnav"), now=0.0)) is ExtNavLandMission
    assert type(land_mission(link, LandConfig(strategy="guided"), now=0.0)) is LandMission


def test_not_set_up_fails_and_says_what_to_set():
    link = RecordingLink(telemetry(*PAD[:2]), params={"VISO_TYPE": 0, "EK3_SRC2_POSXY": 6})
    mission = ExtNavLandMission(link, LandConfig(strategy="extnav"), now=0.0)
    mission.step(0.1)
    assert mission.outcome == "failed"
    assert "external navigation is not set up" in mission.record.message
    assert "VISO_TYPE = 1 (now 0)" in mission.record.message
    assert link.sent == []


def test_vision_goes_out_in_the_ekf_frame_then_the_switch_then_land():
    link = RecordingLink(telemetry(*PAD[:2]))
    config = LandConfig(strategy="extnav", pad_north_m=PAD[0], pad_east_m=PAD[1])
    mission = ExtNavLandMission(link, config, now=0.0)
    t = fly_to_switch(mission, link)
    assert mission.state == "switch" and mission.pad_ekf is not None
    assert mission.pad_ekf == pytest.approx(PAD, abs=1e-6)
    # the vehicle 0.3 m north of the pad: vision puts it there, in the EKF frame
    for _ in range(12):
        t += 0.05
        mission.step(t, sample((PAD[0] + 0.3, PAD[1], -4.0), t))
    vision = [s for s in link.sent if s[0] == "vision_position"]
    assert vision, link.sent
    n, e, d, roll, pitch, yaw, usec = vision[-1][1]
    assert (n, e, d) == pytest.approx((PAD[0] + 0.3, PAD[1], -4.0), abs=1e-6)
    assert (roll, pitch, yaw) == (0.0, 0.0, 0.0)  # the attitude the vehicle reports
    assert usec == round(t * 1e6) + 1  # the frame's capture time on the vehicle's clock
    kinds = [s[0] for s in link.sent]
    assert ("source_set", (2,)) in link.sent
    assert kinds.index("vision_position") < kinds.index("source_set")
    assert mission.state == "settle" and mission.on_vision
    # holds over the pad on vision, then LAND
    while mission.state == "settle":
        t += 0.05
        mission.step(t, sample((PAD[0], PAD[1], -4.0), t))
    assert mission.state == "descend" and ("set_mode", ("LAND",)) in link.sent
    assert any(s[0] == "goto" and s[1][:2] == pytest.approx(PAD[:2]) for s in link.sent)
    assert any(s[0] == "vision_speed" for s in link.sent)


def test_a_refused_switch_is_reported_verbatim_and_holds():
    refusal = CommandResult(
        False, "set_ekf_source_set 2", 4, "FAILED", ("EKF3: source set 2 unavailable",), ""
    )
    link = RecordingLink(telemetry(*PAD[:2]), source_set_result=refusal)
    config = LandConfig(strategy="extnav", pad_north_m=PAD[0], pad_east_m=PAD[1])
    mission = ExtNavLandMission(link, config, now=0.0)
    t = fly_to_switch(mission, link)
    for _ in range(20):
        t += 0.05
        mission.step(t, sample((PAD[0], PAD[1], -4.0), t))
        if mission.done:
            break
    assert mission.outcome == "aborted"
    assert (
        "refused EKF source set 2: FAILED (EKF3: source set 2 unavailable)"
        in mission.record.message
    )
    assert not mission.on_vision


def test_pad_lost_on_vision_lands_in_place_at_once():
    link = RecordingLink(telemetry(*PAD[:2]))
    config = LandConfig(strategy="extnav", pad_north_m=PAD[0], pad_east_m=PAD[1])
    mission = ExtNavLandMission(link, config, now=0.0)
    t = fly_to_switch(mission, link)
    while mission.state in ("switch", "settle"):
        t += 0.05
        mission.step(t, sample((PAD[0], PAD[1], -4.0), t))
    assert mission.state == "descend"
    link.telemetry = replace(link.telemetry, mode="LAND", gps=GpsStatus(1, 0, None))
    lands = sum(1 for s in link.sent if s == ("set_mode", ("LAND",)))
    for _ in range(30):  # 1.5 s without the pad, still 4 m up
        t += 0.05
        mission.step(t)
    assert mission.state == "landing_in_place"
    reason = mission.record.states[-1]["reason"]
    assert "no GPS fix" in reason and "landing in place (LAND, level)" in reason
    assert sum(1 for s in link.sent if s == ("set_mode", ("LAND",))) == lands  # already LAND
    link.telemetry = replace(link.telemetry, armed=False, position_ned=Vec3(2.9, 1.2, 0.0))
    mission.step(t + 0.05)
    assert mission.outcome == "landed_in_place"
    assert "0.92 m from the pad centre" in mission.record.message
    assert "not a landing on the pad" in mission.record.message


def test_velocity_from_recent_positions():
    v = VisionVelocity()
    assert v.velocity() is None
    for i in range(8):
        v.add(1_000_000 + i * 50_000, (0.5 * i * 0.05, -0.2 * i * 0.05, 1.0))
    assert v.velocity() == pytest.approx((0.5, -0.2, 0.0), abs=1e-9)
    v.add(10, (0.0, 0.0, 0.0))  # the vehicle's clock went back (a reboot): start over
    assert v.velocity() is None


def test_an_ambiguous_pose_is_no_fix():
    # A pose made without the attitude that the pixels do not pin (another, tilted the
    # other way, fits as well; or a look-alike taken for a tilted pad) guides nothing.
    link = RecordingLink(telemetry(*PAD[:2]))
    mission = LandMission(link, LandConfig(strategy="guided"), now=0.0)
    seen = sample((PAD[0], PAD[1], -4.0), 0.05)
    assert seen.result.pose is not None
    unsure = replace(
        seen, result=replace(seen.result, pose=replace(seen.result.pose, ambiguous=True))
    )
    mission.step(0.05, unsure)
    mission.step(0.1, unsure)
    assert mission.fix is None and mission.record.detections == 0
    assert mission.record.frames == 2
    assert mission.record.notes.count(AMBIGUOUS_NOTE) == 1
    mission.step(0.15, replace(seen, t_capture=0.15))
    assert mission.fix is not None and mission.record.detections == 1
