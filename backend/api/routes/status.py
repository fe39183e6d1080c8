"""GET /api/status: link, camera, pipeline, mission, reference, flight, 3D view.

The snapshot is built off the event loop by the status service (at least once a
second, and whenever something moves); answering it touches no lock and no database.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from backend.api.deps import StatusDep, Viewer
from backend.api.errors import VIEWER_ERRORS
from backend.api.schemas import Status

router = APIRouter(tags=["status"], dependencies=[Viewer], responses=VIEWER_ERRORS)


@router.get("/status", response_model=Status)
async def get_status(status: StatusDep) -> dict[str, Any]:
    return status.status.data
