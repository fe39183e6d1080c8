"""GET/PUT /api/settings: the settings the operator may change while running."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, status
from pydantic import Field, field_validator

from backend.api.bodies import StrictBody
from backend.api.deps import MissionsDep, Operator, RuntimeDep, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, errors
from backend.api.schemas import PublicSettings
from backend.settings import check_mount

router = APIRouter(tags=["settings"])


class SettingsUpdate(StrictBody):
    """Only the fields given change; unknown fields are refused."""

    view_requires_token: bool | None = None
    record_frames: bool | None = None
    jpeg_quality: int | None = Field(None, ge=10, le=100)
    camera_mount_deg: list[float] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="roll, pitch, yaw in degrees: how the camera is turned from looking "
        "straight down with its picture's top to the nose (as `--camera-mount`); the "
        "attitude hints follow at once, missions from their next start",
    )

    @field_validator("camera_mount_deg")
    @classmethod
    def _mount(cls, value: list[float] | None) -> list[float] | None:
        return None if value is None else list(check_mount((value[0], value[1], value[2])))


@router.get(
    "/settings", dependencies=[Viewer], response_model=PublicSettings, responses=VIEWER_ERRORS
)
async def get_settings(runtime: RuntimeDep) -> dict[str, Any]:
    return runtime.public()


@router.put(
    "/settings",
    dependencies=[Operator],
    response_model=PublicSettings,
    responses={**OPERATOR_ERRORS, **errors(409, 422)},
)
def put_settings(
    update: SettingsUpdate, runtime: RuntimeDep, missions: MissionsDep
) -> dict[str, Any]:
    """Change settings (stored at once, so they hold after a restart). The camera's
    mount is refused (409) while a mission flies: it took the mount at its start, and
    the vision's hints would turn under it."""
    changes = update.model_dump(exclude_none=True)
    if "camera_mount_deg" in changes and missions.running:
        raise HTTPException(
            status.HTTP_409_CONFLICT,
            "A mission is running: the camera's mount changes only between missions "
            "(abort it or let it finish first).",
        )
    return runtime.update(changes)
