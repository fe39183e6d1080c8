"""The WebSocket contract (``/ws``): every message type either way, as pydantic models.

Server to browser, JSON text: ``hello`` (once, first), ``telemetry`` (10 Hz),
``status`` (1 Hz and whenever a mission moves), ``frame`` (each processed frame),
``event`` (as they happen), ``pong``. Binary: a camera or threshold JPEG behind a
length-prefixed JSON header (:class:`BinaryFrameHeader`). Browser to server, JSON
text: ``auth`` first (the token; required when viewing needs it, closes with 4401 when
missing, wrong or garbled, 4408 when it does not come in time), ``ping``,
``subscribe`` (threshold view on or off). The OpenAPI document carries these models as components
(``backend.api.openapi``), so the dashboard's types come from them too.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import ConfigDict, Field

from backend.api.schemas import (
    Model,
    Point,
    PublicSettings,
    ReferenceSummary,
    Status,
    Telemetry,
)


class Pose(Model):
    """The camera's pose over the pad (``pipeline.Pose``)."""

    position_m: tuple[float, float, float]
    R_pad_cam: list[list[float]]
    yaw_deg: float
    reprojection_px: float
    symmetric: bool
    ambiguous: bool = Field(
        description="another pose, tilted the other way, fits the pixels as well, or "
        "they show the tilt too little to tell it (no attitude to tell them apart)"
    )
    lean_deg: float | None = Field(
        None,
        description="with the vehicle's attitude, how far the pad's pixels alone lean it "
        "from the level the attitude gives (degrees): over a few, frame after frame, the "
        "camera's mount is not the one set, or the pad is not level",
    )
    lean_rotation: list[float] | None = Field(
        None,
        description="that lean as a rotation (camera frame, a rotation vector in radians) "
        "turning down as the attitude gives it onto down as the pad's pixels alone give it",
        min_length=3,
        max_length=3,
    )


class FrameResult(Model):
    """What the pipeline found in one frame (``pipeline.FrameResult``), points in pixels."""

    detected: bool
    corners_px: list[Point]
    hu: list[float | None]
    orientation_deg: float | None
    eccentricity: float | None
    pose: Pose | None
    timings_ms: dict[str, float]
    contour_px: list[Point]
    score: float | None
    reason: str
    found_by: str = Field(
        description='"follow": the H\'s sides fitted again where they were in the last frame; '
        '"track": searched in a window around where the pad was; "search": the whole frame; '
        '"board": the whole frame, a pad too far for its H by its board\'s outline; '
        '"" when nothing was found'
    )


class Axes(Model):
    origin: Point
    x: Point
    y: Point
    z: Point


class Overlay(Model):
    """What the dashboard draws beyond the result's own corners and contour."""

    reference_corners: list[Point] = Field(description="the reference's corners through the pose")
    axes: Axes | None
    target: Point | None = Field(description="where the pad's centre is in the picture")


class HelloMessage(Model):
    type: Literal["hello"]
    status: Status
    telemetry: Telemetry
    reference: ReferenceSummary | None
    settings: PublicSettings
    events: list[EventMessage] = Field(description="what happened before, oldest first")


class TelemetryMessage(Telemetry):
    type: Literal["telemetry"]


class StatusMessage(Status):
    type: Literal["status"]


class FrameMessage(Model):
    type: Literal["frame"]
    seq: int
    t_capture: float
    latency_ms: float = Field(description="capture to result")
    width: int
    height: int
    result: FrameResult
    overlay: Overlay
    reference_distance: float | None = Field(
        description="distance of the frame's Hu invariants from the reference's"
    )


class EventMessage(Model):
    """One event; the event's own data rides along in extra fields."""

    model_config = ConfigDict(extra="allow")

    type: Literal["event"]
    kind: str
    text: str
    t: float = Field(description="UNIX time")


class PongMessage(Model):
    type: Literal["pong"]


ServerMessage = Annotated[
    HelloMessage | TelemetryMessage | StatusMessage | FrameMessage | EventMessage | PongMessage,
    Field(discriminator="type"),
]


class BinaryFrameHeader(Model):
    """The JSON header of a binary message; the JPEG bytes follow it."""

    kind: Literal["camera", "threshold"]
    seq: int
    t_capture: float
    width: int
    height: int


class PingMessage(Model):
    type: Literal["ping"]


class SubscribeMessage(Model):
    type: Literal["subscribe"]
    threshold: bool = Field(description="send the threshold view's JPEGs too")


class AuthMessage(Model):
    """The first message: the operator token (never in the socket's URL)."""

    type: Literal["auth"]
    token: str


ClientMessage = Annotated[PingMessage | SubscribeMessage | AuthMessage, Field(discriminator="type")]

#: Every WebSocket model, for the OpenAPI document's components.
WS_MODELS: tuple[type[Model], ...] = (
    HelloMessage,
    TelemetryMessage,
    StatusMessage,
    FrameMessage,
    EventMessage,
    PongMessage,
    BinaryFrameHeader,
    PingMessage,
    SubscribeMessage,
    AuthMessage,
)

HelloMessage.model_rebuild()
