"""Vehicle parameters: list (with ArduCopter's documentation), download, write one,
reboot the autopilot, and set up precision landing or external navigation (the GPS-denied
landing) in one step each.

Writes are checked against the parameter's type and documented range (422 with a
sentence), confirmed by the vehicle's PARAM_VALUE echo (409 when it kept another
value), and recorded as events. A reboot is refused while armed (409).
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path, Query, status
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field, field_validator

from backend.api.deps import Operator, ParamsDep, VehicleDep, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, command_errors, errors
from backend.api.schemas import (
    BatteryThresholds,
    CommandResult,
    ExtNavSetup,
    ParamListing,
    ParamWriteResult,
    PrecLandSetup,
)
from backend.services.params import BadValue, UnknownParam, VehicleArmed
from backend.services.vehicle import VehicleService

router = APIRouter(tags=["parameters"])

ParamName = Annotated[
    str,
    Path(
        min_length=1,
        max_length=16,
        pattern=r"^[A-Z0-9_]+$",
        description="an ArduCopter parameter name, e.g. PLND_ENABLED",
    ),
]


class ParamValue(BaseModel):
    model_config = ConfigDict(extra="forbid")
    value: float = Field(description="the new value")

    @field_validator("value")
    @classmethod
    def _finite(cls, value: float) -> float:
        if not math.isfinite(value):
            raise ValueError("value must be a finite number")
        return value


def _need_link(vehicle: VehicleService, what: str) -> None:
    if not vehicle.link_up:
        raise HTTPException(
            status.HTTP_503_SERVICE_UNAVAILABLE,
            f"The link to the vehicle is down; {what}.",
        )


@router.get("/params", dependencies=[Viewer], response_model=ParamListing, responses=VIEWER_ERRORS)
def list_params(
    params: ParamsDep,
    names: Annotated[
        str | None,
        Query(
            max_length=2000,
            pattern=r"^[A-Z0-9_,]*$",
            description="only these, comma-separated (e.g. PLND_ENABLED,PLND_TYPE)",
        ),
    ] = None,
) -> dict[str, Any]:
    """The parameters heard so far (``complete`` once the vehicle sent them all)."""
    wanted = None if not names else {n for n in names.split(",") if n}
    return params.listing(wanted)


@router.post(
    "/params/refresh",
    dependencies=[Operator],
    response_model=ParamListing,
    responses={**OPERATOR_ERRORS, **errors(503)},
)
def refresh_params(params: ParamsDep, vehicle: VehicleDep) -> dict[str, Any]:
    """Download every parameter from the vehicle (PARAM_REQUEST_LIST, then any the list
    lost by index): until all came, or none came for 20 s; 120 s at most."""
    _need_link(vehicle, "no parameters were read")
    try:
        return params.refresh()
    except ConnectionError as exc:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, f"{exc}.") from None


@router.get(
    "/params/battery",
    dependencies=[Viewer],
    response_model=BatteryThresholds,
    responses=VIEWER_ERRORS,
)
def battery_thresholds(params: ParamsDep) -> dict[str, Any]:
    """The BATT_* thresholds the dashboard's battery alerts use (null when absent)."""
    return params.battery_thresholds()


@router.put(
    "/params/{name}",
    dependencies=[Operator],
    response_model=ParamWriteResult,
    responses={
        **OPERATOR_ERRORS,
        **errors(404, 422, 503),
        409: {"model": ParamWriteResult, "description": "The vehicle kept another value."},
    },
)
def write_param(name: ParamName, body: ParamValue, params: ParamsDep, vehicle: VehicleDep) -> Any:
    """Write one parameter, checked against its type and documented range first."""
    _need_link(vehicle, "nothing was written")
    try:
        write = params.write(name, body.value, why="by the operator")
    except UnknownParam as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from None
    except BadValue as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from None
    answer = write.to_dict()
    if not write.result.ok:
        answer["detail"] = (
            f"The vehicle did not take {name} = {body.value:g}: {write.result.detail}."
        )
        return JSONResponse(answer, status_code=status.HTTP_409_CONFLICT)
    return answer


@router.post(
    "/params/precland-setup",
    dependencies=[Operator],
    response_model=PrecLandSetup,
    responses={
        **OPERATOR_ERRORS,
        **errors(503),
        409: {
            "model": PrecLandSetup,
            "description": "Armed (ErrorResponse), or the vehicle refused a write or the reboot.",
        },
    },
)
def precland_setup(params: ParamsDep, vehicle: VehicleDep) -> Any:
    """PLND_ENABLED 1, PLND_TYPE 1 (MAVLink), PLND_EST_TYPE 1, PLND_LAG from the measured
    latency, PLND_ORIENT down, PLND_CAM_POS_* the camera's mount; then reboot."""
    _need_link(vehicle, "nothing was written")
    try:
        outcome = params.setup_precland()
    except VehicleArmed as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None
    return JSONResponse(outcome, status_code=200 if outcome["ok"] else status.HTTP_409_CONFLICT)


@router.post(
    "/params/extnav-setup",
    dependencies=[Operator],
    response_model=ExtNavSetup,
    responses={
        **OPERATOR_ERRORS,
        **errors(503),
        409: {
            "model": ExtNavSetup,
            "description": "Armed (ErrorResponse), or the vehicle refused a write or the reboot.",
        },
    },
)
def extnav_setup(params: ParamsDep, vehicle: VehicleDep) -> Any:
    """For the GPS-denied landing ("extnav"): VISO_TYPE 1 (MAVLink), EKF source set 2 =
    ExternalNav position and velocity, baro height, compass yaw; ARMING_CHECK without the
    vision check (the pad is not in view on the ground); then reboot."""
    _need_link(vehicle, "nothing was written")
    try:
        outcome = params.setup_extnav()
    except VehicleArmed as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None
    return JSONResponse(outcome, status_code=200 if outcome["ok"] else status.HTTP_409_CONFLICT)


@router.post(
    "/vehicle/reboot",
    dependencies=[Operator],
    tags=["vehicle"],
    response_model=CommandResult,
    responses={**OPERATOR_ERRORS, **command_errors(409, 503, 504)},
)
def reboot(params: ParamsDep, vehicle: VehicleDep) -> Any:
    """Reboot the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN); refused while armed.

    The link goes lost while it restarts and comes back by itself."""
    _need_link(vehicle, "nothing was sent")
    try:
        result = params.reboot(why="by the operator")
    except VehicleArmed as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None
    body = result.to_dict()
    if result.ok:
        return body
    body["detail"] = result.detail or "The vehicle refused to reboot."
    code = 504 if result.result_name == "TIMEOUT" else 409
    return JSONResponse(body, status_code=code)
