"""A reference from a photo of the pad in perspective: upload, corners, preview, activate.

``POST /api/reference/perspective`` keeps the photo as a draft and suggests the pad's
outline (quadrilateral, and ellipse for round pads); ``POST .../{draft}/preview``
rectifies it with the four corners the operator confirmed and measures the H, without
activating anything; ``POST .../{draft}/previews/{preview}/activate`` makes it the
active reference. Every failure leaves the active reference as it was.
"""

from __future__ import annotations

import math
from pathlib import PurePath
from typing import Annotated, Any

from fastapi import APIRouter, File, HTTPException, Path, UploadFile, status
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse
from pydantic import BaseModel, ConfigDict, Field, field_validator

from backend.api.deps import Operator, PerspectiveDep, RuntimeDep, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, errors
from backend.api.routes.reference import read_limited
from backend.api.schemas import PerspectivePhoto, PerspectivePreview, ReferenceSummary
from backend.imaging import UnsupportedImage, decode_image
from backend.services.perspective import BadCorners, NoSuchDraft
from backend.services.references import NoUsableH
from backend.settings import MAX_PAD_SIZE_M

router = APIRouter(prefix="/reference/perspective", tags=["reference"])

DraftId = Annotated[str, Path(pattern=r"^[0-9a-f]{12}$", description="a draft photo's id")]
PreviewId = Annotated[str, Path(pattern=r"^[0-9a-f]{12}$", description="a preview's id")]


class PreviewRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    corners: list[tuple[float, float]] = Field(
        min_length=4,
        max_length=4,
        description="the pad's outer corners in the photo's pixels: TL, TR, BR, BL",
    )
    pad_size_m: float = Field(gt=0, le=MAX_PAD_SIZE_M, description="the pad's width (m)")
    aspect: float = Field(1.0, ge=0.1, le=10, description="the pad's width / height")

    @field_validator("corners")
    @classmethod
    def _finite(cls, value: list[tuple[float, float]]) -> list[tuple[float, float]]:
        if not all(math.isfinite(c) for point in value for c in point):
            raise ValueError("corners must be finite numbers")
        return value


def _missing(exc: NoSuchDraft) -> HTTPException:
    return HTTPException(status.HTTP_404_NOT_FOUND, str(exc))


@router.post(
    "",
    status_code=status.HTTP_201_CREATED,
    dependencies=[Operator],
    response_model=PerspectivePhoto,
    responses={**OPERATOR_ERRORS, **errors(413, 415)},
)
async def upload_photo(
    drafts: PerspectiveDep,
    runtime: RuntimeDep,
    file: Annotated[UploadFile, File(description="a photo of the pad lying on the ground")],
) -> dict[str, Any]:
    """Keep the photo as a draft and suggest the pad's outline; nothing becomes active."""
    data = await read_limited(file, int(runtime.public()["max_upload_bytes"]))
    if not data:
        raise HTTPException(status.HTTP_415_UNSUPPORTED_MEDIA_TYPE, "The file is empty.")
    name = PurePath(file.filename or "photo").name[:120] or "photo"
    try:
        image = await run_in_threadpool(decode_image, data)
    except UnsupportedImage as exc:
        raise HTTPException(status.HTTP_415_UNSUPPORTED_MEDIA_TYPE, str(exc)) from exc
    return await run_in_threadpool(drafts.add_photo, image, name)


@router.get(
    "/{draft_id}/photo",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={
        200: {"content": {"image/png": {}}, "description": "the photo"},
        **VIEWER_ERRORS,
        **errors(404, 422),
    },
)
def draft_photo(draft_id: DraftId, drafts: PerspectiveDep) -> FileResponse:
    try:
        return FileResponse(drafts.photo_path(draft_id), media_type="image/png")
    except NoSuchDraft as exc:
        raise _missing(exc) from None


@router.post(
    "/{draft_id}/preview",
    dependencies=[Operator],
    response_model=PerspectivePreview,
    responses={**OPERATOR_ERRORS, **errors(404, 422)},
)
def preview(draft_id: DraftId, body: PreviewRequest, drafts: PerspectiveDep) -> dict[str, Any]:
    """Rectify with the four corners and measure the H; nothing becomes active.

    422 when the corners do not outline the pad or no usable H is on the result."""
    corners = [list(c) for c in body.corners]
    try:
        return drafts.preview(draft_id, corners, body.pad_size_m, body.aspect)
    except NoSuchDraft as exc:
        raise _missing(exc) from None
    except (BadCorners, NoUsableH) as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from None


@router.get(
    "/{draft_id}/previews/{name}",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={
        200: {"content": {"image/png": {}}, "description": "the rectified picture"},
        **VIEWER_ERRORS,
        **errors(404, 422),
    },
)
def preview_image(
    draft_id: DraftId,
    name: Annotated[str, Path(pattern=r"^[0-9a-f]{12}(-corners)?\.png$")],
    drafts: PerspectiveDep,
) -> FileResponse:
    try:
        return FileResponse(drafts.preview_path(draft_id, name), media_type="image/png")
    except NoSuchDraft as exc:
        raise _missing(exc) from None


@router.post(
    "/{draft_id}/previews/{preview_id}/activate",
    status_code=status.HTTP_201_CREATED,
    dependencies=[Operator],
    response_model=ReferenceSummary,
    responses={**OPERATOR_ERRORS, **errors(404, 422)},
)
def activate(draft_id: DraftId, preview_id: PreviewId, drafts: PerspectiveDep) -> dict[str, Any]:
    """Make the previewed, rectified picture the active reference."""
    try:
        return drafts.activate(draft_id, preview_id)
    except NoSuchDraft as exc:
        raise _missing(exc) from None
    except NoUsableH as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from None
