"""The WebSocket hub at ``/ws``: one connection per browser, latest-slot senders.

Everything a viewer gets is made once for all of them, off the event loop: the
telemetry and status texts by the status service, the frame message and its JPEGs by
the encoder (the hub's slot on the encoded-frame bus). The loop only hands these to
each client. Each client has one slot per stream (telemetry, status, frame) that holds
only the newest item, plus a short bounded queue of events; a sender task per client
sends what its slots hold when it can. A client that does not read blocks only its
own sender while newer items overwrite its slots (counted as ``replaced``). Nothing
ever waits for a client: not the pipeline, not the link, not the other clients.

The messages are described in :mod:`backend.api.messages`.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from fastapi import WebSocket, WebSocketDisconnect
from starlette.websockets import WebSocketState

from backend.encoder import EncodedFrame
from backend.framebus import Slot
from backend.services.status import Snapshot, to_json
from backend.station import Station
from backend.tokens import tokens_equal

log = logging.getLogger(__name__)

#: How long a socket may stay open without its auth message while viewing needs the token.
AUTH_TIMEOUT_S = 5.0
CLOSE_NORMAL = 1000
CLOSE_UNSUPPORTED = 1003
#: The token was missing, wrong or garbled (like HTTP 401); the dashboard asks for it.
CLOSE_UNAUTHORIZED = 4401
#: No auth message within AUTH_TIMEOUT_S (like HTTP 408).
CLOSE_AUTH_TIMEOUT = 4408
NEED_TOKEN_REASON = 'Viewing needs the operator token: send {"type": "auth", "token": "..."} first.'
WRONG_TOKEN_REASON = "The operator token is wrong."
AUTH_TIMEOUT_REASON = f"No auth message within {AUTH_TIMEOUT_S:g} s."
#: Client messages are small (ping, subscribe, auth): anything longer is garbage.
MAX_MESSAGE_CHARS = 4096
EVENT_BACKLOG = 256


@dataclass(eq=False)
class Client:
    """One browser connection: its latest slots, its event backlog, its counters."""

    ws: WebSocket
    threshold: bool = False
    slots: dict[str, Any] = field(default_factory=dict)
    events: deque[str] = field(default_factory=lambda: deque(maxlen=EVENT_BACKLOG))
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    sent: int = 0
    replaced: int = 0
    sender: asyncio.Task[None] | None = None

    def offer(self, key: str, item: Any) -> None:
        if key in self.slots:
            self.replaced += 1
        self.slots[key] = item
        self.wake.set()

    def push_event(self, text: str) -> None:
        self.events.append(text)
        self.wake.set()

    async def run_sender(self) -> None:
        while True:
            await self.wake.wait()
            self.wake.clear()
            while self.events:
                await self._send_text(self.events.popleft())
            for key in ("telemetry", "status", "frame"):
                item = self.slots.pop(key, None)
                if item is None:
                    continue
                if isinstance(item, EncodedFrame):
                    await self._send_text(item.text)
                    if item.camera_message is not None:
                        await self.ws.send_bytes(item.camera_message)
                    if item.threshold_message is not None and self.threshold:
                        await self.ws.send_bytes(item.threshold_message)
                else:
                    await self._send_text(item)

    async def _send_text(self, text: str) -> None:
        await self.ws.send_text(text)
        self.sent += 1


class Hub:
    """Hands the station's telemetry, status, frames and events to WebSocket clients."""

    def __init__(self, station: Station) -> None:
        self.station = station
        self.clients: set[Client] = set()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._removers: list[Any] = []
        self._frames: Slot[EncodedFrame] | None = None
        # Read by other threads; written only on the loop (never iterate the set there).
        self._client_count = 0

    def _refresh(self) -> None:
        self._client_count = len(self.clients)
        self.station.encoder.threshold_wanted = any(c.threshold for c in self.clients)

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        self._loop = loop
        station = self.station
        self._frames = station.encoded.subscribe(
            "viewers",
            wanted=lambda: self._client_count > 0,
            on_put=lambda: self._soon(self._frame_ready),
        )
        self._removers = [
            station.status.listen(self._on_snapshot),
            station.events.listen(self._on_event),
        ]

    async def stop(self) -> None:
        for remove in self._removers:
            remove()
        self._removers = []
        if self._frames is not None:
            self.station.encoded.unsubscribe(self._frames)
            self._frames = None
        for client in list(self.clients):
            if client.sender is not None:
                client.sender.cancel()

    def stats(self) -> list[dict[str, Any]]:
        return [
            {"sent": c.sent, "replaced": c.replaced, "threshold": c.threshold} for c in self.clients
        ]

    # --- from the station's threads: only hand over ------------------------------------------
    def _soon(self, callback: Any, *args: Any) -> None:
        loop = self._loop
        if loop is None or loop.is_closed() or not self._client_count:
            return
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
            loop.call_soon_threadsafe(callback, *args)

    def _on_snapshot(self, snap: Snapshot) -> None:
        self._soon(self._offer_all, snap.kind, snap.text)

    def _on_event(self, event: dict[str, Any]) -> None:
        if self._client_count:
            self._soon(self._broadcast_event, to_json(event))

    # --- on the loop ---------------------------------------------------------------------------
    def _offer_all(self, key: str, item: Any) -> None:
        for client in self.clients:
            client.offer(key, item)

    def _frame_ready(self) -> None:
        slot = self._frames
        item = None if slot is None else slot.take(0.0)
        if item is not None:
            self._offer_all("frame", item)

    def _broadcast_event(self, text: str) -> None:
        for client in self.clients:
            client.push_event(text)

    def hello(self) -> str:
        """The first message: the state now and what happened before."""
        station = self.station
        return to_json(
            {
                "type": "hello",
                "status": station.status.status.data,
                "telemetry": station.status.telemetry.data,
                "reference": station.references.active_summary(),
                "settings": station.runtime.public(),
                # What happened before this browser (re)connected: the events panel's history.
                "events": station.events.recent(50),
            }
        )

    # --- one connection ------------------------------------------------------------------------
    async def serve(self, ws: WebSocket) -> None:
        """Handle one WebSocket from accept to close.

        When viewing needs the token, the first message must be
        ``{"type": "auth", "token": "..."}`` within :data:`AUTH_TIMEOUT_S`; nothing is
        sent before it. Otherwise the state goes out at once, and an ``auth`` message
        (the dashboard sends one whenever it has a token) is checked all the same.
        """
        await ws.accept()
        if self.station.runtime.view_requires_token:
            refusal = await self._authenticate(ws)
            if refusal is not None:
                await self._refuse(ws, *refusal)
                return
        client = Client(ws)
        client.events.append(self.hello())
        client.wake.set()
        self.clients.add(client)
        self._refresh()
        client.sender = asyncio.create_task(client.run_sender())
        close: tuple[int, str] | None = None
        try:
            close = await self._receive(client)
        except WebSocketDisconnect:
            pass
        except Exception:
            log.exception("websocket receive failed")
        finally:
            self.clients.discard(client)
            self._refresh()
            client.sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await client.sender
        if close is not None:
            await self._refuse(ws, *close)

    async def _refuse(self, ws: WebSocket, code: int, reason: str) -> None:
        """Count and close (nothing else: a flood of garbage is a counter, not a log)."""
        self.station.rejections.socket(reason)
        if ws.application_state == WebSocketState.CONNECTED:
            with contextlib.suppress(Exception):
                await ws.close(code=code, reason=reason[:120])

    async def _authenticate(self, ws: WebSocket) -> tuple[int, str] | None:
        """None when the first message is a valid auth message, else the close."""
        try:
            message = await asyncio.wait_for(ws.receive(), AUTH_TIMEOUT_S)
        except TimeoutError:
            return CLOSE_AUTH_TIMEOUT, AUTH_TIMEOUT_REASON
        if message["type"] == "websocket.disconnect":
            return CLOSE_NORMAL, "left before authenticating"
        return self._check_auth(_parse(message.get("text")))

    def _check_auth(self, data: dict[str, Any] | str) -> tuple[int, str] | None:
        if isinstance(data, str) or data.get("type") != "auth":
            return CLOSE_UNAUTHORIZED, NEED_TOKEN_REASON
        token = data.get("token")
        if not isinstance(token, str) or not tokens_equal(token, self.station.token):
            return CLOSE_UNAUTHORIZED, WRONG_TOKEN_REASON
        return None

    async def _receive(self, client: Client) -> tuple[int, str] | None:
        """Read client messages until it leaves; a close (code, reason) on garbage."""
        ws = client.ws
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return None
            if message.get("text") is None:
                return CLOSE_UNSUPPORTED, "Binary messages are not accepted; send JSON text."
            data = _parse(message["text"])
            if isinstance(data, str):
                return CLOSE_UNSUPPORTED, data
            kind = data["type"]
            if kind == "ping":
                client.push_event('{"type":"pong"}')
            elif kind == "subscribe":
                threshold = data.get("threshold", client.threshold)
                if not isinstance(threshold, bool):
                    return CLOSE_UNSUPPORTED, "'threshold' in a subscribe message must be a bool."
                client.threshold = threshold
                self._refresh()
            elif kind == "auth":
                refusal = self._check_auth(data)
                if refusal is not None:
                    return refusal
            else:
                shown = kind[:40].encode("ascii", "backslashreplace").decode()
                return CLOSE_UNSUPPORTED, f"Unknown message type {shown!r}."


def _parse(text: str | None) -> dict[str, Any] | str:
    """A client message as a dict with a string ``type``, or why it is not one."""
    if text is None:
        return "Binary messages are not accepted; send JSON text."
    if len(text) > MAX_MESSAGE_CHARS:
        return f"Messages are at most {MAX_MESSAGE_CHARS} characters."
    try:
        data = json.loads(text)
    except (ValueError, RecursionError):
        data = None
    if not isinstance(data, dict) or not isinstance(data.get("type"), str):
        return "Messages must be JSON objects with a 'type'."
    return data
