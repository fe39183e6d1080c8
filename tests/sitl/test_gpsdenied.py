"""The GPS-denied landing on genuine ArduCopter 4.5.6 SITL, as the station flies it.

The station's external-navigation set-up (parameters, reboot), take-off on GPS, the
``extnav`` mission with the camera rendered from SIM_STATE through the real pipeline on
the vehicle's clock; GPS goes over the pad (SIM_GPS_DISABLE = 1). Touchdown against the
simulator's truth (``bench.sitl_gpsdenied`` flies the same run, N times, for the bars).
"""

from __future__ import annotations

import pytest

from bench.sitl_gpsdenied import fly_once
from tests.sitl.support import requires_sitl

pytestmark = [pytest.mark.sitl, requires_sitl]


def test_gps_lost_over_the_pad_lands_on_vision():
    run = fly_once(seed=1)
    assert "error" not in run, run
    assert run["outcome"] == "landed", run
    assert "on vision navigation (ExternalNav)" in run["message"]
    # "final" (the pad too close to see: dead-reckoned) is skipped when the vehicle
    # disarms before the pad has gone unseen for long (a frame still found it close, or a
    # loaded machine delivered the last frames late): a landing on vision either way.
    landing = [s for s in run["states"] if s != "final"]
    assert landing[-4:] == ["switch", "settle", "descend", "landed"], run["states"]
    assert run["touchdown_error_m"] < 0.20
    assert run["gps_off_at_boot_s"] is not None and run["gps_fix_type_at_end"] <= 1
    assert run["vision_positions_sent"] > 50
    # ArduPilot never lost its position: no EKF variance, no EKF failsafe
    assert not [t for t in run["texts"] if t.startswith(("EKF variance", "EKF Failsafe"))]


def test_a_camera_pitched_ahead_told_its_mount_lands_on_vision():
    # The camera looks 12 degrees ahead of straight down, and the station is told: the
    # pipeline's hints and the mission's geometry both go through the mount. (Taken for
    # a downward camera, its poses would be held 12 degrees off their level.)
    run = fly_once(seed=3, mount_deg=(0.0, 12.0, 0.0))
    assert "error" not in run, run
    assert run["outcome"] == "landed", run
    assert "on vision navigation (ExternalNav)" in run["message"]
    assert run["touchdown_error_m"] < 0.20
    assert run["vision_positions_sent"] > 50
    # (The mount check mostly stays silent here; under a loaded machine it once spoke of
    # a 3.1 degree lean, suggesting a pitch of 9: see the README's camera mount.)


def test_a_camera_pitched_ahead_taken_for_a_downward_one_is_told_in_flight():
    # The camera looks 6 degrees ahead; the station is told it looks straight down. The
    # attitude holds its poses near the wrong level (a few percent of the height off),
    # and the mount check tells the operator which mount the pixels put the camera on.
    run = fly_once(seed=3, true_mount_deg=(0.0, 6.0, 0.0))
    assert "error" not in run, run
    assert run["outcome"] == "landed", run
    assert run["touchdown_error_m"] < 0.20
    warned = [m for m in run["mount_check"] if "suggested_mount_deg" in m]
    assert warned, run["mount_check"]
    roll, pitch, yaw = warned[0]["suggested_mount_deg"]
    # (within the 3 degrees by which a loaded machine's live loop has leant a right mount)
    assert abs(roll) < 3.0 and abs(pitch - 6.0) < 3.0 and yaw == 0.0, warned


def test_pad_lost_without_gps_lands_in_place_and_says_so():
    run = fly_once(seed=2, pad_lost=True)
    assert "error" not in run, run
    assert run["outcome"] == "landed_in_place", run
    assert "not a landing on the pad" in run["message"]
    assert run["states"][-2:] == ["landing_in_place", "landed_in_place"], run["states"]
    # no fly-away: it came down near where the pad was lost (dead-reckoning drift only)
    assert run["drift_after_pad_lost_m"] < 3.0
    assert run["touchdown_error_m"] < 3.5
