"""The reference pad: upload, the active one, the stored ones, their pictures."""

from __future__ import annotations

from functools import partial
from pathlib import PurePath
from typing import Annotated, Any, Literal

from fastapi import APIRouter, File, Form, HTTPException, UploadFile, status
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse

from backend.api.deps import Operator, ReferencesDep, RefId, RuntimeDep, Viewer
from backend.api.errors import OPERATOR_ERRORS, VIEWER_ERRORS, errors
from backend.api.schemas import ReferenceSummary
from backend.imaging import TooManyPixels, UnsupportedImage, decode_image
from backend.services.references import NoUsableH
from backend.settings import MAX_PAD_SIZE_M

router = APIRouter(tags=["reference"])

_CHUNK = 1 << 16


async def read_limited(upload: UploadFile, limit: int) -> bytes:
    """The upload's bytes, or 413 as soon as it grows past ``limit``."""
    parts, size = [], 0
    while chunk := await upload.read(_CHUNK):
        size += len(chunk)
        if size > limit:
            raise HTTPException(
                status.HTTP_413_CONTENT_TOO_LARGE,
                f"The file is larger than the limit of {limit / 1e6:g} MB.",
            )
        parts.append(chunk)
    return b"".join(parts)


@router.post(
    "/reference",
    status_code=status.HTTP_201_CREATED,
    dependencies=[Operator],
    response_model=ReferenceSummary,
    responses={**OPERATOR_ERRORS, **errors(413, 415, 422)},
)
async def upload_reference(
    references: ReferencesDep,
    runtime: RuntimeDep,
    file: Annotated[UploadFile, File(description="a top-down picture of the pad")],
    pad_size_m: Annotated[
        float, Form(gt=0, le=MAX_PAD_SIZE_M, allow_inf_nan=False, description="pad width, m")
    ],
) -> dict[str, Any]:
    """Measure the H on the picture and make it the active reference.

    413 over the size limit (bytes, or pixels as the picture's header gives them: nothing
    that large is decoded), 415 not a picture, 422 no usable H (the pipeline's reason).
    The previous reference stays active on any failure.
    """
    limits = runtime.public()
    data = await read_limited(file, int(limits["max_upload_bytes"]))
    if not data:
        raise HTTPException(status.HTTP_415_UNSUPPORTED_MEDIA_TYPE, "The file is empty.")
    name = PurePath(file.filename or "upload").name[:120] or "upload"
    try:
        image = await run_in_threadpool(
            partial(decode_image, max_pixels=int(limits["max_upload_pixels"])), data
        )
    except TooManyPixels as exc:
        raise HTTPException(status.HTTP_413_CONTENT_TOO_LARGE, str(exc)) from None
    except UnsupportedImage as exc:
        raise HTTPException(status.HTTP_415_UNSUPPORTED_MEDIA_TYPE, str(exc)) from None
    try:
        return await run_in_threadpool(references.add, image, name, pad_size_m)
    except NoUsableH as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from exc


@router.get(
    "/reference",
    dependencies=[Viewer],
    response_model=ReferenceSummary,
    responses={**VIEWER_ERRORS, **errors(404)},
)
async def active_reference(references: ReferencesDep) -> dict[str, Any]:
    summary = references.active_summary()
    if summary is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No reference is active.")
    return summary


@router.get(
    "/references",
    dependencies=[Viewer],
    response_model=list[ReferenceSummary],
    responses=VIEWER_ERRORS,
)
def list_references(references: ReferencesDep) -> list[dict[str, Any]]:
    return references.list()


@router.post(
    "/references/{ref_id}/activate",
    dependencies=[Operator],
    response_model=ReferenceSummary,
    responses={**OPERATOR_ERRORS, **errors(404, 410, 422)},
)
def activate(ref_id: RefId, references: ReferencesDep) -> dict[str, Any]:
    try:
        return references.activate(ref_id)
    except KeyError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No reference {ref_id}.") from exc
    except FileNotFoundError as exc:
        raise HTTPException(status.HTTP_410_GONE, str(exc)) from exc
    except NoUsableH as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from exc


@router.get(
    "/references/{ref_id}/image/{kind}",
    dependencies=[Viewer],
    response_class=FileResponse,
    responses={
        200: {"content": {"image/png": {}}, "description": "the picture"},
        **VIEWER_ERRORS,
        **errors(404, 422),
    },
)
def reference_image(
    ref_id: RefId, kind: Literal["original", "threshold", "corners"], references: ReferencesDep
) -> FileResponse:
    path = references.image_path(ref_id, kind)
    if path is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No {kind} picture of reference {ref_id}.")
    return FileResponse(path, media_type="image/png")
