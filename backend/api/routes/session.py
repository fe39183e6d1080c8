"""POST/DELETE /api/session: the view cookie for a dashboard that has the token."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, Response

from backend.api.deps import Operator
from backend.api.errors import OPERATOR_ERRORS
from backend.api.schemas import ViewSession
from backend.api.view_sessions import VIEW_COOKIE, ViewSessions

router = APIRouter(tags=["session"])


def _sessions(request: Request) -> ViewSessions:
    sessions: ViewSessions = request.app.state.view_sessions
    return sessions


@router.post(
    "/session", dependencies=[Operator], response_model=ViewSession, responses=OPERATOR_ERRORS
)
def open_session(request: Request, response: Response) -> dict[str, Any]:
    """Set a view cookie (HttpOnly, SameSite=Strict): the dashboard's pictures and 3D
    view may then be seen while viewing needs the token. It never commands anything."""
    sessions = _sessions(request)
    sessions.drop(request.cookies.get(VIEW_COOKIE))
    response.set_cookie(
        VIEW_COOKIE,
        sessions.new(),
        httponly=True,
        samesite="strict",
        secure=request.url.scheme == "https",
        path="/",
    )
    return {"view_cookie": True, "detail": "This browser may view until the station restarts."}


@router.delete(
    "/session", dependencies=[Operator], response_model=ViewSession, responses=OPERATOR_ERRORS
)
def close_session(request: Request, response: Response) -> dict[str, Any]:
    """Forget this browser's view cookie."""
    _sessions(request).drop(request.cookies.get(VIEW_COOKIE))
    response.delete_cookie(VIEW_COOKIE, path="/", httponly=True, samesite="strict")
    return {"view_cookie": False, "detail": "This browser's view cookie is forgotten."}
