"""The 3D view on the station's own port: viser's page and its WebSocket, proxied.

viser serves its page and scene on a loopback port of its own, which closes every
WebSocket that does not come from here (``backend.viewer3d``). Browsers get the page at
``/view3d/`` and the scene at ``/view3d`` (where viser's page connects: its own address
as a WebSocket URL), behind the station's guard (Host, Origin, site) and, while viewing
needs the token, the view cookie (``POST /api/session``), as the dashboard's
pictures are. The proxy copies messages both ways as they are, with viser's own
subprotocol (its version check).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from pathlib import Path
from typing import Any

from fastapi import FastAPI, HTTPException, Request, WebSocket, WebSocketDisconnect, status
from fastapi.responses import HTMLResponse, RedirectResponse
from starlette.websockets import WebSocketState

from backend.api.deps import require_viewer, view_cookie_ok
from backend.viewer3d import PROXY_HEADER, VIEW_PATH, Viewer3D

log = logging.getLogger(__name__)

#: viser's scene messages (meshes, the pad's picture) can be large.
MAX_MESSAGE_BYTES = 50 * 1024 * 1024
CONNECT_TIMEOUT_S = 5.0
_page_cache: dict[Path, bytes] = {}


def _viewer(app: Any) -> Viewer3D | None:
    station = getattr(app.state, "station", None)
    return None if station is None else station.viewer


def _viser_page() -> bytes:
    import viser

    path = Path(viser.__file__).resolve().parent / "client" / "build" / "index.html"
    if path not in _page_cache:
        _page_cache[path] = path.read_bytes()
    return _page_cache[path]


def install_view3d(app: FastAPI) -> None:
    """Add ``/view3d/`` (the page) and ``/view3d`` (its WebSocket) to ``app``."""
    base = VIEW_PATH.rstrip("/")

    @app.get(base, include_in_schema=False)
    def view3d_redirect() -> RedirectResponse:
        return RedirectResponse(VIEW_PATH, status_code=status.HTTP_307_TEMPORARY_REDIRECT)

    @app.get(VIEW_PATH, include_in_schema=False)
    def view3d_page(request: Request) -> HTMLResponse:
        station = getattr(request.app.state, "station", None)
        if station is None or station.viewer is None:
            raise HTTPException(status.HTTP_404_NOT_FOUND, "The 3D view is off on this station.")
        require_viewer(request, station, None, request.headers.get("authorization"))
        return HTMLResponse(_viser_page(), headers={"Cache-Control": "no-cache"})

    @app.websocket(base)
    async def view3d_socket(ws: WebSocket) -> None:
        await proxy(ws)


async def proxy(ws: WebSocket) -> None:
    """Copy one browser WebSocket to viser's port and back, until either side closes."""
    import websockets
    from websockets.asyncio.client import connect
    from websockets.typing import Subprotocol

    station = getattr(ws.app.state, "station", None)
    viewer = _viewer(ws.app)
    port = None if viewer is None else viewer.bound_port
    if station is None or viewer is None or port is None:
        await ws.close(1008, "The 3D view is off on this station.")  # refused: HTTP 403
        return
    if station.runtime.view_requires_token and not view_cookie_ok(ws):
        station.rejections.socket("3D view without the view cookie")
        # Refused before it opens (HTTP 403): the cookie is known at the handshake.
        await ws.close(1008, "Viewing needs the operator token: sign in first.")
        return
    offered = [p for p in ws.scope.get("subprotocols", []) if p.startswith("viser-v")][:1]
    try:
        upstream = await asyncio.wait_for(
            connect(
                f"ws://127.0.0.1:{port}/",
                subprotocols=[Subprotocol(p) for p in offered] or None,
                additional_headers={PROXY_HEADER: viewer.proxy_secret},
                compression=None,
                max_size=MAX_MESSAGE_BYTES,
                open_timeout=CONNECT_TIMEOUT_S,
            ),
            CONNECT_TIMEOUT_S,
        )
    except (OSError, TimeoutError, websockets.exceptions.WebSocketException) as exc:
        log.warning("the 3D view's server did not take the connection: %s", exc)
        await ws.close(1011, "The 3D view's server is not answering.")
        return
    await ws.accept(subprotocol=upstream.subprotocol)

    async def browser_to_viser() -> None:
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            data = message.get("bytes")
            await upstream.send(data if data is not None else message.get("text") or "")

    async def viser_to_browser() -> None:
        async for data in upstream:
            if isinstance(data, bytes):
                await ws.send_bytes(data)
            else:
                await ws.send_text(data)

    tasks = [asyncio.create_task(browser_to_viser()), asyncio.create_task(viser_to_browser())]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(
                asyncio.CancelledError,
                WebSocketDisconnect,
                RuntimeError,
                websockets.exceptions.ConnectionClosed,
            ):
                await task
        with contextlib.suppress(Exception):
            await upstream.close()
        if ws.application_state == WebSocketState.CONNECTED:
            with contextlib.suppress(Exception):
                await ws.close(1000)
