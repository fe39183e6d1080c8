"""A real :class:`~backend.link.VehicleLink` to a lockstep stand-in, with the clock in hand.

In lockstep the stand-in handles what arrives only when told to ``advance``. A link
command that waits for its COMMAND_ACK (or a PARAM_VALUE) would wait forever on a
frozen vehicle, so :class:`LockstepLink` runs such calls in a helper thread and keeps
the vehicle handling its inbox (``advance(0)``: no simulated time passes) until the
answer is in. :meth:`LockstepLink.sync` is a barrier through the same TCP stream: a
parameter read whose answer comes after everything the vehicle sent before it and is
asked after everything we sent, so when it returns both sides have seen it all. With
that, a run is the same for the same seed however fast the machine is.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from backend.link import CommandResult, LinkState, Telemetry, VehicleLink

#: Wall-clock bound on one pumped call (a healthy loopback answers in milliseconds).
CALL_TIMEOUT_S = 10.0
SYNC_PARAM = "SYSID_THISMAV"


class LockstepError(RuntimeError):
    """The stand-in did not answer in time."""


class LockstepLink:
    """Wraps ``link`` (started, connected to ``server``) for use from the clock's thread.

    Exposes what missions use: ``telemetry``, ``set_mode``, ``arm``, ``disarm``, ``takeoff``,
    ``goto_local_ned``, ``set_velocity_ned``, ``send_landing_target``, ``get_param``,
    ``set_param``, ``reboot``.
    """

    def __init__(self, link: VehicleLink, server: Any) -> None:
        if not getattr(server, "lockstep", False):
            raise ValueError("server must be a lockstep VehicleServer")
        self.link = link
        self.server = server
        self.syncs = 0

    @property
    def telemetry(self) -> Telemetry:
        return self.link.telemetry

    def latest(self, msg_type: str) -> Any:
        return self.link.latest(msg_type)

    def pump(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """Run ``fn(*args, **kwargs)`` in a helper thread while the vehicle answers."""
        box: dict[str, Any] = {}

        def call() -> None:
            try:
                box["value"] = fn(*args, **kwargs)
            except BaseException as exc:  # handed back to the caller below
                box["error"] = exc

        worker = threading.Thread(target=call, name="lockstep-call", daemon=True)
        worker.start()
        deadline = time.monotonic() + CALL_TIMEOUT_S
        while worker.is_alive():
            self.server.advance(0.0)
            worker.join(0.001)
            if time.monotonic() > deadline:
                raise LockstepError(f"{getattr(fn, '__name__', fn)} got no answer in time")
        if "error" in box:
            raise box["error"]
        return box.get("value")

    def sync(self) -> bool:
        """Barrier: both sides have handled everything the other sent so far.

        Returns False when the link is down or the vehicle is rebooting (nothing to wait
        for: a dropped link is a scenario, not an error); raises :class:`LockstepError`
        when an up link is mute.
        """
        if self._gone():
            return False  # nothing to wait for (a rebooting vehicle answers nothing)
        if self.pump(self.link.get_param, SYNC_PARAM, timeout=CALL_TIMEOUT_S / 2) is None:
            if self._gone():
                return False
            raise LockstepError("the stand-in did not answer the sync parameter read")
        self.syncs += 1
        return True

    def _gone(self) -> bool:
        """The link is down, the vehicle rebooting, or the stand-in stopped (its link's
        reader may not have seen the socket close yet on a loaded machine)."""
        return (
            self.link.telemetry.state != LinkState.UP
            or self.server.rebooting
            or not self.server.running
        )

    # --- acknowledged: pumped ------------------------------------------------------------------
    def set_mode(self, name: str) -> CommandResult:
        return self.pump(self.link.set_mode, name)

    def arm(self) -> CommandResult:
        return self.pump(self.link.arm)

    def disarm(self) -> CommandResult:
        return self.pump(self.link.disarm)

    def takeoff(self, altitude_m: float) -> CommandResult:
        return self.pump(self.link.takeoff, altitude_m)

    def set_yaw(self, heading_deg: float, **kwargs: Any) -> CommandResult:
        return self.pump(self.link.set_yaw, heading_deg, **kwargs)

    def reboot(self) -> CommandResult:
        return self.pump(self.link.reboot)

    def get_param(self, name: str, *, timeout: float | None = None) -> float | None:
        return self.pump(self.link.get_param, name, timeout=timeout)

    def set_param(self, name: str, value: float) -> CommandResult:
        return self.pump(self.link.set_param, name, value)

    def set_ekf_source_set(self, number: int) -> CommandResult:
        return self.pump(self.link.set_ekf_source_set, number)

    def written_since_boot(self, names: tuple[str, ...]) -> list[str]:
        return self.link.written_since_boot(names)

    # --- not acknowledged: sent at once, handled at the next sync -------------------------------
    def goto_local_ned(self, *args: Any, **kwargs: Any) -> CommandResult:
        return self.link.goto_local_ned(*args, **kwargs)

    def set_velocity_ned(self, *args: Any, **kwargs: Any) -> CommandResult:
        return self.link.set_velocity_ned(*args, **kwargs)

    def send_landing_target(self, *args: Any, **kwargs: Any) -> CommandResult:
        return self.link.send_landing_target(*args, **kwargs)

    def send_vision_position(self, *args: Any, **kwargs: Any) -> CommandResult:
        return self.link.send_vision_position(*args, **kwargs)

    def send_vision_speed(self, *args: Any, **kwargs: Any) -> CommandResult:
        return self.link.send_vision_speed(*args, **kwargs)
