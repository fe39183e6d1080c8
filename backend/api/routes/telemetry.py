"""GET /api/telemetry: the vehicle link's latest telemetry snapshot."""

from __future__ import annotations

from fastapi import APIRouter

from backend.api.deps import StationDep, Viewer

router = APIRouter(tags=["telemetry"], dependencies=[Viewer])


@router.get("/telemetry")
def get_telemetry(station: StationDep) -> dict:
    return station.telemetry_dict()
