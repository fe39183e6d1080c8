"""Hover over the pad (the seed's appendix B script, done properly).

States: ``start`` -> ``preflight`` (unless already flying: wait for the vehicle's
position estimate, then GUIDED, arm and take off to ``altitude_m``, each confirmed by a
HEARTBEAT that came after the vehicle accepted it) -> ``takeoff`` -> ``transit`` (fly to
where the pad should be) -> ``hold`` (``hold_s`` while frames are acquired and recorded;
once the pad is seen, centre and turn over it by vision) -> ``completed`` (left hovering
in GUIDED). Link loss and operator abort as in every mission.
"""

from __future__ import annotations

import math
from typing import Any

from backend.link import Telemetry
from backend.missions.config import HoverConfig
from backend.missions.mission import CONFIRM_S, Mission

RESEND_S = 1.0
#: How long to wait for the vehicle's position estimate (mission clock, s). ArduCopter
#: has none for ~41 s after a boot (a reboot too); GUIDED arms only with one.
READY_TIMEOUT_S = 120.0
#: GUIDED accepted but the heartbeat says otherwise this many times: give up (ArduCopter
#: undoes a mode set while it boots).
MODE_TRIES = 3


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
        self._sent_at = -math.inf  # when the latest GUIDED / arm was accepted
        self._mode_tries = 0
        self._armed_asked = False

    def _target_down(self) -> float:
        return -self.hover.altitude_m

    def _s_start(self, now: float, tel: Telemetry) -> None:
        height = self._height(tel)
        if tel.armed and height is not None and height > 0.3:
            if tel.mode != "GUIDED" and not self._mode("GUIDED"):
                return
            self._set_state("transit", "already flying: to the pad")
            return
        self._set_state("preflight", "waiting for the vehicle's position estimate")
        self._s_preflight(now, tel)

    def _s_preflight(self, now: float, tel: Telemetry) -> None:
        """Readiness, then GUIDED, arm, take off: each step only on a HEARTBEAT that came
        after the previous command was accepted (the 1 Hz heartbeat lags behind)."""
        if not tel.position_ready:
            if now - self.state_since > READY_TIMEOUT_S:
                self._fail(
                    f"the vehicle has no position estimate after {READY_TIMEOUT_S:g} s "
                    f"({_not_ready(tel)}); it cannot arm in GUIDED without one"
                )
            return
        if not tel.state_confirmed:
            if now - self._sent_at > CONFIRM_S:
                self._fail(
                    f"no HEARTBEAT from the vehicle for {CONFIRM_S:g} s after it accepted a "
                    "command: its armed state and mode are not known"
                )
            return
        if tel.mode != "GUIDED":
            if self._mode_tries >= MODE_TRIES:
                self._fail(
                    f"the vehicle accepted GUIDED {self._mode_tries} times but its heartbeat "
                    f"says {tel.mode} (ArduCopter undoes a mode set while it is booting)"
                )
                return
            self._mode_tries += 1
            if self._mode("GUIDED"):
                self._sent_at = now
            return
        if not tel.armed:
            if self._armed_asked:
                self._fail("the vehicle accepted arming but its heartbeat says it is disarmed")
                return
            result = self.link.arm()
            if not result.ok:
                reasons = "; ".join(result.reasons) if result.reasons else result.detail
                self._fail(f"the vehicle refused to arm: {reasons}")
                return
            self._armed_asked = True
            self._sent_at = now
            return
        # armed in GUIDED, as the latest heartbeat says
        result = self.link.takeoff(self.hover.altitude_m)
        if not result.ok:
            if result.reasons:
                why = "; ".join(result.reasons)
            else:
                after = self.link.telemetry
                why = (
                    f"{result.detail}, without saying why; its latest heartbeat said "
                    f"{after.mode}, {'armed' if after.armed else 'disarmed'} (ArduCopter "
                    "takes off only when armed in GUIDED)"
                )
            self._fail(f"the vehicle refused to take off: {why}")
            return
        self._set_state("takeoff", f"taking off to {self.hover.altitude_m:g} m")

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


def _not_ready(tel: Telemetry) -> str:
    """Why the vehicle has no usable position, in words."""
    if tel.position_stale:
        return "LOCAL_POSITION_NED stopped"
    if tel.position_ned is None:
        return "no LOCAL_POSITION_NED from it yet"
    if tel.ekf is None:
        return "no EKF_STATUS_REPORT from it"
    return f"its EKF has no absolute horizontal position (flags {tel.ekf.flags:#x})"
