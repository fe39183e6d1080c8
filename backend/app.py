"""The FastAPI application: ``create_app(settings)`` makes it, its lifespan runs the station.

The lifespan builds the station (``backend.station.build_station``) and starts it,
off the event loop. Routes live under ``/api`` (one router per resource), the
WebSocket at ``/ws``, the 3D view at ``/view3d/`` (:mod:`backend.api.view3d`), the
OpenAPI docs at ``/docs`` (the document, with the WebSocket's messages, from
:mod:`backend.api.openapi`) and the built dashboard (``frontend/dist``) at ``/``.
Every request passes the guard of :mod:`backend.api.security` first (Host, Origin,
site, no token in URLs, the operator token before any body is read). Every error is
``{"detail": "<sentence>"}``; invalid input is a 422 with a sentence, never a 500.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
from fastapi import FastAPI, Request, WebSocket
from fastapi.exceptions import RequestValidationError
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from backend.api.docs import install_docs
from backend.api.openapi import install_openapi
from backend.api.routes import (
    abort,
    flights,
    health,
    missions,
    params,
    perspective,
    reference,
    replay,
    session,
    status,
    telemetry,
    vehicle,
)
from backend.api.routes import settings as settings_routes
from backend.api.security import SiteRules, StationGuard, install_log_redaction
from backend.api.view3d import install_view3d
from backend.api.view_sessions import ViewSessions
from backend.api.ws import Hub
from backend.settings import Settings, get_settings
from backend.station import VERSION, Station, build_station

log = logging.getLogger(__name__)

FRONTEND_DIST = Path(__file__).resolve().parent.parent / "frontend" / "dist"
#: How uvicorn must serve the app (``python -m backend serve``, the tests, the benches).
#: No per-message deflate on the WebSocket: its compressor is per connection, so every
#: JPEG would be deflated once per viewer (for nothing: JPEG does not shrink) on the
#: event loop, which then has no time left for the API.
#: Client messages to /ws are small; the 3D view's (camera moves) too.
SERVER_OPTIONS: dict[str, object] = {"ws_per_message_deflate": False, "ws_max_size": 1 << 20}

# Multipart framing around the file: what an upload may carry beyond the file itself.
_MULTIPART_SLACK = 64 * 1024


class UploadLimit:
    """Refuse request bodies over the upload limit with 413, before they are stored.

    Checks Content-Length up front and counts the bytes of chunked bodies as they come,
    so a huge upload is cut off early instead of being spooled to disk first.
    """

    def __init__(self, app: ASGIApp, limit: int) -> None:
        self.app, self.limit = app, limit + _MULTIPART_SLACK

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] not in ("POST", "PUT"):
            await self.app(scope, receive, send)
            return
        for name, value in scope.get("headers", []):
            if name == b"content-length":
                try:
                    too_big = int(value) > self.limit
                except ValueError:
                    too_big = False
                if too_big:
                    await self._refuse(send)
                    return
        seen = 0
        started = False

        async def counting_receive() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.limit:
                    raise _TooLarge(self.limit - _MULTIPART_SLACK)
            return message

        async def tracking_send(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, counting_receive, tracking_send)
        except _TooLarge:
            if not started:
                await self._refuse(send)

    async def _refuse(self, send: Send) -> None:
        limit_mb = (self.limit - _MULTIPART_SLACK) / 1e6
        response = JSONResponse(
            {"detail": f"The upload is larger than the limit of {limit_mb:g} MB."},
            status_code=413,
        )
        await response({"type": "http"}, _empty_receive, send)


class _TooLarge(StarletteHTTPException):
    """Raised from ``receive`` inside a route: FastAPI passes HTTPExceptions through."""

    def __init__(self, limit: int) -> None:
        super().__init__(413, f"The upload is larger than the limit of {limit / 1e6:g} MB.")


async def _empty_receive() -> Message:
    return {"type": "http.disconnect"}


def _sentence(exc: RequestValidationError) -> str:
    """One readable sentence from pydantic's list of errors."""
    parts = []
    for err in exc.errors():
        kind = err.get("type", "")
        loc = [str(p) for p in err.get("loc", ()) if p not in ("body", "query", "path", "header")]
        where = ".".join(loc)
        if kind == "json_invalid":
            parts.append("The request body is not valid JSON")
            continue
        if kind == "missing" and not where:
            parts.append("A JSON body is required")
            continue
        msg = str(err.get("msg", "is invalid")).removeprefix("Value error, ")
        parts.append(f"{where}: {msg}" if where else msg)
    text = "; ".join(dict.fromkeys(parts)) or "The request is invalid"
    return f"Invalid input: {text}."


def create_app(settings: Settings | None = None, *, station: Station | None = None) -> FastAPI:
    """Make the app; the station (built here from ``settings`` unless given) runs with
    the app's lifespan. Making the app starts nothing (``app.openapi()`` works alone)."""
    settings = settings or get_settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        # Building and starting open sockets and threads (a second or so): off the loop.
        running: Station = (
            station
            if station is not None
            else await anyio.to_thread.run_sync(build_station, settings)
        )
        await anyio.to_thread.run_sync(running.start)
        install_log_redaction(running.token)
        app.state.station = running
        hub = Hub(running)
        app.state.hub = hub
        await hub.start()
        try:
            yield
        finally:
            await hub.stop()
            await anyio.to_thread.run_sync(running.stop)

    app = FastAPI(
        title="Visland ground station",
        version=VERSION,
        description="Lands an ArduCopter on an 'H' helipad by machine vision.",
        lifespan=lifespan,
        docs_url=None,  # served offline by backend.api.docs
        redoc_url=None,
    )
    app.state.station = None
    app.state.settings = settings
    app.state.view_sessions = ViewSessions()
    app.add_middleware(UploadLimit, limit=settings.max_upload_bytes)
    # Added last, so it runs first: nothing reaches a route (or reads a body) before it.
    app.add_middleware(
        StationGuard,
        rules=SiteRules.for_station(
            settings.host, settings.allowed_hosts, settings.allowed_origins
        ),
        station=lambda: app.state.station,
    )

    @app.exception_handler(RequestValidationError)
    async def invalid_input(request: Request, exc: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": _sentence(exc)}, status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        detail = exc.detail if isinstance(exc.detail, str) else str(exc.detail)
        return JSONResponse(
            {"detail": detail}, status_code=exc.status_code, headers=getattr(exc, "headers", None)
        )

    @app.exception_handler(Exception)
    async def unexpected(request: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error on %s %s", request.method, request.url.path)
        return JSONResponse(
            {"detail": f"Internal error ({type(exc).__name__}); see the server log."},
            status_code=500,
        )

    for module in (
        health,
        status,
        telemetry,
        reference,
        vehicle,
        flights,
        replay,
        missions,
        abort,
        params,
        perspective,
        settings_routes,
        session,
    ):
        app.include_router(module.router, prefix="/api")

    @app.websocket("/ws")
    async def websocket(ws: WebSocket) -> None:
        await app.state.hub.serve(ws)

    install_view3d(app)
    install_openapi(app)
    install_docs(app, FRONTEND_DIST)

    if (FRONTEND_DIST / "index.html").is_file():
        app.mount("/", StaticFiles(directory=FRONTEND_DIST, html=True), name="dashboard")
    else:

        @app.get("/", include_in_schema=False)
        def no_dashboard() -> HTMLResponse:
            return HTMLResponse(
                "<!doctype html><title>Visland</title><h1>Visland ground station</h1>"
                "<p>The dashboard is not built: run <code>cd frontend && npm ci && "
                "npm run build</code>, then reload. The API is live: "
                '<a href="/docs">/docs</a>.</p>'
            )

    return app
