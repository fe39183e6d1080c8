"""The hover mission against the real stand-in: take off, fly over the pad, hold, centre."""

from __future__ import annotations

import math

import pytest

from backend.missions import HoverConfig, HoverMission, LandConfig
from bench.scenarios.land import PAD_NE, LockstepDriver, RunSpec, camera_config, fly

pytestmark = pytest.mark.slow


def test_takes_off_flies_over_the_pad_and_centres_on_it():
    spec = RunSpec(0, 5, "guided", 20.0, 0.0, 0.0, 3.5, 0.0, 1.0, 200.0, 0.2, 25.0)
    driver = LockstepDriver(spec)
    try:
        driver.connect()
        while not driver.link.telemetry.prearm_ok:  # the stand-in's EKF settles first
            assert driver.now() < 30.0
            driver.advance(0.1)
        config = HoverConfig(
            altitude_m=3.5,
            hold_s=6.0,
            land=LandConfig(
                strategy="guided", pad_north_m=PAD_NE[0], pad_east_m=PAD_NE[1], pad_heading_deg=20
            ),
        )
        changes = []
        mission = HoverMission(
            driver.link, config, now=driver.now(), on_change=lambda m: changes.append(m.state)
        )
        fly(driver, mission, camera_config(spec))
        assert mission.outcome == "completed", mission.record.message
        assert changes == ["preflight", "takeoff", "transit", "hold", "completed"]
        rec = mission.record
        # frames count from the start: ~2 s on the ground (GUIDED, arming, each confirmed
        # by a heartbeat) and the climb see no pad
        assert rec.frames > 50 and rec.detections > 0.4 * rec.frames
        truth = driver.server.truth()
        assert truth.armed and truth.mode == 4  # left hovering in GUIDED
        n, e, d = truth.position_ned
        assert math.hypot(n - PAD_NE[0], e - PAD_NE[1]) < 0.2  # centred by vision
        assert -d == pytest.approx(3.5, abs=0.3)
        snap = mission.snapshot()
        assert snap["kind"] == "hover" and snap["state"] == "completed"
        assert snap["fix"] is not None and snap["image_size"] == [640, 480]
    finally:
        driver.close()


def test_refuses_a_config_of_the_wrong_kind():
    with pytest.raises(ValueError, match="HoverConfig"):
        HoverMission(object(), LandConfig(), now=0.0)
