"""Landing without GPS: the vision pose becomes ArduPilot's position source (ExternalNav).

The ``extnav`` strategy, measured on ArduCopter 4.5.6 SITL (notes/sitl-findings.md):

``check`` (also: VISO_TYPE 1 and EK3_SRC2_POSXY 6 on the vehicle, i.e. the station's
external-navigation set-up and its reboot) -> ``approach`` (GPS) -> ``align``: centre and
turn over the pad by GUIDED velocity targets while GPS still navigates, and learn where
the pad is in the EKF's own frame (its origin's NED: ArduPilot resets its position to
the vision's on a source switch, so vision must be in that frame or the vehicle jumps)
-> ``switch``: from now on every detection goes out as VISION_POSITION_ESTIMATE (the pad's
EKF position less the camera's view of it; time_usec = the frame's capture time on the
vehicle's clock) and VISION_SPEED_ESTIMATE (the same positions differenced), then
MAV_CMD_SET_EKF_SOURCE_SET 2 (EK3_SRC2_*: ExternalNav, baro, compass) -> ``settle``: hold
over the pad on vision -> ``descend``: LAND, which holds position on the EKF, now vision:
GPS may go at any time -> ``final``: the pad fills the view, the last decimetres are
dead-reckoned -> ``landed``.

The pad lost without GPS (unseen ``lost_hold_s`` above ``final_alt_m`` once on vision):
the EKF has no position source left. Holding or climbing to search would need a
position ArduPilot no longer has (it would drift on dead reckoning for ~8 s, then its EKF
failsafe lands anyway, ~4 m off on SITL). The mission commands LAND at once instead
(``landing_in_place``): level, straight down where it is, drifting with the dead
reckoning (1.2 m off from 5 m on SITL), and the outcome is ``landed_in_place``, never
``landed``: it did not land on the pad.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from backend.link import Telemetry
from backend.missions.land import (
    BLIND_AFTER_S,
    CENTRED_FIXES,
    FINAL_TIMEOUT_S,
    RESEND_S,
    LandMission,
)
from backend.missions.mission import Mission, VisionSample

#: What the external-navigation set-up writes (then a reboot: VISO_TYPE is read at boot).
#: Source set 1 stays GPS; set 2 is vision for XY position and velocity, baro height and
#: compass yaw. The set-up also leaves the vision check out of ARMING_CHECK (bit 18): the
#: pad is not in view on the ground, and ArduCopter refuses to arm without vision when
#: VISO_TYPE is 1 ("Arm: VisOdom: not healthy").
EXTNAV_PARAMS: tuple[tuple[str, float], ...] = (
    ("VISO_TYPE", 1.0),
    ("EK3_SRC2_POSXY", 6.0),
    ("EK3_SRC2_VELXY", 6.0),
    ("EK3_SRC2_POSZ", 1.0),
    ("EK3_SRC2_YAW", 1.0),
)
#: ArduPilot's ARMING_CHECK bit for the visual odometry, and bits 1..20 (BARO .. OSD)
#: without it.
ARMING_CHECK_VISION = 1 << 18
ARMING_CHECK_ALL_BUT_VISION = (1 << 21) - 2 - ARMING_CHECK_VISION
#: The source set the set-up makes vision's (set 1 stays GPS, as the vehicle boots).
VISION_SOURCE_SET = 2
#: Pad positions (EKF frame) averaged before the switch: one fix is not a frame.
PAD_FIXES = 10
#: Vision sent this long before the switch: ArduPilot calls it healthy within 0.3 s.
FEED_BEFORE_SWITCH_S = 0.5
#: Hold over the pad on vision this long before LAND.
SETTLE_S = 2.0
#: Velocity from the positions of the last this many seconds (needs 3 spanning 0.15 s).
SPEED_WINDOW_S = 0.4
#: The pad last seen within this of ``final_alt_m`` (m, camera height by vision): losing
#: it is the blind last part (the 0.55 m pad overfills a 60-degree view below ~0.9 m).
BLIND_MARGIN_M = 0.5
#: VISO_DELAY_MS's documented range (ms).
VISO_DELAY_RANGE_MS = (0, 250)


def viso_delay_ms(latency_ms: float | None, send_ms: float = 10.0) -> int:
    """VISO_DELAY_MS for a measured capture -> result latency: ArduPilot's jitter
    correction takes the steady part of the delay for clock offset, so the EKF must be
    told it (as PLND_LAG for precision landing).

    >>> viso_delay_ms(42.3), viso_delay_ms(None), viso_delay_ms(900)
    (52, 10, 250)
    """
    if latency_ms is None or not math.isfinite(latency_ms) or latency_ms < 0:
        return 10  # ArduPilot's default: nothing measured yet
    low, high = VISO_DELAY_RANGE_MS
    return int(min(high, max(low, round(latency_ms + send_ms))))


def extnav_missing(values: dict[str, float | None]) -> list[str]:
    """What the vehicle's parameters lack for the ``extnav`` strategy (empty: set up).

    >>> extnav_missing({"VISO_TYPE": 1, "EK3_SRC2_POSXY": 6})
    []
    >>> extnav_missing({"VISO_TYPE": 0, "EK3_SRC2_POSXY": None})
    ['VISO_TYPE = 1 (now 0)', 'EK3_SRC2_POSXY = 6 (not read)']
    """
    out = []
    for name, want in (("VISO_TYPE", 1), ("EK3_SRC2_POSXY", 6)):
        got = values.get(name)
        if got is None:
            out.append(f"{name} = {want} (not read)")
        elif got != want:
            out.append(f"{name} = {want} (now {got:g})")
    return out


class VisionVelocity:
    """The vehicle's velocity from its recent vision positions (least squares over
    :data:`SPEED_WINDOW_S`), on the vehicle's clock."""

    def __init__(self) -> None:
        self._points: deque[tuple[float, float, float, float]] = deque()

    def add(self, time_usec: int, ned: tuple[float, float, float]) -> None:
        t = time_usec / 1e6
        if self._points and t <= self._points[-1][0]:
            self._points.clear()  # the vehicle's clock went back: it rebooted
        self._points.append((t, *ned))
        while self._points and t - self._points[0][0] > SPEED_WINDOW_S:
            self._points.popleft()

    def velocity(self) -> tuple[float, float, float] | None:
        if len(self._points) < 3 or self._points[-1][0] - self._points[0][0] < 0.15:
            return None
        a = np.asarray(self._points, float)
        t = a[:, 0] - a[:, 0].mean()
        denom = float(t @ t)
        slopes = [(t @ (a[:, k] - a[:, k].mean())) / denom for k in (1, 2, 3)]
        return float(slopes[0]), float(slopes[1]), float(slopes[2])


class ExtNavLandMission(LandMission):
    """The ``extnav`` strategy; see the module docstring."""

    def __init__(self, link: Any, config: Any, **kwargs: Any) -> None:
        super().__init__(link, config, **kwargs)
        self.pad_ekf: tuple[float, float, float] | None = None
        self.feeding_since: float | None = None
        self.on_vision = False
        self._pad_samples: list[tuple[float, float, float]] = []
        self._velocity = VisionVelocity()
        self._lost_land_sent = False
        self.vision_sent = 0

    # --- vision out ---------------------------------------------------------------------------
    def _take(self, sample: VisionSample, tel: Telemetry) -> None:
        before = self.record.detections
        super()._take(sample, tel)
        if self.record.detections > before and self.feeding_since is not None:
            self._send_vision(tel)

    def _send_vision(self, tel: Telemetry) -> None:
        fix, pad = self.fix, self.pad_ekf
        if fix is None or pad is None or tel.attitude is None:
            return
        ned = (
            pad[0] - fix.offset_ned[0],
            pad[1] - fix.offset_ned[1],
            pad[2] - fix.offset_ned[2],
        )
        a = tel.attitude
        result = self.link.send_vision_position(
            *ned, a.roll, a.pitch, a.yaw, time_usec=fix.time_usec
        )
        if not result.ok:
            return
        self.vision_sent += 1
        self.record.target(self.now, "vision_position", *ned, fix.time_usec)
        self.last_target_t = self.now
        self._velocity.add(fix.time_usec, ned)
        v = self._velocity.velocity()
        if v is not None:
            self.link.send_vision_speed(*v, time_usec=fix.time_usec)

    # --- states -------------------------------------------------------------------------------
    def _s_check(self, now: float, tel: Telemetry) -> None:
        values = {name: self.link.get_param(name) for name in ("VISO_TYPE", "EK3_SRC2_POSXY")}
        missing = extnav_missing(values)
        if missing:
            self._fail(
                "external navigation is not set up on the vehicle: "
                + ", ".join(missing)
                + "; set it up (it ends in a reboot of the autopilot) before a GPS-denied landing"
            )
            return
        super()._s_check(now, tel)

    def _s_align(self, now: float, tel: Telemetry) -> None:
        step = self._centre_over_pad(now, tel)
        if step is None:
            return
        _, vd, centred = step
        if centred and vd == 0.0 and self.pad_est is not None:
            self._pad_samples.append(self.pad_est)
        if not centred:
            self._pad_samples.clear()
        if self._centred_count >= CENTRED_FIXES and len(self._pad_samples) >= PAD_FIXES:
            n, e, d = (float(v) for v in np.median(self._pad_samples[-PAD_FIXES:], axis=0))
            self.pad_ekf = (n, e, d)
            self.feeding_since = now
            self._send_velocity(0.0, 0.0, 0.0, 0.0)
            self._set_state(
                "switch",
                f"pad at ({n:.2f}, {e:.2f}, {d:.2f}) m in the EKF frame: sending vision "
                "as the vehicle's position",
            )

    def _s_switch(self, now: float, tel: Telemetry) -> None:
        if self._unseen_s() >= self.config.lost_hold_s:
            # Still on GPS: stop feeding vision and centre again when it is back.
            self.feeding_since = None
            self._pad_samples.clear()
            self._centred_count = 0
            self._set_state("align", "pad lost before the switch to vision (still on GPS)")
            return
        if now - (self.feeding_since or now) < FEED_BEFORE_SWITCH_S or self.vision_sent < 3:
            return
        result = self.link.set_ekf_source_set(VISION_SOURCE_SET)
        if not result.ok:
            reasons = "; ".join(result.reasons) if result.reasons else result.detail
            self._do_abort(
                f"the vehicle refused EKF source set {VISION_SOURCE_SET}: "
                f"{result.result_name} ({reasons})"
            )
            return
        self.on_vision = True
        self.record.notes.append(
            f"EKF source set {VISION_SOURCE_SET} (ExternalNav) from t = "
            f"{now - self.started:.2f} s: the vision pose is the vehicle's position"
        )
        self._last_goto = -math.inf
        self._set_state("settle", "EKF on vision (source set 2): holding over the pad")

    def _s_settle(self, now: float, tel: Telemetry) -> None:
        if self._lost_without_gps(now, tel):
            return
        pad = self.pad_ekf
        p = tel.position_ned
        if pad is not None and p is not None and now - self._last_goto >= RESEND_S:
            self._last_goto = now
            self._goto(pad[0], pad[1], p.z)
        if now - self.state_since >= SETTLE_S:
            if not self._mode("LAND"):
                return
            self._set_state("descend", "LAND on the vision position (GPS not needed)")

    def _s_descend(self, now: float, tel: Telemetry) -> None:
        if not tel.armed:
            self._landed(tel)
            return
        c = self.config
        if self._take_new_fix() is not None:
            return
        # Blind when the pad was last seen close (the vision's own height: the EKF's baro
        # height reads ~0.2 m high on SITL) or the estimate says it is low.
        height = self._height(tel)
        last = self.fix.height_m if self.fix is not None else None
        close = (last is not None and last <= c.final_alt_m + BLIND_MARGIN_M) or (
            height is not None and height <= c.final_alt_m + 0.3
        )
        if close and self._unseen_s() >= BLIND_AFTER_S:
            self._set_state("final", "the pad fills the view: the last decimetres dead-reckoned")
            return
        self._lost_without_gps(now, tel)

    def _s_final(self, now: float, tel: Telemetry) -> None:
        if not tel.armed:
            self._landed(tel)
            return
        self._take_new_fix()
        if now - self.state_since > FINAL_TIMEOUT_S:
            self._fail(f"still armed {FINAL_TIMEOUT_S:g} s into the final descent")

    def _s_landing_in_place(self, now: float, tel: Telemetry) -> None:
        if not tel.armed:
            touchdown = self._touchdown(tel)
            self.record.touchdown = touchdown
            where = "" if touchdown is None else f" {touchdown.error_m:.2f} m from the pad centre"
            self._end(
                "landed_in_place",
                f"landed in place{where} after the pad was lost without GPS (LAND, level): "
                "not a landing on the pad",
            )
            return
        self._take_new_fix()
        if not self._lost_land_sent and tel.mode != "LAND":
            self._lost_land_sent = self.link.set_mode("LAND").ok

    # --- helpers ------------------------------------------------------------------------------
    def _lost_without_gps(self, now: float, tel: Telemetry) -> bool:
        """The pad unseen ``lost_hold_s`` while vision is (about to be) the position
        source: LAND where it is, at once; True when that happened."""
        if self._unseen_s() < self.config.lost_hold_s:
            return False
        already = tel.mode == "LAND"
        self._lost_land_sent = already or self.link.set_mode("LAND").ok
        gps = tel.gps
        gps_text = (
            "no GPS fix" if gps is None or gps.fix_type < 3 else "GPS not the position source"
        )
        self._set_state(
            "landing_in_place",
            f"pad lost on vision navigation ({gps_text}): landing in place (LAND, level), "
            "not on the pad; it drifts with the dead reckoning",
        )
        return True

    def _landed(self, tel: Telemetry) -> None:
        touchdown = self._touchdown(tel)
        self.record.touchdown = touchdown
        nav = "on vision navigation (ExternalNav)" if self.on_vision else "still on GPS"
        if touchdown is None:
            self._end("landed", f"landed and disarmed {nav} (no position to measure the error)")
        else:
            self._end(
                "landed",
                f"landed {nav} {touchdown.error_m * 100:.1f} cm from the pad centre, heading "
                f"off by {touchdown.heading_error_deg:.1f} deg ({touchdown.source})",
            )


def land_mission(link: Any, config: Any, **kwargs: Any) -> Mission:
    """The landing mission for ``config.strategy``: :class:`ExtNavLandMission` for
    ``extnav``, else :class:`LandMission`."""
    if getattr(config, "strategy", None) == "extnav":
        return ExtNavLandMission(link, config, **kwargs)
    return LandMission(link, config, **kwargs)
