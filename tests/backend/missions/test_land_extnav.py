"""The GPS-denied landing ("extnav") flown against the real stand-in over a real link
(lockstep TCP), the camera rendered from the stand-in's true pose and the real pipeline.

GPS goes (SIM_GPS_DISABLE = 1) once the vehicle holds over the pad on vision; it lands on
vision alone. The pad lost without GPS: LAND in place, said so, and never a fly-away.
"""

from __future__ import annotations

import math

import pytest

from bench.scenarios.land import PAD_NE, run_one
from tests.backend.missions.test_land import height, spec

pytestmark = pytest.mark.slow


def gps_off_once(state: str):
    """``after_step`` that switches the stand-in's GPS off when the mission reaches ``state``."""
    done: dict[str, float] = {}

    def after(driver, mission):
        if "at" not in done and mission.state == state:
            assert driver.link.set_param("SIM_GPS_DISABLE", 1).ok
            done["at"] = driver.now()
        if "at" in done:
            gps = driver.link.telemetry.gps
            if gps is not None and gps.fix_type <= 1:
                done.setdefault("no_fix_at", driver.now())

    return after, done


def test_gps_lost_over_the_pad_lands_on_vision():
    after, gps = gps_off_once("settle")
    result = run_one(spec("extnav"), after_step=after)
    assert result.outcome == "landed", result.message
    assert result.success
    assert "on vision navigation (ExternalNav)" in result.message
    assert result.touchdown_error_m < 0.10
    assert "no_fix_at" in gps, "GPS never lost its fix"
    states = [s["state"] for s in result.states]
    assert states[:3] == ["check", "approach", "align"], states
    assert [s for s in states if s in ("switch", "settle", "descend")] == [
        "switch",
        "settle",
        "descend",
    ]
    assert states[-1] == "landed"
    record = result.record
    assert record is not None
    sent = [t for t in record.targets if t[1] == "vision_position"]
    assert len(sent) > 30
    # every VISION_POSITION_ESTIMATE carried the frame's time on the vehicle's clock
    assert all(t[5] > 0 for t in sent)
    assert any("source set 2" in n for n in record.notes)
    # landed on vision after GPS went: frames with the pad seen after the GPS loss
    after_gps = [t for t in sent if t[0] + record.started >= gps["no_fix_at"]]
    assert len(after_gps) > 10


def test_pad_lost_without_gps_lands_in_place_and_says_so():
    seen: dict[str, float] = {}
    after_gps, _ = gps_off_once("settle")

    def hide(driver, mission):
        if "from" not in seen and mission.state == "descend" and height(driver) < 2.5:
            truth = driver.server.truth().position_ned
            seen["from"] = driver.now()
            seen["n"], seen["e"] = truth[0], truth[1]
        return "from" in seen

    def after(driver, mission):
        after_gps(driver, mission)
        if mission.done:
            truth = driver.server.truth()
            seen["end"] = (truth.armed, truth.position_ned[0], truth.position_ned[1])

    result = run_one(spec("extnav"), hide_pad=hide, after_step=after)
    assert result.outcome == "landed_in_place", result.message
    assert not result.success
    assert "not a landing on the pad" in result.message
    states = [s["state"] for s in result.states]
    assert states[-2:] == ["landing_in_place", "landed_in_place"], states
    reason = result.states[-2]["reason"]
    assert "landing in place (LAND, level)" in reason and "no GPS fix" in reason
    armed, n, e = seen["end"]
    assert not armed
    # no fly-away: down within a metre of where the pad was lost
    assert math.hypot(n - seen["n"], e - seen["e"]) < 1.0
    assert math.hypot(n - PAD_NE[0], e - PAD_NE[1]) < 1.5
