"""Vehicle commands: arm, disarm, force-disarm, land, rtl, takeoff, mode.

Each answers the link's CommandResult: 200 accepted, 409 refused by the vehicle (its
reasons verbatim), 503 link down, 504 no acknowledgement in time. Nothing is sent
without the operator token.
"""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse
from pydantic import Field, field_validator

from backend.api.bodies import StrictBody
from backend.api.deps import Operator, VehicleDep
from backend.api.errors import OPERATOR_ERRORS, command_errors, errors
from backend.api.schemas import CommandResult
from backend.link import CommandResult as LinkCommandResult
from backend.link.commands import INVALID_ARGUMENT, LINK_DOWN, TIMEOUT
from backend.link.modes import COPTER_MODES

# Errors of a command carry the whole CommandResult (the vehicle's reasons verbatim);
# 401 and a body that does not validate are plain ErrorResponses.
router = APIRouter(
    prefix="/vehicle",
    tags=["vehicle"],
    dependencies=[Operator],
    responses={**OPERATOR_ERRORS, **command_errors(409, 503, 504), **errors(422)},
)

MIN_TAKEOFF_M = 1.0
MAX_TAKEOFF_M = 100.0


class Takeoff(StrictBody):
    altitude_m: float = Field(
        ge=MIN_TAKEOFF_M, le=MAX_TAKEOFF_M, description="metres above home (1 to 100)"
    )


class Mode(StrictBody):
    mode: str = Field(max_length=40, description="an ArduCopter mode name, e.g. GUIDED")

    @field_validator("mode")
    @classmethod
    def _known(cls, value: str) -> str:
        name = value.strip().upper()
        if name not in COPTER_MODES.values():
            shown = value[:30].encode("ascii", "backslashreplace").decode()
            raise ValueError(
                f"unknown mode {shown!r}; ArduCopter modes: " + ", ".join(COPTER_MODES.values())
            )
        return name


def _answer(result: LinkCommandResult) -> JSONResponse:
    body = result.to_dict()
    if result.ok:
        code = 200
    elif result.result_name == LINK_DOWN:
        code = 503
    elif result.result_name == TIMEOUT:
        code = 504
    elif result.result_name == INVALID_ARGUMENT:
        code = 422
    else:
        code = 409
    if not result.ok:
        # Errors carry a sentence in "detail" like every other error of the API.
        body["detail"] = result.detail or f"{result.command} refused ({result.result_name})"
    return JSONResponse(body, status_code=code)


@router.post("/arm", response_model=CommandResult)
def arm(vehicle: VehicleDep) -> JSONResponse:
    return _answer(vehicle.command("arm"))


@router.post("/disarm", response_model=CommandResult)
def disarm(vehicle: VehicleDep) -> JSONResponse:
    return _answer(vehicle.command("disarm"))


@router.post("/force-disarm", response_model=CommandResult)
def force_disarm(vehicle: VehicleDep) -> JSONResponse:
    return _answer(vehicle.command("force-disarm"))


@router.post("/land", response_model=CommandResult)
def land(vehicle: VehicleDep) -> JSONResponse:
    return _answer(vehicle.command("land"))


@router.post("/rtl", response_model=CommandResult)
def rtl(vehicle: VehicleDep) -> JSONResponse:
    return _answer(vehicle.command("rtl"))


@router.post("/takeoff", response_model=CommandResult)
def takeoff(body: Takeoff, vehicle: VehicleDep) -> JSONResponse:
    return _answer(vehicle.command("takeoff", body.altitude_m))


@router.post("/mode", response_model=CommandResult)
def set_mode(body: Mode, vehicle: VehicleDep) -> JSONResponse:
    return _answer(vehicle.command("mode", body.mode))
