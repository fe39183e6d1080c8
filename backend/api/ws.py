"""The WebSocket hub at ``/ws``: one connection per browser, latest-slot senders.

Each client has one slot per stream (telemetry, status, frame) that always holds only
the newest item, plus a short bounded queue of events. A sender task per client sends
what its slots hold when it can; a client that does not read blocks only its own
sender while newer items overwrite the slots (counted as ``replaced``). Nothing ever
waits for a client: not the pipeline, not the link, not the other clients.

The status message also goes out whenever a running mission moves (its ``mission``
field is the live state the precision-landing panel draws), not only once a second.

Binary frames: 4-byte big-endian header length N, N bytes of UTF-8 JSON header
(``kind``, ``seq``, ``t_capture``, ``width``, ``height``), then the JPEG bytes.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import secrets
import struct
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from fastapi import WebSocket, WebSocketDisconnect
from starlette.websockets import WebSocketState

from backend.vision_worker import Processed
from pipeline.moments import hu_distance
from pipeline.preprocess import binarize

if TYPE_CHECKING:
    from backend.station import Station

log = logging.getLogger(__name__)

TELEMETRY_PERIOD_S = 0.1
STATUS_PERIOD_S = 1.0
AUTH_TIMEOUT_S = 5.0
CLOSE_UNSUPPORTED = 1003
CLOSE_POLICY = 1008
EVENT_BACKLOG = 256
HU_COUNT = 2


def pack_binary(header: dict, jpeg: bytes) -> bytes:
    """A binary frame message: length-prefixed JSON header, then the JPEG bytes."""
    head = json.dumps(header, separators=(",", ":")).encode()
    return struct.pack(">I", len(head)) + head + jpeg


def unpack_binary(message: bytes) -> tuple[dict, bytes]:
    """The inverse of :func:`pack_binary` (tests and tools)."""
    if len(message) < 4:
        raise ValueError("message is shorter than its 4-byte length prefix")
    (n,) = struct.unpack_from(">I", message)
    if 4 + n > len(message):
        raise ValueError(f"header length {n} runs past the message's {len(message)} bytes")
    return json.loads(message[4 : 4 + n].decode()), message[4 + n :]


def _project(points_pad: np.ndarray, position_m, R_pad_cam, camera) -> np.ndarray:
    """Pad-frame points (N x 3) to pixels through the pose (camera centre, R_pad_cam)."""
    R = np.asarray(R_pad_cam, float)
    rvec, _ = cv2.Rodrigues(R.T)
    tvec = -R.T @ np.asarray(position_m, float).reshape(3)
    px, _ = cv2.projectPoints(np.asarray(points_pad, float), rvec, tvec, camera.K, camera.dist)
    return px.reshape(-1, 2)


def _finite_list(points: np.ndarray) -> list[list[float]]:
    return [
        [round(float(x), 2), round(float(y), 2)]
        for x, y in np.asarray(points).reshape(-1, 2)
        if np.isfinite(x) and np.isfinite(y)
    ]


def overlay_for(processed: Processed) -> dict:
    """What the dashboard draws over the frame, in the frame's pixels."""
    result, camera, reference = processed.result, processed.camera, processed.reference
    overlay: dict[str, Any] = {
        "contour": _finite_list(result.contour_px),
        "corners": _finite_list(result.corners_px),
        "reference_corners": [],
        "axes": None,
        "target": None,
    }
    pose = result.pose
    if pose is None:
        return overlay
    # Only draw what lies in front of the camera.
    R = np.asarray(pose.R_pad_cam, float)
    pos = np.asarray(pose.position_m, float)
    corners_m = np.asarray(reference.corners_m, float).reshape(-1, 2)
    ref3 = np.column_stack([corners_m, np.zeros(len(corners_m))])
    axis = float(getattr(reference, "pad_size_m", 0.55)) / 2
    axes3 = np.array([[0, 0, 0], [axis, 0, 0], [0, axis, 0], [0, 0, axis]], float)
    depth = (R.T @ (np.vstack([ref3, axes3]) - pos).T)[2]
    if np.any(depth <= 1e-6):
        return overlay
    overlay["reference_corners"] = _finite_list(_project(ref3, pos, R, camera))
    ax = _project(axes3, pos, R, camera)
    if np.all(np.isfinite(ax)):
        o, x, y, z = ([round(float(v), 2) for v in p] for p in ax)
        overlay["axes"] = {"origin": o, "x": x, "y": y, "z": z}
        overlay["target"] = o
    return overlay


def frame_message(processed: Processed) -> dict:
    """The ``frame`` JSON message of one processed frame."""
    frame, result = processed.frame, processed.result
    h, w = frame.image.shape[:2]
    distance = None
    if result.detected and any(result.hu):
        with contextlib.suppress(Exception):
            # Compared as the pipeline compares them: the first two invariants (the H is
            # symmetric under a half turn, so Hu 3..7 are noise around zero).
            d = float(hu_distance(result.hu, processed.reference.hu, count=HU_COUNT))
            distance = d if np.isfinite(d) else None
    return {
        "type": "frame",
        "seq": frame.seq,
        "t_capture": frame.t_capture,
        "latency_ms": round(processed.latency_ms, 2),
        "width": w,
        "height": h,
        "result": result.to_dict(),
        "overlay": overlay_for(processed),
        "reference_distance": distance,
    }


@dataclass(eq=False)
class Client:
    """One browser connection: its latest slots, its event backlog, its counters."""

    ws: WebSocket
    threshold: bool = False
    slots: dict[str, Any] = field(default_factory=dict)
    events: deque = field(default_factory=lambda: deque(maxlen=EVENT_BACKLOG))
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    sent: int = 0
    replaced: int = 0
    sender: asyncio.Task | None = None

    def offer(self, key: str, item: Any) -> None:
        if key in self.slots:
            self.replaced += 1
        self.slots[key] = item
        self.wake.set()

    def push_event(self, message: dict) -> None:
        self.events.append(message)
        self.wake.set()

    async def run_sender(self) -> None:
        while True:
            await self.wake.wait()
            self.wake.clear()
            while self.events:
                await self._send_json(self.events.popleft())
            for key in ("telemetry", "status", "frame"):
                item = self.slots.pop(key, None)
                if item is None:
                    continue
                if key == "frame":
                    text, camera_jpeg, threshold_jpeg = item
                    await self.ws.send_text(text)
                    self.sent += 1
                    if camera_jpeg is not None:
                        await self.ws.send_bytes(camera_jpeg)
                    if threshold_jpeg is not None and self.threshold:
                        await self.ws.send_bytes(threshold_jpeg)
                else:
                    await self._send_json(item)

    async def _send_json(self, message: dict) -> None:
        await self.ws.send_text(json.dumps(message, default=_json_default))
        self.sent += 1


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


class Hub:
    """Fans the station's telemetry, status, frames and events out to WebSocket clients."""

    def __init__(self, station: Station) -> None:
        self.station = station
        self.clients: set[Client] = set()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._tasks: list[asyncio.Task] = []
        self._remove_listener = None
        self.frames_encoded = 0
        # Read by the worker thread; written only on the loop (never iterate the set there).
        self._client_count = 0
        self._threshold_wanted = False

    def _refresh(self) -> None:
        self._client_count = len(self.clients)
        self._threshold_wanted = any(c.threshold for c in self.clients)

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._remove_listener = self.station.add_listener(self._on_station)
        self._tasks = [
            asyncio.create_task(self._tick("telemetry", TELEMETRY_PERIOD_S)),
            asyncio.create_task(self._tick("status", STATUS_PERIOD_S)),
        ]

    async def stop(self) -> None:
        if self._remove_listener is not None:
            self._remove_listener()
            self._remove_listener = None
        for task in self._tasks:
            task.cancel()
        for client in list(self.clients):
            if client.sender is not None:
                client.sender.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        self._tasks = []

    def stats(self) -> list[dict]:
        return [
            {"sent": c.sent, "replaced": c.replaced, "threshold": c.threshold} for c in self.clients
        ]

    # --- from the station's threads -------------------------------------------------------
    def _on_station(self, kind: str, payload: Any) -> None:
        loop = self._loop
        if loop is None or loop.is_closed() or not self._client_count:
            return
        if kind == "event":
            loop.call_soon_threadsafe(self._broadcast_event, payload)
        elif kind == "frame":
            item = self._encode_frame(payload)
            loop.call_soon_threadsafe(self._broadcast_frame, item)
        elif kind == "mission":
            # The live mission state rides in the status message (its "mission" field),
            # sent at once instead of at the next 1 s tick: the precision-landing panel
            # follows the mission at its pace, the latest-value slot keeps it bounded.
            loop.call_soon_threadsafe(self._broadcast_status)

    def _encode_frame(self, processed: Processed) -> tuple[str, bytes | None, bytes | None]:
        # Encoded once per frame for all clients, on the worker's thread (a few ms).
        frame = processed.frame
        h, w = frame.image.shape[:2]
        quality = int(self.station.runtime.get("jpeg_quality", 80))
        text = json.dumps(frame_message(processed), default=_json_default)
        head = {"seq": frame.seq, "t_capture": frame.t_capture, "width": w, "height": h}
        ok, buf = cv2.imencode(".jpg", frame.image, [cv2.IMWRITE_JPEG_QUALITY, quality])
        camera_jpeg = pack_binary({"kind": "camera", **head}, buf.tobytes()) if ok else None
        threshold_jpeg = None
        if self._threshold_wanted:
            mask = binarize(frame.image).mask
            mask = ((np.asarray(mask) > 0).astype(np.uint8)) * 255
            mh, mw = mask.shape[:2]
            ok, buf = cv2.imencode(".jpg", mask, [cv2.IMWRITE_JPEG_QUALITY, quality])
            if ok:
                threshold_jpeg = pack_binary(
                    {"kind": "threshold", **head, "width": mw, "height": mh}, buf.tobytes()
                )
        self.frames_encoded += 1
        return text, camera_jpeg, threshold_jpeg

    def _broadcast_event(self, event: dict) -> None:
        for client in self.clients:
            client.push_event(event)

    def _broadcast_status(self) -> None:
        if not self.clients:
            return
        try:
            message = {"type": "status", **self.station.status()}
        except Exception:
            log.exception("building the status message failed")
            return
        for client in self.clients:
            client.offer("status", message)

    def _broadcast_frame(self, item: tuple) -> None:
        for client in self.clients:
            client.offer("frame", item)

    async def _tick(self, kind: str, period: float) -> None:
        while True:
            await asyncio.sleep(period)
            if not self.clients:
                continue
            try:
                if kind == "telemetry":
                    message = {"type": "telemetry", **self.station.telemetry_dict()}
                else:
                    message = {"type": "status", **self.station.status()}
            except Exception:
                log.exception("building the %s message failed", kind)
                continue
            for client in self.clients:
                client.offer(kind, message)

    # --- one connection -------------------------------------------------------------------
    def hello(self) -> dict:
        station = self.station
        return {
            "type": "hello",
            "status": station.status(),
            "telemetry": station.telemetry_dict(),
            "reference": station.reference_summary(),
            "settings": station.public_settings(),
            # What happened before this browser (re)connected: the events panel's history.
            "events": station.recent_events(50),
        }

    async def serve(self, ws: WebSocket) -> None:
        """Handle one WebSocket from accept to close."""
        await ws.accept()
        station = self.station
        if station.runtime.get("view_requires_token") and not await self._authenticate(ws):
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
        if close is not None and ws.application_state == WebSocketState.CONNECTED:
            with contextlib.suppress(Exception):
                await ws.close(code=close[0], reason=close[1])

    async def _authenticate(self, ws: WebSocket) -> bool:
        token = ws.query_params.get("token")
        if token is None:
            try:
                first = await asyncio.wait_for(ws.receive_text(), AUTH_TIMEOUT_S)
                token = json.loads(first).get("token") if first.startswith("{") else None
            except (
                TimeoutError,
                json.JSONDecodeError,
                AttributeError,
                WebSocketDisconnect,
                KeyError,
                RuntimeError,
            ):
                token = None
        if isinstance(token, str) and secrets.compare_digest(token, self.station.token):
            return True
        with contextlib.suppress(Exception):
            await ws.close(
                code=CLOSE_POLICY,
                reason="Viewing needs the operator token: connect with ?token=<token>.",
            )
        return False

    async def _receive(self, client: Client) -> tuple[int, str] | None:
        """Read client messages until it leaves; a close (code, reason) on garbage."""
        ws = client.ws
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return None
            text = message.get("text")
            if text is None:
                return CLOSE_UNSUPPORTED, "Binary messages are not accepted; send JSON text."
            try:
                data = json.loads(text)
            except json.JSONDecodeError:
                return CLOSE_UNSUPPORTED, "Messages must be JSON objects with a 'type'."
            if not isinstance(data, dict) or not isinstance(data.get("type"), str):
                return CLOSE_UNSUPPORTED, "Messages must be JSON objects with a 'type'."
            kind = data["type"]
            if kind == "ping":
                client.push_event({"type": "pong"})
            elif kind == "subscribe":
                threshold = data.get("threshold", client.threshold)
                if not isinstance(threshold, bool):
                    return CLOSE_UNSUPPORTED, "'threshold' in a subscribe message must be a bool."
                client.threshold = threshold
                self._refresh()
            elif kind == "auth":
                continue  # already authorised (or viewing is open)
            else:
                return CLOSE_UNSUPPORTED, f"Unknown message type {kind[:40]!r}."
