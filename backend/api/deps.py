"""FastAPI dependencies as ``Annotated`` aliases: the services, the operator token.

Routes depend on the services of the running station (``backend.services``), never
on the storage or the station's other parts. The token is the operator's bearer
token (OpenAPI security scheme ``OperatorToken``); viewing needs it (or the view
cookie, :mod:`backend.api.view_sessions`) only when the ``view_requires_token``
setting is on. Routes that change something are checked for the token before their
body is read, by :class:`backend.api.security.StationGuard`; the dependencies here
check again and document it.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Header, HTTPException, Path, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.requests import HTTPConnection

from backend.api.security import token_problem
from backend.api.view_sessions import VIEW_COOKIE, ViewSessions
from backend.missions.manager import MissionManager
from backend.services.abort import AbortService
from backend.services.events import EventLog
from backend.services.flights import FlightService
from backend.services.params import ParamService
from backend.services.perspective import PerspectiveDrafts
from backend.services.references import ReferenceService
from backend.services.runtime import RuntimeSettings
from backend.services.status import StatusService
from backend.services.vehicle import VehicleService
from backend.station import Station

_TOKEN_DOC = "The operator token, printed at start and kept in DATA_DIR/token."

# For the OpenAPI document only: the checks below read the header themselves, so that
# a malformed header gets its own sentence.
operator_scheme = HTTPBearer(auto_error=False, scheme_name="OperatorToken", description=_TOKEN_DOC)
viewer_scheme = HTTPBearer(auto_error=False, scheme_name="ViewerToken", description=_TOKEN_DOC)


def get_station(request: Request) -> Station:
    """The running station of this app (503 while it is not running)."""
    station: Station | None = getattr(request.app.state, "station", None)
    if station is None or not station.started:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, "The station is not running.")
    return station


StationDep = Annotated[Station, Depends(get_station)]


def _events(station: StationDep) -> EventLog:
    return station.events


def _runtime(station: StationDep) -> RuntimeSettings:
    return station.runtime


def _references(station: StationDep) -> ReferenceService:
    return station.references


def _flights(station: StationDep) -> FlightService:
    return station.flights


def _vehicle(station: StationDep) -> VehicleService:
    return station.vehicle


def _missions(station: StationDep) -> MissionManager:
    return station.missions


def _status(station: StationDep) -> StatusService:
    return station.status


def _params(station: StationDep) -> ParamService:
    return station.params


def _abort(station: StationDep) -> AbortService:
    return station.abort


def _perspective(station: StationDep) -> PerspectiveDrafts:
    return station.perspective


EventsDep = Annotated[EventLog, Depends(_events)]
RuntimeDep = Annotated[RuntimeSettings, Depends(_runtime)]
ReferencesDep = Annotated[ReferenceService, Depends(_references)]
FlightsDep = Annotated[FlightService, Depends(_flights)]
VehicleDep = Annotated[VehicleService, Depends(_vehicle)]
MissionsDep = Annotated[MissionManager, Depends(_missions)]
StatusDep = Annotated[StatusService, Depends(_status)]
ParamsDep = Annotated[ParamService, Depends(_params)]
AbortDep = Annotated[AbortService, Depends(_abort)]
PerspectiveDep = Annotated[PerspectiveDrafts, Depends(_perspective)]

# Ids are SQLite integers: anything outside 1..2**63-1 cannot name a row.
_MAX_ID = 2**63 - 1
RefId = Annotated[int, Path(ge=1, le=_MAX_ID, description="a reference's id")]
FlightId = Annotated[int, Path(ge=1, le=_MAX_ID, description="a flight's id")]
RunId = Annotated[int, Path(ge=1, le=_MAX_ID, description="a mission run's id")]


def check_token(expected: str, authorization: str | None) -> None:
    """401 with a sentence unless ``authorization`` is ``Bearer <expected>``."""
    problem = token_problem(expected, authorization)
    if problem is not None:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED, problem, headers={"WWW-Authenticate": "Bearer"}
        )


AuthorizationHeader = Annotated[str | None, Header(include_in_schema=False)]
_OperatorDoc = Annotated[HTTPAuthorizationCredentials | None, Depends(operator_scheme)]
_ViewerDoc = Annotated[HTTPAuthorizationCredentials | None, Depends(viewer_scheme)]


def require_operator(
    station: StationDep, _doc: _OperatorDoc, authorization: AuthorizationHeader = None
) -> None:
    """Commands and uploads: a valid operator token or 401."""
    check_token(station.token, authorization)


def require_viewer(
    request: Request,
    station: StationDep,
    _doc: _ViewerDoc,
    authorization: AuthorizationHeader = None,
) -> None:
    """Viewing: open unless the view_requires_token setting is on; then the token, or
    the view cookie a dashboard got with it (pictures and the 3D view send no header)."""
    if station.runtime.view_requires_token and not view_cookie_ok(request):
        check_token(station.token, authorization)


def view_cookie_ok(connection: HTTPConnection) -> bool:
    """Whether the request (or WebSocket) carries a view cookie this station issued."""
    sessions: ViewSessions | None = getattr(connection.app.state, "view_sessions", None)
    return sessions is not None and sessions.valid(connection.cookies.get(VIEW_COOKIE))


Operator = Depends(require_operator)
Viewer = Depends(require_viewer)
