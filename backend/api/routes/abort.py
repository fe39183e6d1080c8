"""POST /api/abort: the operator's ABORT, always safe (:mod:`backend.services.abort`).

Stops any Visland mission and makes an armed vehicle hold where it is (GUIDED and a
position target there, or BRAKE), answering with every command sent and the
vehicle's answer. 200 when the vehicle holds or needs no hold (disarmed), 503 when the
link is down (nothing could be sent), 409 when the vehicle refused both holds.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from backend.api.deps import AbortDep, Operator
from backend.api.errors import OPERATOR_ERRORS
from backend.api.schemas import AbortResult
from backend.link import LinkState

router = APIRouter(tags=["missions"])


@router.post(
    "/abort",
    dependencies=[Operator],
    response_model=AbortResult,
    responses={
        **OPERATOR_ERRORS,
        409: {"model": AbortResult, "description": "The vehicle refused GUIDED and BRAKE."},
        503: {"model": AbortResult, "description": "The link is down: nothing could be sent."},
    },
)
def abort(service: AbortDep) -> Any:
    """Stop any mission and hold the vehicle where it is; says what was sent."""
    outcome = service.abort()
    body = outcome.to_dict()
    if outcome.ok:
        return body
    down = service.link_state != LinkState.UP
    return JSONResponse(body, status_code=503 if down else 409)
