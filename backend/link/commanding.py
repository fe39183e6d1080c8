"""The link's commands: acknowledged COMMAND_LONGs, parameters, and unacknowledged targets.

Commands block the calling thread until the COMMAND_ACK or a timeout (one
retransmission halfway) and return a :class:`CommandResult`; they never raise for a
refusal by the vehicle, whose reasons (its STATUSTEXTs) come back verbatim.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from backend.link import commands as cmd
from backend.link.commands import CommandResult
from backend.link.connection import SendError
from backend.link.core import _REASON_GRACE_S, _REBOOT_HOLD_S, _RESENT_ACK_WAIT_S, LinkCore
from backend.link.modes import mode_number
from backend.link.state import LinkState


class LinkCommands(LinkCore):
    """The commands of :class:`~backend.link.VehicleLink`."""

    #: VISION_POSITION_ESTIMATE / VISION_SPEED_ESTIMATE sent so far.
    vision_positions_sent: int = 0
    vision_speeds_sent: int = 0

    # ------------------------------------------------------------------ commands
    def arm(self) -> CommandResult:
        """Arm (MAV_CMD_COMPONENT_ARM_DISARM param1 = 1); refusals carry the reasons."""
        return self._command_long("arm", mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (1,))

    def disarm(self) -> CommandResult:
        """Disarm; ArduCopter refuses while flying (use :meth:`force_disarm` only then)."""
        return self._command_long("disarm", mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (0,))

    def force_disarm(self) -> CommandResult:
        """Disarm at once, even in flight (param2 = 21196): the motors stop. Explicit only."""
        return self._command_long(
            "force_disarm", mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (0, cmd.FORCE_MAGIC)
        )

    def set_mode(self, name: str) -> CommandResult:
        """Change flight mode by name (MAV_CMD_DO_SET_MODE with the custom mode number)."""
        try:
            number = mode_number(name)
        except ValueError as exc:
            return self._invalid("set_mode", exc)
        return self._command_long(
            f"set_mode {name.strip().upper()}",
            mavlink2.MAV_CMD_DO_SET_MODE,
            (mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number),
        )

    def takeoff(self, altitude_m: float) -> CommandResult:
        """Take off to ``altitude_m`` above home (MAV_CMD_NAV_TAKEOFF; GUIDED and armed)."""
        try:
            alt = cmd.check_altitude(altitude_m)
        except ValueError as exc:
            return self._invalid("takeoff", exc)
        return self._command_long(
            "takeoff", mavlink2.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, math.nan, 0, 0, alt)
        )

    def set_yaw(self, heading_deg: float, *, rate_dps: float = 0.0) -> CommandResult:
        """Turn to ``heading_deg`` (absolute, clockwise from north) the shortest way
        (MAV_CMD_CONDITION_YAW; ArduCopter takes it in GUIDED, AUTO and LAND), at
        ``rate_dps`` (0: its default)."""
        try:
            heading = cmd.finite(heading_deg, "heading_deg") % 360.0
            rate = cmd.finite(rate_dps, "rate_dps")
            if rate < 0:
                raise ValueError(f"rate_dps must be >= 0, got {rate_dps!r}")
        except ValueError as exc:
            return self._invalid("set_yaw", exc)
        return self._command_long("set_yaw", mavlink2.MAV_CMD_CONDITION_YAW, (heading, rate, 0, 0))

    def land(self) -> CommandResult:
        """Land where the vehicle is (MAV_CMD_NAV_LAND: ArduCopter switches to LAND)."""
        return self._command_long("land", mavlink2.MAV_CMD_NAV_LAND, (0, 0, 0, math.nan, 0, 0, 0))

    def rtl(self) -> CommandResult:
        """Return to launch (MAV_CMD_NAV_RETURN_TO_LAUNCH)."""
        return self._command_long("rtl", mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH, ())

    def reboot(self) -> CommandResult:
        """Reboot the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1 = 1).

        ArduCopter refuses while armed. Needed for settings read at boot, such as
        PLND_TYPE. Once accepted the link is LOST at once (commands meanwhile answer
        LINK_DOWN, not a timeout) and comes back by itself with the new boot's heartbeat.
        """
        result = self._command_long("reboot", mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (1,))
        if result.ok:
            self._rebooting_until = time.monotonic() + _REBOOT_HOLD_S
            self._set_state(LinkState.LOST, "the vehicle is rebooting")
        return result

    def goto_local_ned(
        self, north: float, east: float, down: float, *, yaw_deg: float | None = None
    ) -> CommandResult:
        """Send a GUIDED position target in the local NED frame (metres from home).

        ArduCopter does not acknowledge these: ``ok`` means sent. It obeys only in GUIDED.
        """
        try:
            fields = cmd.position_target(north, east, down, yaw_deg=yaw_deg)
        except ValueError as exc:
            return self._invalid("goto_local_ned", exc)
        return self._send_position_target("goto_local_ned", fields)

    def set_velocity_ned(
        self,
        vn: float,
        ve: float,
        vd: float,
        *,
        yaw_rate_dps: float | None = None,
        frame: str = "local_ned",
    ) -> CommandResult:
        """Send a GUIDED velocity target (m/s); re-send at >= 1 Hz, it lapses after ~3 s.

        ``frame``: ``"local_ned"`` or ``"body_offset_ned"`` (forward/right/down).
        """
        try:
            fields = cmd.velocity_target(vn, ve, vd, yaw_rate_dps=yaw_rate_dps, frame=frame)
        except ValueError as exc:
            return self._invalid("set_velocity_ned", exc)
        return self._send_position_target("set_velocity_ned", fields)

    def send_landing_target(
        self,
        x: float,
        y: float,
        z: float,
        *,
        time_usec: int,
        distance: float | None = None,
        frame: int = mavlink2.MAV_FRAME_BODY_FRD,
        target_num: int = 0,
        size_x: float = 0.0,
        size_y: float = 0.0,
        target_type: int = mavlink2.LANDING_TARGET_TYPE_VISION_FIDUCIAL,
    ) -> CommandResult:
        """Send LANDING_TARGET (position_valid = 1, MAVLink 2 extension fields).

        ``x, y, z`` metres in ``frame`` (ArduCopter takes MAV_FRAME_BODY_FRD only),
        ``time_usec`` the capture time of the frame the pad was seen in. Not
        acknowledged: ``ok`` means sent; the telemetry counts what was sent.
        """
        try:
            fields = cmd.landing_target(
                x,
                y,
                z,
                time_usec=time_usec,
                distance=distance,
                frame=frame,
                target_num=target_num,
                size_x=size_x,
                size_y=size_y,
                target_type=target_type,
            )
        except ValueError as exc:
            return self._invalid("landing_target", exc)
        result = self._send_unacked(
            "landing_target", mavlink2.MAVLink_landing_target_message(**fields)
        )
        if result.ok:
            self._landing_targets += 1
            self._apply(
                {
                    "landing_targets_sent": self._landing_targets,
                    "last_landing_target": {
                        "x": fields["x"],
                        "y": fields["y"],
                        "z": fields["z"],
                        "distance": fields["distance"],
                        "time_usec": float(fields["time_usec"]),
                        "sent_monotonic": time.monotonic(),
                    },
                }
            )
        return result

    def send_vision_position(
        self,
        north: float,
        east: float,
        down: float,
        roll: float,
        pitch: float,
        yaw: float,
        *,
        time_usec: int,
        reset_counter: int = 0,
    ) -> CommandResult:
        """Send VISION_POSITION_ESTIMATE: the vehicle's position from vision (m, the EKF
        origin's NED) and attitude (rad), ``time_usec`` the frame's capture time on the
        vehicle's clock. ArduCopter fuses it with VISO_TYPE 1 (read at boot) when the
        active EKF source set takes ExternalNav. Not acknowledged: ``ok`` means sent."""
        try:
            fields = cmd.vision_position_estimate(
                north,
                east,
                down,
                roll,
                pitch,
                yaw,
                time_usec=time_usec,
                reset_counter=reset_counter,
            )
        except ValueError as exc:
            return self._invalid("vision_position", exc)
        result = self._send_unacked(
            "vision_position", mavlink2.MAVLink_vision_position_estimate_message(**fields)
        )
        if result.ok:
            self.vision_positions_sent += 1
        return result

    def send_vision_speed(
        self, vn: float, ve: float, vd: float, *, time_usec: int, reset_counter: int = 0
    ) -> CommandResult:
        """Send VISION_SPEED_ESTIMATE: the vehicle's velocity from vision (m/s, NED),
        stamped like :meth:`send_vision_position`. Not acknowledged: ``ok`` means sent."""
        try:
            fields = cmd.vision_speed_estimate(
                vn, ve, vd, time_usec=time_usec, reset_counter=reset_counter
            )
        except ValueError as exc:
            return self._invalid("vision_speed", exc)
        result = self._send_unacked(
            "vision_speed", mavlink2.MAVLink_vision_speed_estimate_message(**fields)
        )
        if result.ok:
            self.vision_speeds_sent += 1
        return result

    def set_ekf_source_set(self, number: int) -> CommandResult:
        """Switch the EKF's position/velocity/yaw sources to EK3_SRC<number>_*
        (MAV_CMD_SET_EKF_SOURCE_SET). ArduCopter announces nothing and resets its
        position to the new source's at once."""
        try:
            number = cmd.check_source_set(number)
        except ValueError as exc:
            return self._invalid("set_ekf_source_set", exc)
        return self._command_long(
            f"set_ekf_source_set {number}", mavlink2.MAV_CMD_SET_EKF_SOURCE_SET, (number,)
        )

    def rc_override(self, channels: Mapping[int, int]) -> CommandResult:
        """Override RC channels: ``{channel (1-based): pwm}``; 0 releases, 65535 ignores.

        ArduCopter drops overrides after RC_OVERRIDE_TIME (3 s): re-send at >= 1 Hz. In
        LOITER/ALT_HOLD hold the throttle (channel 3) at 1500 or the vehicle descends.
        """
        try:
            values = cmd.rc_override_channels(channels)
        except ValueError as exc:
            return self._invalid("rc_override", exc)
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_rc_channels_override_message(target[0], target[1], *values)
        return self._send_unacked("rc_override", msg)

    def get_param(self, name: str, *, timeout: float | None = None) -> float | None:
        """Read one parameter (PARAM_REQUEST_READ); None if the link is down or no answer.

        Raises ``ValueError`` for a malformed name.
        """
        name = cmd.check_param_name(name)
        wait = self._cmd_timeout if timeout is None else cmd.finite(timeout, "timeout")
        if wait <= 0:
            raise ValueError(f"timeout must be > 0, got {timeout!r}")
        if self._state != LinkState.UP:
            return None
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_param_request_read_message(
            target[0], target[1], name.encode("ascii"), -1
        )
        try:
            got = self._param_exchange(name, msg, wait)
        except SendError as exc:
            self._note_error(f"get_param {name}: {exc}")
            return None
        return None if got is None else got[0]

    def written_since_boot(self, names: tuple[str, ...]) -> list[str]:
        """Those of ``names`` this link wrote since the vehicle's latest boot it saw:
        settings read at boot (PLND_TYPE, VISO_TYPE) do not act before a reboot."""
        boots = self._telemetry.boots
        return [n for n in names if self._written_in_boot.get(n) == boots]

    def request_param_list(self) -> CommandResult:
        """Ask for every parameter (PARAM_REQUEST_LIST); they arrive as PARAM_VALUEs.

        Not acknowledged: ``ok`` means sent. :meth:`param_table` fills as they come.
        """
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_param_request_list_message(target[0], target[1])
        return self._send_unacked("param_request_list", msg)

    def request_param_index(self, index: int) -> CommandResult:
        """Ask for one parameter by its index (PARAM_REQUEST_READ with ``param_index``), as
        a download fills the gaps a list left. Not acknowledged: ``ok`` means sent."""
        name = "param_request_read"
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= 0x7FFF:
            return self._invalid(name, ValueError(f"index must be 0 .. 32767, got {index!r}"))
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_param_request_read_message(target[0], target[1], b"", index)
        return self._send_unacked(name, msg)

    def missing_params(self) -> tuple[list[int], int]:
        """The indices of the parameters not heard since the vehicle's latest boot, and how
        many it says it has (0, and none missing, before its first PARAM_VALUE)."""
        with self._param_cond:
            count = self._param_count
            return [i for i in range(count) if i not in self._param_indices], count

    def param_table(self) -> tuple[dict[str, tuple[float, int]], int]:
        """Every parameter heard so far, name -> (value, MAV_PARAM_TYPE), and how many
        the vehicle says it has (0 before its first PARAM_VALUE)."""
        with self._param_cond:
            table = {name: (v[0], v[1]) for name, v in self._params.items()}
            return table, self._param_count

    def set_param(self, name: str, value: float) -> CommandResult:
        """Write one parameter (PARAM_SET), verified by the vehicle's PARAM_VALUE echo."""
        label = f"set_param {name}"
        try:
            name = cmd.check_param_name(name)
            fvalue = cmd.finite(value, "value")
        except ValueError as exc:
            return self._invalid(label, exc)
        if self._state != LinkState.UP:
            return self._link_down(label)
        known = self._params.get(name)
        ptype = known[1] if known else mavlink2.MAV_PARAM_TYPE_REAL32
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_param_set_message(
            target[0], target[1], name.encode("ascii"), fvalue, ptype
        )
        started = time.monotonic()
        try:
            got = self._param_exchange(name, msg, self._cmd_timeout)
        except SendError as exc:
            return self._finish(
                CommandResult(False, label, None, cmd.SEND_FAILED, detail=f"not sent: {exc}")
            )
        elapsed = time.monotonic() - started
        if got is None:
            detail = (
                f"no PARAM_VALUE echo within {self._cmd_timeout:g} s "
                "(unknown parameter, or the link lost it)"
            )
            return self._finish(CommandResult(False, label, None, cmd.TIMEOUT, (), detail, elapsed))
        echoed = got[0]
        expected = cmd.as_float32(fvalue)
        if math.isclose(echoed, expected, rel_tol=1e-6, abs_tol=1e-9):
            self._written_in_boot[name] = self._telemetry.boots
            return self._finish(
                CommandResult(True, label, None, "ACCEPTED", (), f"{name} = {echoed:g}", elapsed)
            )
        detail = f"the vehicle kept {name} = {echoed:g}, not {fvalue:g}"
        return self._finish(CommandResult(False, label, None, cmd.MISMATCH, (), detail, elapsed))

    # ------------------------------------------------------------------ command plumbing
    def _invalid(self, name: str, exc: ValueError) -> CommandResult:
        # refused before anything is sent; not an event: nothing happened on the link
        return CommandResult(False, name, None, cmd.INVALID_ARGUMENT, (), str(exc))

    def _link_down(self, name: str) -> CommandResult:
        state = self._state
        if state == LinkState.LOST and time.monotonic() < self._rebooting_until:
            why = "the link is lost: the vehicle is rebooting"
        elif state == LinkState.LOST:
            why = "the link is lost (no heartbeat from the vehicle)"
        elif state == LinkState.CLOSED:
            why = "the link is closed"
        else:
            why = "the link is not up yet (no heartbeat from the vehicle so far)"
        return CommandResult(False, name, None, cmd.LINK_DOWN, (), f"{why}; nothing was sent")

    def _finish(self, result: CommandResult) -> CommandResult:
        self._emit("command", result.to_dict())
        return result

    def _command_lock(self, command_id: int) -> threading.Lock:
        with self._command_locks_guard:
            return self._command_locks.setdefault(command_id, threading.Lock())

    def _command_long_msg(
        self, command_id: int, params: tuple[float, ...], confirmation: int
    ) -> Any:
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        target = self._target or (1, 1)
        return mavlink2.MAVLink_command_long_message(
            target[0], target[1], command_id, confirmation, *p
        )

    def _command_long(self, name: str, command_id: int, params: tuple[float, ...]) -> CommandResult:
        """Send COMMAND_LONG and wait for its COMMAND_ACK (one retransmission halfway)."""
        if self._state != LinkState.UP:
            return self._link_down(name)
        timeout = self._cmd_timeout
        lock = self._command_lock(command_id)
        if not lock.acquire(timeout=timeout):
            detail = f"another {name} command is still waiting for its acknowledgement"
            return self._finish(CommandResult(False, name, None, cmd.TIMEOUT, (), detail))
        try:
            pending = self._tracker.begin(command_id, name)
            try:
                return self._finish(self._await_ack(name, command_id, params, pending, timeout))
            finally:
                self._tracker.end(pending)
        finally:
            lock.release()

    def _await_ack(
        self,
        name: str,
        command_id: int,
        params: tuple[float, ...],
        pending: cmd.PendingCommand,
        timeout: float,
    ) -> CommandResult:
        sent = time.monotonic()
        try:
            self._send(self._command_long_msg(command_id, params, 0))
        except SendError as exc:
            return CommandResult(False, name, None, cmd.SEND_FAILED, (), f"not sent: {exc}")
        deadline = sent + timeout
        resend_at = sent + timeout / 2
        resent = False
        while True:
            now = time.monotonic()
            if (
                pending.ack_result is not None
                and pending.ack_result != mavlink2.MAV_RESULT_IN_PROGRESS
            ):
                break
            if now >= deadline or self._state != LinkState.UP:
                break
            if now >= resend_at and pending.ack_result is None:
                resend_at = math.inf
                with contextlib.suppress(SendError):
                    self._send(self._command_long_msg(command_id, params, 1))
                    resent = True
            pending.event.wait(min(0.05, max(0.0, min(deadline, resend_at) - now)))
            pending.event.clear()
        if resent and pending.ack_result is not None:
            # The retransmission earns an ACK of its own; take it here so that it cannot
            # pass for the answer to the next command with the same id.
            linger = time.monotonic() + _RESENT_ACK_WAIT_S
            while pending.acks < 2 and time.monotonic() < linger and not self._stop.is_set():
                pending.event.wait(0.02)
                pending.event.clear()
        result = pending.ack_result
        if result is None or result == mavlink2.MAV_RESULT_IN_PROGRESS:
            elapsed = time.monotonic() - sent
            reasons = cmd.select_reasons(pending.texts)
            if self._state != LinkState.UP:
                detail = f"the link went {self._state.value} before the vehicle answered"
                return CommandResult(False, name, None, cmd.LINK_DOWN, reasons, detail, elapsed)
            detail = f"no COMMAND_ACK within {timeout:g} s"
            if result == mavlink2.MAV_RESULT_IN_PROGRESS:
                detail += " (the vehicle reported it in progress)"
            return CommandResult(False, name, result, cmd.TIMEOUT, reasons, detail, elapsed)
        elapsed = (pending.acked_at or time.monotonic()) - sent
        result_name = cmd.mav_result_name(result)
        if result == mavlink2.MAV_RESULT_ACCEPTED:
            return CommandResult(True, name, result, result_name, (), "accepted", elapsed)
        # the vehicle's explanation may trail its COMMAND_ACK by a few messages
        self._stop.wait(_REASON_GRACE_S)
        reasons = cmd.select_reasons(pending.texts)
        detail = f"refused by the vehicle ({result_name})"
        if reasons:
            detail += ": " + "; ".join(reasons)
        return CommandResult(False, name, result, result_name, reasons, detail, elapsed)

    def _send_position_target(self, name: str, fields: dict[str, Any]) -> CommandResult:
        target = self._target or (1, 1)
        msg = mavlink2.MAVLink_set_position_target_local_ned_message(
            self._time_boot_ms(), target[0], target[1], **fields
        )
        result = self._send_unacked(name, msg)
        mode = self._telemetry.mode
        if result.ok and mode != "GUIDED":
            return replace(result, detail=f"sent; ArduCopter ignores it in {mode} (not GUIDED)")
        return result

    def _send_unacked(self, name: str, msg: Any) -> CommandResult:
        if self._state != LinkState.UP:
            return self._link_down(name)
        try:
            self._send(msg)
        except SendError as exc:
            return CommandResult(False, name, None, cmd.SEND_FAILED, (), f"not sent: {exc}")
        return CommandResult(True, name, None, cmd.SENT, (), "sent (not acknowledged by design)")

    def _param_exchange(self, name: str, msg: Any, timeout: float) -> tuple[float, int] | None:
        """Send ``msg`` and wait for a PARAM_VALUE for ``name`` (resent halfway)."""
        sent = time.monotonic()
        self._send(msg)
        deadline = sent + timeout
        resend_at = sent + timeout / 2
        while True:
            with self._param_cond:
                got = self._params.get(name)
                if got is not None and got[2] >= sent:
                    return got[0], got[1]
                now = time.monotonic()
                if now >= deadline or self._state != LinkState.UP:
                    return None
                if now < resend_at:
                    self._param_cond.wait(min(0.05, deadline - now))
                    continue
            resend_at = math.inf  # sent outside the lock: the reader must not wait on us
            with contextlib.suppress(SendError):
                self._send(msg)
