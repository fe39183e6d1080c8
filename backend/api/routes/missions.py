"""Vision missions: hover over the pad, land on it, abort; the live state and the history.

Commands need the operator token and answer in the vehicle routes' shape (``ok``,
``command``, ``result_name``, ``detail``, ``reasons``) plus ``mission`` (the live state):
200 started, 409 one is already running (or none to abort), 503 the link is down.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Body, HTTPException, status
from pydantic import BaseModel, Field

from backend.api.bodies import StrictBody
from backend.api.deps import MissionsDep, Operator, RunId, VehicleDep, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, errors
from backend.api.schemas import (
    MissionCommand,
    MissionDefaults,
    MissionRun,
    MissionRunSummary,
    MissionSnapshot,
)
from backend.missions import HoverConfig
from backend.missions.manager import MissionBusy
from backend.services.vehicle import VehicleService

router = APIRouter(prefix="/missions", tags=["missions"])

_COMMAND_ERRORS = {**OPERATOR_ERRORS, **errors(409, 422)}


_ABORT_DOC = (
    "where the mission leaves the vehicle when it gives up (LOITER holds in GUIDED instead "
    "when no pilot holds the throttle)"
)


class HoverRequest(StrictBody):
    altitude_m: float = Field(
        4.0, ge=1, le=100, title="Altitude", description="hover height above home (m)"
    )
    hold_s: float = Field(
        20.0, gt=0, le=3600, title="Hold time", description="how long to hold over the pad (s)"
    )
    abort_mode: Literal["LOITER", "RTL"] = Field(
        "LOITER", title="If it gives up", description=_ABORT_DOC
    )


class LandRequest(StrictBody):
    strategy: Literal["plnd", "guided", "extnav"] = Field(
        "plnd",
        title="Strategy",
        description="plnd: ArduCopter's precision landing fed LANDING_TARGET; guided: GUIDED "
        "velocity targets from the vision pose; extnav: GPS-denied: the vision pose becomes "
        "ArduPilot's position (ExternalNav, after the external-navigation set-up) and LAND "
        "holds over the pad on it; the pad lost without GPS lands in place",
    )
    approach_alt_m: float | None = Field(
        None,
        ge=1,
        le=50,
        title="Approach height",
        description="height to look for the pad from (m); by default a margin under where "
        "the active pad is still reliably found with this camera",
    )
    abort_mode: Literal["LOITER", "RTL"] = Field(
        "LOITER", title="If it gives up", description=_ABORT_DOC
    )
    lost_timeout_s: float = Field(
        5.0,
        gt=0,
        le=120,
        title="Lost timeout",
        description="pad unseen this long: climb and search (s)",
    )
    search_s: float = Field(
        8.0, gt=0, le=600, title="Search time", description="search this long, then abort (s)"
    )


def form_fields(model: type[BaseModel]) -> list[dict[str, Any]]:
    """The request model's fields as the dashboard's form shows them."""
    schema = model.model_json_schema()
    out = []
    for name, prop in schema["properties"].items():
        # an optional number (``float | None``) keeps its bounds in the non-null branch
        prop = {**next((p for p in prop.get("anyOf", []) if p.get("type") != "null"), {}), **prop}
        field: dict[str, Any] = {
            "name": name,
            "title": prop.get("title", name),
            "description": prop.get("description", ""),
            "default": prop.get("default"),
            "kind": "choice" if "enum" in prop else "number",
            "choices": [str(c) for c in prop.get("enum", [])],
            "minimum": prop.get("minimum"),
            "maximum": prop.get("maximum"),
            "exclusive_minimum": prop.get("exclusiveMinimum"),
            "unit": "s" if name.endswith("_s") else "m" if name.endswith("_m") else "",
        }
        out.append(field)
    return out


def _check_link(vehicle: VehicleService) -> None:
    if not vehicle.link_up:
        raise HTTPException(
            status.HTTP_503_SERVICE_UNAVAILABLE,
            "The link to the vehicle is down; no mission was started.",
        )


def _started(command: str, snapshot: dict[str, Any]) -> dict[str, Any]:
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


@router.post(
    "/hover", dependencies=[Operator], response_model=MissionCommand, responses=_COMMAND_ERRORS
)
def hover(
    missions: MissionsDep,
    vehicle: VehicleDep,
    body: Annotated[HoverRequest | None, Body()] = None,
) -> dict[str, Any]:
    """Take off (if need be), fly over the pad and hold there."""
    req = body or HoverRequest()
    _check_link(vehicle)
    land = vehicle.land_config(abort_mode=req.abort_mode)
    config = HoverConfig(altitude_m=req.altitude_m, hold_s=req.hold_s, land=land)
    try:
        return _started("mission hover", missions.start_hover(config))
    except MissionBusy as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None


@router.post(
    "/land", dependencies=[Operator], response_model=MissionCommand, responses=_COMMAND_ERRORS
)
def land(
    missions: MissionsDep,
    vehicle: VehicleDep,
    body: Annotated[LandRequest | None, Body()] = None,
) -> dict[str, Any]:
    """Land on the pad by precision landing ("plnd"), GCS guidance ("guided") or on vision
    as the vehicle's position source, without GPS ("extnav")."""
    req = body or LandRequest()
    _check_link(vehicle)
    config = vehicle.land_config(**req.model_dump())
    try:
        return _started("mission land", missions.start_land(config))
    except MissionBusy as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None


@router.post(
    "/abort",
    dependencies=[Operator],
    response_model=MissionCommand,
    responses={**OPERATOR_ERRORS, **errors(409)},
)
def abort(missions: MissionsDep) -> dict[str, Any]:
    snapshot = missions.abort("operator abort")
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


@router.get(
    "/current",
    dependencies=[Viewer],
    response_model=MissionSnapshot | None,
    responses=VIEWER_ERRORS,
)
def current(missions: MissionsDep) -> dict[str, Any] | None:
    """The running mission's live state (or the last one's, or null)."""
    return missions.current()


@router.get(
    "", dependencies=[Viewer], response_model=list[MissionRunSummary], responses=VIEWER_ERRORS
)
def history(missions: MissionsDep) -> list[dict[str, Any]]:
    """Stored runs, newest first, with their outcomes and touchdown errors."""
    return missions.history()


@router.get(
    "/defaults", dependencies=[Viewer], response_model=MissionDefaults, responses=VIEWER_ERRORS
)
def defaults(vehicle: VehicleDep) -> dict[str, Any]:
    """Every mission parameter with its default and bounds (the dashboard's forms).

    The approach height's default is computed for the active pad and camera: a margin
    under the height up to which that pad is still reliably found. A form that leaves it
    unchanged omits it, so the pad active when the mission starts decides.
    """
    land = form_fields(LandRequest)
    computed = vehicle.approach_altitude_m()
    for field in land:
        if field["name"] == "approach_alt_m" and computed is not None:
            field.update(default=computed, computed=True)
            field["description"] += f" (now {computed:g} m for the active pad)"
    return {"hover": form_fields(HoverRequest), "land": land}


@router.get(
    "/{run_id}",
    dependencies=[Viewer],
    response_model=MissionRun,
    responses={**VIEWER_ERRORS, **errors(404, 422)},
)
def run(run_id: RunId, missions: MissionsDep) -> dict[str, Any]:
    """One stored run with its whole record (states, targets sent, touchdown)."""
    row = missions.run(run_id)
    if row is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No mission run {run_id}.")
    return row
