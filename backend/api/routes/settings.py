"""GET/PUT /api/settings: the settings the operator may change while running."""

from __future__ import annotations

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field, StrictBool

from backend.api.deps import Operator, StationDep, Viewer

router = APIRouter(tags=["settings"])


class SettingsUpdate(BaseModel):
    """Only the fields given change; unknown fields are refused."""

    model_config = ConfigDict(extra="forbid")

    view_requires_token: StrictBool | None = None
    record_frames: StrictBool | None = None
    jpeg_quality: int | None = Field(None, ge=10, le=100, strict=True)


@router.get("/settings", dependencies=[Viewer])
def get_settings(station: StationDep) -> dict:
    return station.public_settings()


@router.put("/settings", dependencies=[Operator])
def put_settings(update: SettingsUpdate, station: StationDep) -> dict:
    changes = update.model_dump(exclude_none=True)
    return station.update_runtime(changes)
