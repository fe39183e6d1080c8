"""GET/PUT /api/settings: the settings the operator may change while running."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field, StrictBool

from backend.api.deps import Operator, RuntimeDep, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, errors
from backend.api.schemas import PublicSettings

router = APIRouter(tags=["settings"])


class SettingsUpdate(BaseModel):
    """Only the fields given change; unknown fields are refused."""

    model_config = ConfigDict(extra="forbid")

    view_requires_token: StrictBool | None = None
    record_frames: StrictBool | None = None
    jpeg_quality: int | None = Field(None, ge=10, le=100, strict=True)


@router.get(
    "/settings", dependencies=[Viewer], response_model=PublicSettings, responses=VIEWER_ERRORS
)
async def get_settings(runtime: RuntimeDep) -> dict[str, Any]:
    return runtime.public()


@router.put(
    "/settings",
    dependencies=[Operator],
    response_model=PublicSettings,
    responses={**OPERATOR_ERRORS, **errors(422)},
)
def put_settings(update: SettingsUpdate, runtime: RuntimeDep) -> dict[str, Any]:
    """Change settings (stored at once, so they hold after a restart)."""
    return runtime.update(update.model_dump(exclude_none=True))
