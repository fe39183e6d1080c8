"""Land on the pad by vision: ArduCopter precision landing ("plnd") or GCS guidance ("guided").

States: ``check`` -> ``approach`` (fly to where the pad should be, at ``approach_alt_m``,
until it is seen) -> ``align`` (GUIDED: centre and turn to the pad's heading by vision)
-> ``descend`` -> ``final`` (the blind last metres) -> ``landed``.

- ``plnd``: ``descend`` is LAND mode with a LANDING_TARGET per detection
  (MAV_FRAME_BODY_FRD, position_valid = 1, x/y/z and distance from the camera,
  time_usec = the frame's capture time on the vehicle's clock); ArduCopter steers.
- ``guided``: ``descend`` is GUIDED velocity targets (centre, then sink while centred);
  below ``final_alt_m`` the pad fills the view and LAND does the blind last part.

Failsafes: pad unseen ``lost_hold_s`` above ``final_alt_m`` -> ``hold`` (GUIDED, no
descent); unseen ``lost_timeout_s`` -> ``search`` (climb ``search_climb_m``, look for
``search_s``) -> ``aborted`` in ``abort_mode``; link lost -> ``link_lost`` (the vehicle's
own failsafe decides); operator abort at any time.
"""

from __future__ import annotations

import math
from typing import Any

from backend.link import Telemetry
from backend.missions.geometry import PadFix
from backend.missions.mission import Mission

#: Consecutive centred fixes before descending (one lucky frame is not alignment).
CENTRED_FIXES = 3
#: Re-send a position target this often while it is the plan (s).
RESEND_S = 1.0
#: How long LAND may take from the blind height before the mission gives up (s).
FINAL_TIMEOUT_S = 60.0
#: Height above the pad below which a vehicle counts as down (m).
ON_GROUND_M = 0.3
#: The pad unseen this long near the ground means it fills the view (s).
BLIND_AFTER_S = 0.15
#: Guided final descent: sink rate, horizontal speed limit, LAND below this height, and
#: LAND anyway after this long (a height estimate that never reaches it).
FINAL_SINK_MPS = 0.3
FINAL_SPEED_MPS = 0.3
TOUCHDOWN_M = 0.1
FINAL_GUIDED_S = 10.0
#: ArduCopter's own precision-landing announcements (AC_PrecLand): the only proof that it
#: takes the targets; "Failsafe Measures" without them means it has no backend.
PRECLAND_ACCEPTED = ("PrecLand: Target Found", "PrecLand: Init Complete")
PRECLAND_FAILSAFE = "PrecLand: Failsafe Measures"
#: plnd: ArduCopter's precision landing steers the position only; in LAND it holds a fixed
#: yaw given by MAV_CMD_CONDITION_YAW, sent when the pad's heading is off by more than this
#: (deg), at most once per RESEND_S.
YAW_FIX_DEG = 0.5


class LandMission(Mission):
    """Land on the pad; see the module docstring."""

    kind = "land"

    def __init__(self, link: Any, config: Any, **kwargs: Any) -> None:
        super().__init__(link, config, **kwargs)
        self._centred_count = 0
        self._last_goto = -math.inf
        self._search_alt: float | None = None
        self._land_accepted = False
        self._texts_mark: int | None = None
        self._last_yaw = -math.inf
        if config.strategy == "plnd":
            self.record.precland = "silent"

    def _observe(self, tel: Telemetry) -> None:
        """Note ArduCopter's "PrecLand: ..." texts since the mission started."""
        if self.config.strategy != "plnd":
            return
        count = getattr(tel, "statustexts_received", 0)
        if self._texts_mark is None:
            self._texts_mark = count  # what came before this run says nothing about it
        new = min(count - self._texts_mark, len(tel.statustexts))
        self._texts_mark = count
        for entry in tel.statustexts[len(tel.statustexts) - new :] if new > 0 else ():
            if not entry.text.startswith("PrecLand"):
                continue
            self.record.precland_texts.append(entry.text)
            if entry.text in PRECLAND_ACCEPTED:
                self.record.precland = "accepted"
            elif entry.text == PRECLAND_FAILSAFE and self.record.precland != "accepted":
                self.record.precland = "failsafe"

    # --- states -----------------------------------------------------------------------------
    def _s_start(self, now: float, tel: Telemetry) -> None:
        self._set_state("check", "checking the vehicle")
        self._s_check(now, tel)

    def _s_check(self, now: float, tel: Telemetry) -> None:
        c = self.config
        height = self._height(tel)
        if not tel.armed or height is None or height < ON_GROUND_M:
            self._fail("the vehicle must be flying: take off (or run the hover mission) first")
            return
        if c.strategy == "plnd" and not self._precland_ready():
            return
        if tel.mode != "GUIDED" and not self._mode("GUIDED"):
            return
        self._set_state("approach", "looking for the pad")

    def _precland_ready(self) -> bool:
        values = {}
        for name in ("PLND_ENABLED", "PLND_TYPE"):
            values[name] = self.link.get_param(name)
            if values[name] is None:
                self._fail(f"could not read {name} from the vehicle")
                return False
        wrong = []
        if values["PLND_ENABLED"] != 1:
            wrong.append("PLND_ENABLED = 1")
        if values["PLND_TYPE"] != 1:
            wrong.append("PLND_TYPE = 1 (MAVLink), then reboot the autopilot (read at boot)")
        if wrong:
            self._fail("precision landing is off: set " + " and ".join(wrong))
            return False
        since = getattr(self.link, "written_since_boot", None)
        pending = since(("PLND_ENABLED", "PLND_TYPE")) if since is not None else []
        if pending:
            self._fail(
                f"{' and '.join(pending)} changed since the autopilot booted: ArduCopter reads "
                "them at boot, reboot it before a precision landing"
            )
            return False
        offset = self.config.mount.offset_m
        for axis, value in zip("XYZ", offset, strict=True):
            got = self.link.get_param(f"PLND_CAM_POS_{axis}")
            if got is not None and abs(got - value) > 0.01:
                self.record.notes.append(
                    f"PLND_CAM_POS_{axis} is {got:g} but the camera is mounted at {value:g} m"
                )
        return True

    def _s_approach(self, now: float, tel: Telemetry) -> None:
        c = self.config
        if self._take_new_fix() is not None:
            self._set_state("align", "pad in view")
            return
        if now - self._last_goto >= RESEND_S:
            self._last_goto = now
            self._goto(c.pad_north_m, c.pad_east_m, c.pad_down_m - c.approach_alt_m)
        if tel.position_ned is not None:
            p = tel.position_ned
            there = (
                math.hypot(p.x - c.pad_north_m, p.y - c.pad_east_m) < 0.5
                and abs(c.pad_down_m - p.z - c.approach_alt_m) < 0.5
            )
            if there and now - self.state_since > 2.0 and self._unseen_s() > c.lost_timeout_s:
                self._start_search(tel, "the pad is not in view where it should be")

    def _centre_over_pad(self, now: float, tel: Telemetry) -> tuple[PadFix, float, bool] | None:
        """One step of centring and turning over the pad on a new fix: (the fix, the
        descent speed sent, whether it is centred); None without a new fix."""
        c = self.config
        fix = self._take_new_fix()
        if fix is None:
            self._no_fix(now, tel)
            return None
        height = self._height(tel) or fix.height_m
        # Too high to see the pad reliably: come down to the approach height meanwhile.
        vd = 0.0
        if height > c.approach_alt_m + 0.5:
            vd = min(c.descent_speed_mps, 0.5 * (height - c.approach_alt_m))
        self._send_velocity(*self._steer(fix, vd))
        centred = self._centred(fix, c.align_tolerance_m)
        self._centred_count = self._centred_count + 1 if centred else 0
        return fix, vd, centred

    def _s_align(self, now: float, tel: Telemetry) -> None:
        c = self.config
        step = self._centre_over_pad(now, tel)
        if step is None:
            return
        fix, vd, _ = step
        if self._centred_count >= CENTRED_FIXES and vd == 0.0:
            self._centred_count = 0
            if c.strategy == "plnd":
                if not self._mode("LAND"):
                    return
                self._send_landing_target(fix)
            self._set_state("descend", "centred and turned to the pad")

    def _s_descend(self, now: float, tel: Telemetry) -> None:
        if not tel.armed:
            self._landed(tel)
            return
        if self.config.strategy == "plnd":
            self._descend_plnd(now, tel)
        else:
            self._descend_guided(now, tel)

    def _descend_plnd(self, now: float, tel: Telemetry) -> None:
        c = self.config
        fix = self._take_new_fix()
        if fix is not None:
            self._send_landing_target(fix)
            self._turn_to_pad(fix, tel)
            return
        height = self._height(tel)
        unseen = self._unseen_s()
        if height is not None and height <= c.final_alt_m + 0.3 and unseen >= BLIND_AFTER_S:
            self._set_state("final", "the pad fills the view: blind descent")
            self._s_final(now, tel)
        elif unseen >= c.lost_hold_s and self._mode("GUIDED"):
            self._set_state("hold", "pad lost: holding")

    def _descend_guided(self, now: float, tel: Telemetry) -> None:
        c = self.config
        fix = self._take_new_fix()
        height = self._height(tel)
        if fix is None:
            unseen = self._unseen_s()
            if height is not None and height <= c.final_alt_m + 0.2 and unseen >= BLIND_AFTER_S:
                self._set_state("final", "the pad fills the view: blind descent")
                self._s_final(now, tel)
            elif unseen >= c.lost_hold_s:
                self._send_velocity(0.0, 0.0, 0.0, 0.0)
                self._set_state("hold", "pad lost: holding")
            return
        h = fix.height_m if height is None else height
        offset = math.hypot(fix.offset_ned[0], fix.offset_ned[1])
        if h <= c.final_alt_m and self._centred(fix, c.final_tolerance_m):
            self._set_state("final", "centred at the blind height")
            self._s_final(now, tel)
            return
        vd = 0.0
        if offset <= max(c.final_tolerance_m, 0.08 * h) and h > c.final_alt_m:
            vd = min(c.descent_speed_mps, max(0.15, 0.3 * (h - c.final_alt_m)))
        self._send_velocity(*self._steer(fix, vd))

    def _s_hold(self, now: float, tel: Telemetry) -> None:
        c = self.config
        if not tel.armed:
            self._landed(tel)
            return
        if self._take_new_fix() is not None:
            self._set_state("align", "pad seen again")
            return
        if now - self._last_goto >= RESEND_S:
            self._last_goto = now
            self._send_velocity(0.0, 0.0, 0.0, 0.0)
        if self._unseen_s() >= c.lost_timeout_s:
            self._start_search(tel, "pad lost too long")

    def _start_search(self, tel: Telemetry, reason: str) -> None:
        c = self.config
        height = self._height(tel) or c.approach_alt_m
        # Climbing widens the view, but the H is found only up to about 6 m (a 0.55 m
        # pad): never search above the approach height plus one climb.
        self._search_alt = min(height + c.search_climb_m, c.approach_alt_m + c.search_climb_m)
        self._last_goto = -math.inf
        self._set_state(
            "search", f"{reason}: searching from {self._search_alt:.1f} m over the pad's place"
        )

    def _s_search(self, now: float, tel: Telemetry) -> None:
        c = self.config
        if self._take_new_fix() is not None:
            self._set_state("align", "pad found")
            return
        if now - self._last_goto >= RESEND_S:
            self._last_goto = now
            # Over where the pad was last seen (or should be), at the search height.
            n, e = self.pad_est[:2] if self.pad_est is not None else (c.pad_north_m, c.pad_east_m)
            self._goto(n, e, c.pad_down_m - (self._search_alt or c.approach_alt_m))
        if now - self.state_since >= c.search_s:
            self._do_abort(f"pad not found within {c.search_s:g} s of searching")

    def _s_final(self, now: float, tel: Telemetry) -> None:
        """The blind last metres: steer to where the last fixes put the pad.

        ``plnd``: LANDING_TARGETs predicted from the pad's estimated position and the
        vehicle's own (stamped with that position's time), so ArduCopter keeps steering
        to the pad instead of declaring it lost 2 s after the last real sighting.
        ``guided``: velocity toward the same point while sinking slowly, then LAND to
        touch down and disarm.
        """
        if not tel.armed:
            self._landed(tel)
            return
        if now - self.state_since > FINAL_TIMEOUT_S:
            self._fail(f"still armed {FINAL_TIMEOUT_S:g} s into the final descent")
            return
        fix = self._take_new_fix()
        if self.config.strategy == "plnd":
            if fix is not None:
                self._send_landing_target(fix)
            else:
                self._send_predicted_target(tel)
            return
        # LAND is asked for once: the mode in telemetry comes with the 1 Hz HEARTBEAT, so
        # it reads GUIDED for up to a second after the vehicle accepted LAND.
        if tel.mode == "LAND" or self._land_accepted:
            return
        height = self._height(tel)
        p = tel.position_ned
        if height is None or p is None or self.pad_est is None:
            self._land_accepted = self._mode("LAND")
            return
        if height <= TOUCHDOWN_M or now - self.state_since > FINAL_GUIDED_S:
            self._land_accepted = self._mode("LAND")  # LAND touches down and disarms
            return
        c = self.config
        vn = c.gain_xy * (self.pad_est[0] - p.x)
        ve = c.gain_xy * (self.pad_est[1] - p.y)
        speed = math.hypot(vn, ve)
        if speed > FINAL_SPEED_MPS:
            vn, ve = vn * FINAL_SPEED_MPS / speed, ve * FINAL_SPEED_MPS / speed
        rate = 0.0 if fix is None else self._steer(fix)[3]
        self._send_velocity(vn, ve, FINAL_SINK_MPS, rate)

    # --- helpers ------------------------------------------------------------------------------
    def _no_fix(self, now: float, tel: Telemetry) -> None:
        """No fresh fix while aligning: stop, and search when it has been too long."""
        self._centred_count = 0
        if now - self._last_goto >= RESEND_S / 2:
            self._last_goto = now
            self._send_velocity(0.0, 0.0, 0.0, 0.0)
        if self._unseen_s() >= self.config.lost_timeout_s:
            self._start_search(tel, "pad lost too long")

    def _send_landing_target(self, fix: Any) -> None:
        x, y, z = fix.target_frd
        result = self.link.send_landing_target(
            x, y, z, time_usec=fix.time_usec, distance=fix.distance_m
        )
        if result.ok:
            self.record.target(self.now, "landing_target", x, y, z, fix.distance_m, fix.time_usec)
            self.last_target_t = self.now

    def _turn_to_pad(self, fix: Any, tel: Telemetry) -> None:
        """LAND holds the heading it had: turn it to the pad's, as seen."""
        if abs(fix.heading_error_deg) < YAW_FIX_DEG or tel.attitude is None:
            return
        if self.now - self._last_yaw < RESEND_S or not hasattr(self.link, "set_yaw"):
            return
        self._last_yaw = self.now
        heading = math.degrees(tel.attitude.yaw) - fix.heading_error_deg
        result = self.link.set_yaw(heading, rate_dps=10.0)
        if not result.ok:
            note = f"the vehicle refused to turn to the pad in LAND: {result.detail}"
            if note not in self.record.notes:
                self.record.notes.append(note)

    def _send_predicted_target(self, tel: Telemetry) -> None:
        target = self._predicted_target(tel)
        stamp = tel.local_position_time_boot_ms
        if target is None or stamp is None:
            return
        x, y, z = target
        distance = math.sqrt(x * x + y * y + z * z)
        if distance <= 0.0:
            return
        usec = max(1, stamp * 1000)
        result = self.link.send_landing_target(x, y, z, time_usec=usec, distance=distance)
        if result.ok:
            self.record.target(self.now, "landing_target_predicted", x, y, z, distance, usec)
            self.last_target_t = self.now

    def _landed(self, tel: Telemetry) -> None:
        touchdown = self._touchdown(tel)
        self.record.touchdown = touchdown
        outcome, lead = "landed", "landed"
        verdict = self.record.precland
        if verdict is not None and verdict != "accepted":
            outcome = "landed_blind"
            said = (
                f"it said '{PRECLAND_FAILSAFE}': no precision-landing backend, set PLND_TYPE 1 "
                "and reboot"
                if verdict == "failsafe"
                else "it never said 'PrecLand: Target Found'"
            )
            lead = (
                f"landed blind, not a precision landing: ArduCopter ignored the targets ({said});"
            )
        if touchdown is None:
            self._end(outcome, f"{lead} disarmed (no position to measure the error)")
        else:
            self._end(
                outcome,
                f"{lead} {touchdown.error_m * 100:.1f} cm from the pad centre, heading off "
                f"by {touchdown.heading_error_deg:.1f} deg ({touchdown.source})",
            )
