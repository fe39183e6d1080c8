"""The documented error answers: every one is ``{"detail": "<sentence>"}`` (ErrorResponse),
except a vehicle command's, which is the whole CommandResult with its ``detail``."""

from __future__ import annotations

from typing import Any

from backend.api.schemas import CommandResult, ErrorResponse

_MEANING = {
    401: "The operator token is missing or wrong.",
    404: "No such thing.",
    409: "Refused: the vehicle said no (its reasons verbatim), or the state forbids it.",
    410: "Stored, but its files are gone.",
    413: "The upload is larger than the limit (in bytes, or in pixels by its header).",
    415: "The upload is not a picture we can read.",
    422: "The input is invalid (one sentence says why).",
    503: "The link to the vehicle is down, or the station is not running.",
    504: "The vehicle did not acknowledge in time.",
}


def errors(*codes: int) -> dict[int | str, dict[str, Any]]:
    """``responses=`` for a route that may answer with these error codes."""
    return {code: {"model": ErrorResponse, "description": _MEANING[code]} for code in codes}


def command_errors(*codes: int) -> dict[int | str, dict[str, Any]]:
    """``responses=`` for a vehicle command: its errors carry the CommandResult."""
    return {code: {"model": CommandResult, "description": _MEANING[code]} for code in codes}


#: Every route that checks the token may answer 401; every route may answer 503 while
#: the station is not running.
VIEWER_ERRORS = errors(401, 503)
OPERATOR_ERRORS = errors(401, 503)
