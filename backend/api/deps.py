"""FastAPI dependencies as ``Annotated`` aliases: the station, the operator token."""

from __future__ import annotations

import secrets
from typing import Annotated

from fastapi import Depends, Header, HTTPException, Path, Request, status

from backend.station import Station

_BEARER_HINT = (
    "send it as 'Authorization: Bearer <token>' (printed at start, kept in DATA_DIR/token)"
)


def get_station(request: Request) -> Station:
    """The running station of this app."""
    return request.app.state.station


StationDep = Annotated[Station, Depends(get_station)]

# Ids are SQLite integers: anything outside 1..2**63-1 cannot name a row.
_MAX_ID = 2**63 - 1
RefId = Annotated[int, Path(ge=1, le=_MAX_ID, description="a reference's id")]
FlightId = Annotated[int, Path(ge=1, le=_MAX_ID, description="a flight's id")]


def _check_token(station: Station, authorization: str | None) -> None:
    if not authorization:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            f"This needs the operator token: {_BEARER_HINT}.",
            headers={"WWW-Authenticate": "Bearer"},
        )
    scheme, _, token = authorization.partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            f"The Authorization header must be 'Bearer <token>': {_BEARER_HINT}.",
            headers={"WWW-Authenticate": "Bearer"},
        )
    if not secrets.compare_digest(token.strip().encode(), station.token.encode()):
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            "The operator token is wrong; nothing was done.",
            headers={"WWW-Authenticate": "Bearer"},
        )


def require_operator(
    station: StationDep, authorization: Annotated[str | None, Header()] = None
) -> None:
    """Commands and uploads: a valid operator token or 401."""
    _check_token(station, authorization)


def require_viewer(
    station: StationDep, authorization: Annotated[str | None, Header()] = None
) -> None:
    """Viewing: open unless the view_requires_token setting is on."""
    if station.runtime.get("view_requires_token"):
        _check_token(station, authorization)


Operator = Depends(require_operator)
Viewer = Depends(require_viewer)
