"""Mission settings reject bad values with a ValueError that names the field."""

from __future__ import annotations

import math

import numpy as np
import pytest

from backend.missions import HoverConfig, LandConfig, Mount, RunRecord


def test_defaults_are_valid():
    c = LandConfig()
    assert c.strategy == "plnd" and c.abort_mode == "LOITER"
    assert c.pad_ned == (0.0, 0.0, 0.0)
    assert HoverConfig().land.strategy == "plnd"


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("strategy", "autoland"),
        ("abort_mode", "LAND"),
        ("approach_alt_m", 0.0),
        ("approach_alt_m", -1.0),
        ("final_alt_m", math.nan),
        ("lost_timeout_s", math.inf),
        ("descent_speed_mps", "fast"),
        ("gain_xy", True),
        ("pad_north_m", math.nan),
        ("pad_heading_deg", math.inf),
    ],
)
def test_land_config_names_the_bad_field(field, value):
    with pytest.raises(ValueError, match=field):
        LandConfig(**{field: value})


@pytest.mark.parametrize(
    ("field", "value"), [("altitude_m", 0.0), ("altitude_m", 150.0), ("hold_s", -1.0)]
)
def test_hover_config_names_the_bad_field(field, value):
    with pytest.raises(ValueError, match=field):
        HoverConfig(**{field: value})


def test_mount_must_be_a_rotation():
    with pytest.raises(ValueError, match="rotation"):
        Mount(rotation=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="offset_m"):
        Mount(offset_m=(0.0, math.nan, 0.0))


def test_record_rejects_unknown_outcomes_and_caps_targets():
    rec = RunRecord(kind="land", strategy="plnd", config={}, started=10.0)
    for i in range(6000):
        rec.target(10.0 + i, "velocity", 0.0, 0.0, 0.0, 0.0)
    assert rec.targets_sent == 6000 and len(rec.targets) == 5000
    with pytest.raises(ValueError, match="outcome"):
        rec.finish(20.0, "crashed", "")
    rec.finish(20.0, "landed", "ok")
    assert rec.to_dict()["duration_s"] == 10.0


def test_missions_check_their_clock_and_config():
    from backend.missions import LandMission

    with pytest.raises(ValueError, match="now"):
        LandMission(object(), LandConfig(), now=math.nan)
    with pytest.raises(ValueError, match="config"):
        LandMission(object(), HoverConfig(), now=0.0)
    mission = LandMission(object(), LandConfig(), now=5.0)
    with pytest.raises(ValueError, match="now"):
        mission.step(4.0)
    with pytest.raises(ValueError, match="now"):
        mission.step(math.inf)
    assert mission.state == "start" and not mission.done
