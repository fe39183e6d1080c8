"""GET /api/status: link, camera, pipeline, mission, reference, flight, 3D view."""

from __future__ import annotations

from fastapi import APIRouter

from backend.api.deps import StationDep, Viewer

router = APIRouter(tags=["status"], dependencies=[Viewer])


@router.get("/status")
def get_status(station: StationDep) -> dict:
    return station.status()
