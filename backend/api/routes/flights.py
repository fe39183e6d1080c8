"""Recorded flights: list, start/stop on demand, and their .tlog, results and frames."""

from __future__ import annotations

import re
from pathlib import Path

from fastapi import APIRouter, HTTPException, status
from fastapi.responses import FileResponse

from backend.api.deps import FlightId, Operator, StationDep, Viewer

router = APIRouter(prefix="/flights", tags=["flights"])

_FRAME_RE = re.compile(r"^\d{1,9}$")


def _summary(row: dict) -> dict:
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
    }


def _flight_dir(station, flight_id: int) -> Path:
    row = station.storage.get_flight(flight_id)
    if row is None or not row["dir"]:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No flight {flight_id}.")
    return Path(row["dir"])


@router.get("", dependencies=[Viewer])
def list_flights(station: StationDep) -> list[dict]:
    return [_summary(r) for r in station.storage.list_flights()]


@router.post("/start", dependencies=[Operator])
def start_flight(station: StationDep) -> dict:
    """Start recording now (a flight also starts by itself when the vehicle arms)."""
    return station.recorder.start("operator")


@router.post("/stop", dependencies=[Operator])
def stop_flight(station: StationDep) -> dict:
    ended = station.recorder.stop("operator")
    if ended is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "No flight is being recorded.")
    return ended


@router.get("/{flight_id}", dependencies=[Viewer])
def get_flight(flight_id: FlightId, station: StationDep) -> dict:
    row = station.storage.get_flight(flight_id)
    if row is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No flight {flight_id}.")
    return _summary(row)


@router.get(
    "/{flight_id}/tlog",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={200: {"content": {"application/octet-stream": {}}}},
)
def flight_tlog(flight_id: FlightId, station: StationDep) -> FileResponse:
    folder = _flight_dir(station, flight_id)
    # A flight still in the air gets its log written up to now.
    station.recorder.write_tlog_now(flight_id)
    path = folder / "flight.tlog"
    if not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"Flight {flight_id} has no .tlog.")
    return FileResponse(
        path, media_type="application/octet-stream", filename=f"flight-{flight_id}.tlog"
    )


@router.get(
    "/{flight_id}/results",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={200: {"content": {"application/x-ndjson": {}}}},
)
def flight_results(flight_id: FlightId, station: StationDep) -> FileResponse:
    path = _flight_dir(station, flight_id) / "results.jsonl"
    if not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"Flight {flight_id} has no results.")
    return FileResponse(path, media_type="application/x-ndjson")


@router.get("/{flight_id}/frames", dependencies=[Viewer])
def flight_frames(flight_id: FlightId, station: StationDep) -> list[dict]:
    folder = _flight_dir(station, flight_id) / "frames"
    if not folder.is_dir():
        return []
    out = []
    for path in sorted(folder.glob("*.jpg")):
        n = int(path.stem)
        out.append({"seq": n, "url": f"/api/flights/{flight_id}/frames/{n}.jpg"})
    return out


@router.get(
    "/{flight_id}/frames/{name}",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={200: {"content": {"image/jpeg": {}}}},
)
def flight_frame(flight_id: FlightId, name: str, station: StationDep) -> FileResponse:
    stem = name.removesuffix(".jpg")
    if not name.endswith(".jpg") or not _FRAME_RE.match(stem):
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, "A frame is named by its number: <n>.jpg."
        )
    path = _flight_dir(station, flight_id) / "frames" / f"{int(stem):06d}.jpg"
    if not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"Flight {flight_id} has no frame {stem}.")
    return FileResponse(path, media_type="image/jpeg")
