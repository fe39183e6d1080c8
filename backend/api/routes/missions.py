"""Vision missions: hover over the pad, land on it, abort; the live state and the history.

Commands need the operator token and answer in the vehicle routes' shape (``ok``,
``command``, ``result_name``, ``detail``, ``reasons``) plus ``mission`` (the live state):
200 started, 409 one is already running (or none to abort), 503 the link is down.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from fastapi import APIRouter, Body, HTTPException, Path, status
from pydantic import BaseModel, ConfigDict, Field, field_validator

from backend.api.deps import Operator, StationDep, Viewer
from backend.link import LinkState
from backend.missions import HoverConfig
from backend.missions.manager import MissionBusy

router = APIRouter(prefix="/missions", tags=["missions"])

RunId = Annotated[int, Path(ge=1, le=2**63 - 1, description="a mission run's id")]


class _Finite(BaseModel):
    model_config = ConfigDict(extra="forbid")

    @field_validator("*")
    @classmethod
    def _finite(cls, value: object) -> object:
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError("must be a finite number")
        return value


class HoverRequest(_Finite):
    altitude_m: float = Field(4.0, gt=0, le=100, description="hover height above home (m)")
    hold_s: float = Field(20.0, gt=0, le=3600, description="how long to hold over the pad")
    abort_mode: Literal["LOITER", "RTL"] = "LOITER"


class LandRequest(_Finite):
    strategy: Literal["plnd", "guided"] = "plnd"
    approach_alt_m: float = Field(4.0, gt=0, le=50, description="height to look for the pad")
    abort_mode: Literal["LOITER", "RTL"] = "LOITER"
    lost_timeout_s: float = Field(5.0, gt=0, le=120)
    search_s: float = Field(8.0, gt=0, le=600)


def _manager(station):
    manager = station.missions
    if manager is None:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, "The station is not running.")
    return manager


def _check_link(station) -> None:
    tel = station.telemetry
    if tel is None or tel.state != LinkState.UP:
        raise HTTPException(
            status.HTTP_503_SERVICE_UNAVAILABLE,
            "The link to the vehicle is down; no mission was started.",
        )


def _started(command: str, snapshot: dict) -> dict:
    strategy = snapshot.get("strategy")
    return {
        "ok": True,
        "command": command,
        "result": None,
        "result_name": "STARTED",
        "detail": f"{snapshot['kind']} mission started" + (f" ({strategy})" if strategy else ""),
        "reasons": [],
        "mission": snapshot,
    }


@router.post("/hover", dependencies=[Operator])
def hover(station: StationDep, body: Annotated[HoverRequest | None, Body()] = None) -> dict:
    req = body or HoverRequest()
    manager = _manager(station)
    _check_link(station)
    land = station.land_config(abort_mode=req.abort_mode)
    config = HoverConfig(altitude_m=req.altitude_m, hold_s=req.hold_s, land=land)
    try:
        return _started("mission hover", manager.start_hover(config))
    except MissionBusy as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None


@router.post("/land", dependencies=[Operator])
def land(station: StationDep, body: Annotated[LandRequest | None, Body()] = None) -> dict:
    req = body or LandRequest()
    manager = _manager(station)
    _check_link(station)
    config = station.land_config(**req.model_dump())
    try:
        return _started("mission land", manager.start_land(config))
    except MissionBusy as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None


@router.post("/abort", dependencies=[Operator])
def abort(station: StationDep) -> dict:
    snapshot = _manager(station).abort("operator abort")
    if snapshot is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "No mission is running.")
    return {
        "ok": True,
        "command": "mission abort",
        "result": None,
        "result_name": "ABORTED",
        "detail": snapshot.get("message") or "mission aborted",
        "reasons": [],
        "mission": snapshot,
    }


@router.get("/current", dependencies=[Viewer])
def current(station: StationDep) -> dict | None:
    """The running mission's live state (or the last one's, or null)."""
    return _manager(station).current()


@router.get("", dependencies=[Viewer])
def history(station: StationDep) -> list[dict]:
    """Stored runs, newest first, with their outcomes and touchdown errors."""
    return _manager(station).history()


@router.get("/{run_id}", dependencies=[Viewer])
def run(run_id: RunId, station: StationDep) -> dict:
    """One stored run with its whole record (states, targets sent, touchdown)."""
    row = _manager(station).run(run_id)
    if row is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No mission run {run_id}.")
    return row
