"""The reference pad: upload, the active one, the stored ones, their pictures."""

from __future__ import annotations

from pathlib import PurePath
from typing import Annotated, Literal

from fastapi import APIRouter, File, Form, HTTPException, UploadFile, status
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse

from backend.api.deps import Operator, RefId, StationDep, Viewer
from backend.settings import MAX_PAD_SIZE_M
from backend.station import NoUsableH, UnsupportedImage, decode_image

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


@router.post("/reference", status_code=status.HTTP_201_CREATED, dependencies=[Operator])
async def upload_reference(
    station: StationDep,
    file: Annotated[UploadFile, File(description="a top-down picture of the pad")],
    pad_size_m: Annotated[float, Form(gt=0, le=MAX_PAD_SIZE_M, description="pad width, m")],
) -> dict:
    """Measure the H on the picture and make it the active reference.

    413 over the size limit, 415 not a picture, 422 no usable H (the pipeline's reason).
    The previous reference stays active on any failure.
    """
    data = await read_limited(file, station.settings.max_upload_bytes)
    if not data:
        raise HTTPException(status.HTTP_415_UNSUPPORTED_MEDIA_TYPE, "The file is empty.")
    name = PurePath(file.filename or "upload").name[:120] or "upload"
    try:
        image = await run_in_threadpool(decode_image, data)
    except UnsupportedImage as exc:
        raise HTTPException(status.HTTP_415_UNSUPPORTED_MEDIA_TYPE, str(exc)) from exc
    try:
        return await run_in_threadpool(station.add_reference, image, name, pad_size_m)
    except NoUsableH as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from exc


@router.get("/reference", dependencies=[Viewer])
def active_reference(station: StationDep) -> dict:
    summary = station.reference_summary()
    if summary is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No reference is active.")
    return summary


@router.get("/references", dependencies=[Viewer])
def list_references(station: StationDep) -> list[dict]:
    return station.list_references()


@router.post("/references/{ref_id}/activate", dependencies=[Operator])
def activate(ref_id: RefId, station: StationDep) -> dict:
    try:
        return station.activate_reference(ref_id)
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
    responses={200: {"content": {"image/png": {}}}},
)
def reference_image(
    ref_id: RefId, kind: Literal["original", "threshold", "corners"], station: StationDep
) -> FileResponse:
    path = station.reference_image_path(ref_id, kind)
    if path is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No {kind} picture of reference {ref_id}.")
    return FileResponse(path, media_type="image/png")
