"""Recorded flights: list, start/stop on demand, and their .tlog, results and frames."""

from __future__ import annotations

import re
from typing import Any

from fastapi import APIRouter, HTTPException, status
from fastapi.responses import FileResponse

from backend.api.deps import FlightId, FlightsDep, Operator, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, errors
from backend.api.schemas import FlightDeleted, FlightFrame, FlightRef, FlightSummary
from backend.services.flights import FlightBusy, FlightService, NoSuchFlight

router = APIRouter(prefix="/flights", tags=["flights"])

_FRAME_RE = re.compile(r"^\d{1,9}$")


def _summary(row: dict[str, Any], flights: FlightService) -> dict[str, Any]:
    fid = row["id"]
    return {
        "id": fid,
        "started": row["started"],
        "ended": row["ended"],
        "frames": row["frames"],
        "reason": row["reason"],
        "end_reason": row["end_reason"],
        "tlog": f"/api/flights/{fid}/tlog",
        "results": f"/api/flights/{fid}/results",
        "size_bytes": flights.size_bytes(row),
    }


def _not_found(exc: NoSuchFlight) -> HTTPException:
    return HTTPException(status.HTTP_404_NOT_FOUND, str(exc))


@router.get("", dependencies=[Viewer], response_model=list[FlightSummary], responses=VIEWER_ERRORS)
def list_flights(flights: FlightsDep) -> list[dict[str, Any]]:
    return [_summary(r, flights) for r in flights.rows()]


@router.post("/start", dependencies=[Operator], response_model=FlightRef, responses=OPERATOR_ERRORS)
def start_flight(flights: FlightsDep) -> dict[str, Any]:
    """Start recording now (a flight also starts by itself when the vehicle arms)."""
    return flights.start("operator")


@router.post(
    "/stop",
    dependencies=[Operator],
    response_model=FlightRef,
    responses={**OPERATOR_ERRORS, **errors(409)},
)
def stop_flight(flights: FlightsDep) -> dict[str, Any]:
    ended = flights.stop("operator")
    if ended is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "No flight is being recorded.")
    return ended


@router.get(
    "/{flight_id}",
    dependencies=[Viewer],
    response_model=FlightSummary,
    responses={**VIEWER_ERRORS, **errors(404, 422)},
)
def get_flight(flight_id: FlightId, flights: FlightsDep) -> dict[str, Any]:
    try:
        return _summary(flights.get(flight_id), flights)
    except NoSuchFlight as exc:
        raise _not_found(exc) from None


@router.delete(
    "/{flight_id}",
    dependencies=[Operator],
    response_model=FlightDeleted,
    responses={**OPERATOR_ERRORS, **errors(404, 409, 422)},
)
def delete_flight(flight_id: FlightId, flights: FlightsDep) -> dict[str, Any]:
    """Delete a flight: its folder (tlog, frames, results) and its row."""
    try:
        return flights.delete(flight_id)
    except NoSuchFlight as exc:
        raise _not_found(exc) from None
    except FlightBusy as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None


@router.get(
    "/{flight_id}/tlog",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={
        200: {"content": {"application/octet-stream": {}}, "description": "the .tlog"},
        **VIEWER_ERRORS,
        **errors(404, 422),
    },
)
def flight_tlog(flight_id: FlightId, flights: FlightsDep) -> FileResponse:
    """The flight's MAVLink log (a flight still in the air: written up to now)."""
    try:
        path = flights.tlog(flight_id)
    except NoSuchFlight as exc:
        raise _not_found(exc) from None
    return FileResponse(
        path, media_type="application/octet-stream", filename=f"flight-{flight_id}.tlog"
    )


@router.get(
    "/{flight_id}/results",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={
        200: {"content": {"application/x-ndjson": {}}, "description": "one result per line"},
        **VIEWER_ERRORS,
        **errors(404, 422),
    },
)
def flight_results(flight_id: FlightId, flights: FlightsDep) -> FileResponse:
    try:
        path = flights.results(flight_id)
    except NoSuchFlight as exc:
        raise _not_found(exc) from None
    return FileResponse(path, media_type="application/x-ndjson")


@router.get(
    "/{flight_id}/frames",
    dependencies=[Viewer],
    response_model=list[FlightFrame],
    responses={**VIEWER_ERRORS, **errors(404, 422)},
)
def flight_frames(flight_id: FlightId, flights: FlightsDep) -> list[dict[str, Any]]:
    try:
        seqs = flights.frames(flight_id)
    except NoSuchFlight as exc:
        raise _not_found(exc) from None
    return [{"seq": n, "url": f"/api/flights/{flight_id}/frames/{n}.jpg"} for n in seqs]


@router.get(
    "/{flight_id}/frames/{name}",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={
        200: {"content": {"image/jpeg": {}}, "description": "the frame"},
        **VIEWER_ERRORS,
        **errors(404, 422),
    },
)
def flight_frame(flight_id: FlightId, name: str, flights: FlightsDep) -> FileResponse:
    stem = name.removesuffix(".jpg")
    if not name.endswith(".jpg") or not _FRAME_RE.match(stem):
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, "A frame is named by its number: <n>.jpg."
        )
    try:
        path = flights.frame(flight_id, int(stem))
    except NoSuchFlight as exc:
        raise _not_found(exc) from None
    return FileResponse(path, media_type="image/jpeg")
