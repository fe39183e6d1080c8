"""Hover over the pad (the seed's appendix B script, done properly).

States: ``start`` -> ``takeoff`` (GUIDED, arm, take off to ``altitude_m`` unless already
flying) -> ``transit`` (fly to where the pad should be) -> ``hold`` (``hold_s`` while
frames are acquired and recorded; once the pad is seen, centre and turn over it by
vision) -> ``completed`` (left hovering in GUIDED). Link loss and operator abort as in
every mission.
"""

from __future__ import annotations

import math
from typing import Any

from backend.link import Telemetry
from backend.missions.config import HoverConfig
from backend.missions.mission import Mission

RESEND_S = 1.0


class HoverMission(Mission):
    """Take off, fly over the pad, hold there; see the module docstring."""

    kind = "hover"

    def __init__(self, link: Any, config: HoverConfig, **kwargs: Any) -> None:
        if not isinstance(config, HoverConfig):
            raise ValueError("config must be a HoverConfig")
        self.hover = config
        super().__init__(link, config.land, **kwargs)
        self.record.strategy = None
        self.record.config = {
            "altitude_m": config.altitude_m,
            "hold_s": config.hold_s,
            "arrive_tolerance_m": config.arrive_tolerance_m,
            "land": self.record.config,
        }
        self._last_goto = -math.inf
        self._hold_started: float | None = None

    def _target_down(self) -> float:
        return -self.hover.altitude_m

    def _s_start(self, now: float, tel: Telemetry) -> None:
        height = self._height(tel)
        flying = tel.armed and height is not None and height > 0.3
        if tel.mode != "GUIDED" and not self._mode("GUIDED"):
            return
        if not flying:
            if not tel.armed:
                result = self.link.arm()
                if not result.ok:
                    reasons = "; ".join(result.reasons) if result.reasons else result.detail
                    self._fail(f"the vehicle refused to arm: {reasons}")
                    return
            result = self.link.takeoff(self.hover.altitude_m)
            if not result.ok:
                reasons = "; ".join(result.reasons) if result.reasons else result.detail
                self._fail(f"the vehicle refused to take off: {reasons}")
                return
            self._set_state("takeoff", f"taking off to {self.hover.altitude_m:g} m")
        else:
            self._set_state("transit", "already flying: to the pad")

    def _s_takeoff(self, now: float, tel: Telemetry) -> None:
        if self._disarmed(tel):
            self._fail("the vehicle disarmed during take-off")
            return
        p = tel.position_ned
        if p is not None and -p.z >= 0.9 * self.hover.altitude_m:
            self._set_state("transit", "at altitude: to the pad")
        elif now - self.state_since > self.hover.takeoff_timeout_s:
            self._do_abort(f"take-off not done in {self.hover.takeoff_timeout_s:g} s")

    def _s_transit(self, now: float, tel: Telemetry) -> None:
        c = self.config
        if self._disarmed(tel):
            self._fail("the vehicle disarmed in flight")
            return
        if self._take_new_fix() is not None:
            self._set_state("hold", "pad in view: centring over it")
            return
        if now - self._last_goto >= RESEND_S:
            self._last_goto = now
            self._goto(c.pad_north_m, c.pad_east_m, self._target_down())
        p = tel.position_ned
        if (
            p is not None
            and math.hypot(p.x - c.pad_north_m, p.y - c.pad_east_m) < self.hover.arrive_tolerance_m
        ):
            self._set_state("hold", "over the pad's expected location")

    def _s_hold(self, now: float, tel: Telemetry) -> None:
        c = self.config
        if self._disarmed(tel):
            self._fail("the vehicle disarmed in flight")
            return
        if self._hold_started is None:
            self._hold_started = now
        fix = self._take_new_fix()
        if fix is not None:
            # Keep the altitude: a gentle correction toward the hover height.
            vd = 0.0
            if tel.position_ned is not None:
                vd = max(-0.5, min(0.5, 0.5 * (tel.position_ned.z - self._target_down())))
                vd = -vd
            self._send_velocity(*self._steer(fix, vd))
            self._last_goto = now
        elif self._unseen_s() >= c.fix_max_age_s and now - self._last_goto >= RESEND_S:
            self._last_goto = now
            self._goto(c.pad_north_m, c.pad_east_m, self._target_down())
        if now - self._hold_started >= self.hover.hold_s:
            seen = self.record.detections
            self._end(
                "completed",
                f"held {self.hover.hold_s:g} s over the pad; {self.record.frames} frames, "
                f"pad seen in {seen}",
            )
