"""A precision landing is refused when PLND was written since the autopilot booted
(ArduCopter reads PLND_TYPE at boot: without the reboot it ignores every target)."""

from __future__ import annotations

import pytest

from backend.missions import LandConfig, LandMission
from bench.scenarios.land import LockstepDriver, RunSpec, fly_to_start

pytestmark = pytest.mark.slow

SPEC = RunSpec(0, 11, "guided", 35.0, 7.0, -0.5, 3.5, 80.0, 0.0, 0.0, 0.0, 25.0)


def test_plnd_written_without_a_reboot_is_refused_and_says_reboot() -> None:
    driver = LockstepDriver(SPEC)
    try:
        driver.connect()
        fly_to_start(driver, SPEC, precland=False)
        link = driver.link
        for name in ("PLND_ENABLED", "PLND_TYPE"):
            assert link.set_param(name, 1).ok
        assert link.written_since_boot(("PLND_ENABLED", "PLND_TYPE", "PLND_LAG")) == [
            "PLND_ENABLED",
            "PLND_TYPE",
        ]
        mission = LandMission(link, LandConfig(strategy="plnd"), now=driver.now())
        while not mission.done:
            driver.advance(0.05)
            mission.step(driver.now())
        assert mission.outcome == "failed"
        assert mission.record.message == (
            "PLND_ENABLED and PLND_TYPE changed since the autopilot booted: ArduCopter reads "
            "them at boot, reboot it before a precision landing"
        )
    finally:
        driver.close()
