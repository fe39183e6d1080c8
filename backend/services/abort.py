"""ABORT: stop whatever Visland is doing and make the vehicle hold where it is.

Always does something safe and says exactly what was sent:

- a running Visland mission is stopped (without its own abort manoeuvre);
- an armed vehicle is put in GUIDED and given a position target where it is now
  (it stops and holds, whatever the pilot's throttle stick says); if GUIDED is refused,
  BRAKE (which holds without a position target);
- a disarmed vehicle needs no hold: nothing is sent, and the answer says so;
- with the link down nothing can be sent: the vehicle's own failsafe decides.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from backend.link import CommandResult, LinkState, VehicleLink
from backend.missions.manager import MissionManager
from backend.services.events import EventLog


@dataclass
class AbortOutcome:
    """What ABORT did: the mission it stopped, every command sent and its answer."""

    ok: bool
    mission: dict[str, Any] | None
    sent: list[dict[str, Any]] = field(default_factory=list)
    detail: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"ok": self.ok, "mission": self.mission, "sent": self.sent, "detail": self.detail}


def _step(what: str, result: CommandResult) -> dict[str, Any]:
    return {
        "command": what,
        "ok": result.ok,
        "result_name": result.result_name,
        "detail": result.detail,
        "reasons": list(result.reasons),
    }


class AbortService:
    """The station's ABORT over ``link`` and ``missions``."""

    def __init__(self, link: VehicleLink, missions: MissionManager, events: EventLog) -> None:
        self._link = link
        self._missions = missions
        self._events = events

    @property
    def link_state(self) -> LinkState:
        return self._link.state

    def abort(self) -> AbortOutcome:
        """Stop any mission, hold the vehicle; never raises for a refusal."""
        mission = self._missions.abort("stopped by the operator's ABORT", hand_over=True)
        stopped = "" if mission is None else f"The {mission['kind']} mission was stopped. "
        link, tel = self._link, self._link.telemetry
        outcome = AbortOutcome(ok=True, mission=mission)
        if link.state != LinkState.UP:
            outcome.ok = False
            outcome.detail = (
                f"{stopped}The link is {link.state.value}: nothing could be sent; "
                "the vehicle's own failsafe decides."
            )
        elif not tel.armed and tel.state_confirmed:
            # (unconfirmed: it accepted an arm since its last heartbeat; hold it anyway)
            outcome.detail = f"{stopped}The vehicle is disarmed: nothing to hold, nothing sent."
        else:
            self._hold(outcome, stopped)
        self._events.emit("abort", f"ABORT: {outcome.detail}", outcome.to_dict())
        return outcome

    def _hold(self, outcome: AbortOutcome, stopped: str) -> None:
        link = self._link
        guided = link.set_mode("GUIDED")
        outcome.sent.append(_step("set mode GUIDED", guided))
        position = link.telemetry.position_ned
        if guided.ok and position is not None:
            hold = link.goto_local_ned(position.x, position.y, position.z)
            outcome.sent.append(
                _step(
                    f"hold position N {position.x:.1f} m, E {position.y:.1f} m, "
                    f"{-position.z:.1f} m up",
                    hold,
                )
            )
            if hold.ok:
                outcome.detail = (
                    f"{stopped}Sent GUIDED and a position hold where the vehicle is "
                    f"({-position.z:.1f} m up)."
                )
                return
        brake = link.set_mode("BRAKE")
        outcome.sent.append(_step("set mode BRAKE", brake))
        if brake.ok:
            why = "GUIDED was refused" if not guided.ok else "no position to hold at"
            outcome.detail = f"{stopped}Sent BRAKE ({why}): the vehicle stops and holds."
            return
        outcome.ok = False
        reasons = "; ".join(brake.reasons) or brake.detail
        outcome.detail = (
            f"{stopped}The vehicle refused GUIDED and BRAKE ({reasons}); take control with "
            "the remote."
        )
