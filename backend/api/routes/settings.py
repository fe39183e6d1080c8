"""GET/PUT /api/settings: the settings the operator may change while running."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from pydantic import Field

from backend.api.bodies import StrictBody
from backend.api.deps import Operator, RuntimeDep, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, errors
from backend.api.schemas import PublicSettings

router = APIRouter(tags=["settings"])


class SettingsUpdate(StrictBody):
    """Only the fields given change; unknown fields are refused."""

    view_requires_token: bool | None = None
    record_frames: bool | None = None
    jpeg_quality: int | None = Field(None, ge=10, le=100)


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
