"""GET /api/telemetry: the vehicle link's latest telemetry snapshot (at most 0.1 s old)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from backend.api.deps import StatusDep, Viewer
from backend.api.errors import VIEWER_ERRORS
from backend.api.schemas import Telemetry

router = APIRouter(tags=["telemetry"], dependencies=[Viewer], responses=VIEWER_ERRORS)


@router.get("/telemetry", response_model=Telemetry)
async def get_telemetry(status: StatusDep) -> dict[str, Any]:
    return status.telemetry.data
