"""The HTTP contract: a pydantic model for every response (and every error body).

These models are the source of the OpenAPI document, from which ``make types``
generates the dashboard's TypeScript types (``frontend/src/lib/api-types.ts``).
The WebSocket's messages are in :mod:`backend.api.messages`. Numbers that may be
non-finite inside the station are ``null`` on the wire.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

Point = tuple[float, float]


class Model(BaseModel):
    """Base of the contract's models: unknown fields are an error (the contract is whole)."""

    model_config = ConfigDict(extra="forbid")


# --- errors and commands ------------------------------------------------------------------
class ErrorResponse(Model):
    """Every error answer: one sentence for the operator."""

    detail: str = Field(description="what went wrong, in one sentence")


class CommandResult(Model):
    """What became of one vehicle command (also the body of its error answers)."""

    ok: bool = Field(description="accepted by the vehicle (or, unacknowledged, sent)")
    command: str
    result: int | None = Field(description="the COMMAND_ACK's MAV_RESULT, if one came")
    result_name: str = Field(
        description="ACCEPTED, FAILED, ... or LINK_DOWN, TIMEOUT, INVALID_ARGUMENT, SENT, "
        "SEND_FAILED, MISMATCH, STARTED, ABORTED"
    )
    reasons: list[str] = Field(description="the vehicle's own refusal texts, verbatim")
    detail: str = Field(description="one sentence for the operator")
    elapsed_s: float = 0.0


class ViewSession(Model):
    """Whether this browser holds a view cookie now (``POST``/``DELETE /api/session``)."""

    view_cookie: bool
    detail: str


class Health(Model):
    ok: bool
    version: str


# --- telemetry ----------------------------------------------------------------------------
class Attitude(Model):
    roll: float | None
    pitch: float | None
    yaw: float | None
    rollspeed: float | None
    pitchspeed: float | None
    yawspeed: float | None


class Vec3(Model):
    x: float | None
    y: float | None
    z: float | None


class GlobalPosition(Model):
    lat_deg: float | None
    lon_deg: float | None
    alt_msl_m: float | None


class GpsStatus(Model):
    fix_type: int
    satellites: int | None
    hdop: float | None


class EkfStatus(Model):
    flags: int
    healthy: bool
    pos_horiz_ok: bool


class Battery(Model):
    voltage_v: float | None
    current_a: float | None
    remaining_pct: int | None


class StatusText(Model):
    time: float
    severity: int
    text: str


class LandingTargetSent(Model):
    x: float | None
    y: float | None
    z: float | None
    distance: float | None
    time_usec: float | None
    sent_monotonic: float | None


LinkStateName = Literal["connecting", "up", "lost", "closed"]


class Telemetry(Model):
    """The link's telemetry snapshot (``backend.link.Telemetry``); null until reported."""

    state: LinkStateName
    vehicle_sysid: int | None
    armed: bool
    mode: str | None
    mode_number: int | None
    system_status: int | None
    attitude: Attitude | None
    position_ned: Vec3 | None
    velocity_ned: Vec3 | None
    relative_alt_m: float | None
    global_position: GlobalPosition | None
    heading_deg: float | None
    gps: GpsStatus | None
    ekf: EkfStatus | None
    battery: Battery | None
    rangefinder_m: float | None
    prearm_ok: bool | None
    statustexts: list[StatusText]
    msgs_per_s: float | None
    crc_errors: int
    heartbeat_age_s: float | None
    packets_lost_pct: float | None
    handler_errors: int
    implausible: int = Field(description="messages dropped: their values cannot be real")
    last_implausible: str | None
    reconnects: int
    last_error: str | None
    attitude_time_boot_ms: int | None
    attitude_rx_monotonic: float | None
    local_position_time_boot_ms: int | None
    local_position_rx_monotonic: float | None
    vehicle_time_boot_ms: int | None = Field(
        description="the vehicle's clock: time_boot_ms of its latest time-stamped message"
    )
    boots: int = Field(description="reboots seen (the vehicle's clock went back)")
    heartbeats: int = Field(description="HEARTBEATs received from the vehicle")
    statustexts_received: int
    state_confirmed: bool = Field(
        description="a HEARTBEAT came after the latest accepted arm/disarm/mode command"
    )
    position_stale: bool = Field(
        description="LOCAL_POSITION_NED stopped coming: position_ned is null until it returns"
    )
    landing_targets_sent: int
    last_landing_target: LandingTargetSent | None


# --- references ---------------------------------------------------------------------------
class VerifierStatus(Model):
    state: Literal["off", "queued", "training", "ready", "unavailable", "failed"]
    progress: float
    detail: str


class ReferenceImages(Model):
    original: str
    threshold: str
    corners: str


class ReferenceSummary(Model):
    id: int
    name: str
    pad_size_m: float
    created: float
    active: bool
    corners_m: list[Point]
    hu: list[float | None]
    orientation_deg: float | None
    eccentricity: float | None
    symmetric: bool
    marks: int = Field(
        description="the pad's other marks found on the picture (rims, rings, bars, stars): "
        "the pose is fitted to their edges too"
    )
    letter_hs: int = Field(
        description="smaller H's in the H's paint (the H of a painted HELIPAD): a frame's H "
        "that reads as one of them is not taken for the pad's"
    )
    outline_share: float | None = Field(
        description="how much of the picture the pad's outer edge (its board against the "
        "floor) spans, where one was found: under 1, the picture shows ground around the "
        "pad, and the pad's size is taken for the whole picture's"
    )
    slant_deg: float | None = Field(
        description="how far the H's parallel sides converge on the picture (degrees): over "
        "a degree or two, the picture was taken at a slant, not straight from above"
    )
    image_size: tuple[int, int]
    images: ReferenceImages
    verifier: VerifierStatus


# --- missions -----------------------------------------------------------------------------
class PadFix(Model):
    """Where the pad was, relative to the vehicle, in one frame."""

    t_capture: float | None
    time_usec: int
    target_frd: list[float | None]
    distance_m: float | None
    offset_ned: list[float | None]
    height_m: float | None
    heading_error_deg: float | None
    image_px: list[float | None]


class Touchdown(Model):
    north_m: float | None
    east_m: float | None
    yaw_deg: float | None
    error_m: float | None
    heading_error_deg: float | None
    source: Literal["truth", "telemetry"]


PrecLandVerdict = Literal["accepted", "failsafe", "silent"]
_PRECLAND_DOC = (
    "plnd runs: did ArduCopter take the targets? accepted ('PrecLand: Target Found' / "
    "'Init Complete'), failsafe ('PrecLand: Failsafe Measures': no backend), silent (said "
    "nothing). A plnd landing that is not accepted ends 'landed_blind'."
)


class MissionSnapshot(Model):
    """A mission's live state (the precision-landing panel)."""

    kind: Literal["hover", "land", "mission"]
    strategy: Literal["plnd", "guided", "extnav"] | None
    state: str
    state_age_s: float
    elapsed_s: float
    outcome: str | None
    message: str
    frames: int
    detections: int
    targets_sent: int
    target_age_s: float | None
    pad_seen_age_s: float | None
    fix: PadFix | None
    image_size: tuple[int, int] | None
    touchdown: Touchdown | None
    precland: PrecLandVerdict | None = Field(default=None, description=_PRECLAND_DOC)
    run_id: int | None
    stored: bool


class MissionCommand(CommandResult):
    """A mission command's answer: the command's shape plus the mission's live state."""

    mission: MissionSnapshot


class MissionRunSummary(Model):
    id: int
    kind: str
    started: float
    ended: float | None
    outcome: str | None
    strategy: str | None
    message: str
    touchdown: Touchdown | None
    duration_s: float | None
    frames: int | None
    detections: int | None
    targets_sent: int | None


class StateChange(Model):
    t: float
    state: str
    reason: str


class MissionRecord(Model):
    """A run's whole record; while it runs only ``strategy`` and ``config`` are there."""

    kind: str | None = None
    strategy: str | None = None
    config: dict[str, Any] = Field(default_factory=dict)
    states: list[StateChange] = Field(default_factory=list)
    targets: list[list[Any]] = Field(
        default_factory=list, description="[t, kind, values...] per target sent"
    )
    targets_sent: int = 0
    frames: int = 0
    detections: int = 0
    notes: list[str] = Field(default_factory=list)
    touchdown: Touchdown | None = None
    precland: PrecLandVerdict | None = Field(default=None, description=_PRECLAND_DOC)
    precland_texts: list[str] = Field(
        default_factory=list, description="ArduCopter's 'PrecLand: ...' texts during the run"
    )
    outcome: str | None = None
    message: str = ""
    duration_s: float | None = None


class MissionRun(Model):
    id: int
    kind: str
    started: float
    ended: float | None
    outcome: str | None
    detail: MissionRecord


# --- flights, status, settings ------------------------------------------------------------
class FlightRef(Model):
    """The flight being recorded: its id and folder."""

    id: int
    dir: str


class FlightSummary(Model):
    id: int
    started: float
    ended: float | None
    frames: int
    reason: str
    end_reason: str | None
    tlog: str = Field(description="URL of its .tlog")
    results: str = Field(description="URL of its results (JSON lines)")
    size_bytes: int = Field(0, description="what its folder takes on disk")


class FlightFrame(Model):
    seq: int
    url: str


class LinkStatus(Model):
    state: LinkStateName
    url: str
    heartbeat_age_s: float | None
    msgs_per_s: float | None
    crc_errors: int
    implausible: int = Field(
        description="telemetry messages dropped because their values cannot be real"
    )


class CameraStatus(Model):
    name: str
    state: Literal["starting", "streaming", "stalled", "error", "closed"]
    fps: float
    frames: int
    errors: int
    last_error: str


class PipelineStatus(Model):
    fps: float
    latency_ms: float | None
    processed: int
    dropped: int
    detected_rate: float
    errors: int
    last_error: str


class Rejected(Model):
    """What the station refused at its edge since it started (counted, never a crash)."""

    requests: int = Field(
        description="HTTP requests refused for their Host, Origin or site, or a token in the URL"
    )
    sockets: int = Field(
        description="WebSockets refused or closed: Host, Origin, a missing or wrong token, "
        "garbage messages"
    )
    last_reason: str


class Status(Model):
    """Link, camera, pipeline, mission, reference, flight and 3D view, in one snapshot."""

    link: LinkStatus
    camera: CameraStatus
    pipeline: PipelineStatus
    mission: MissionSnapshot | None
    reference: ReferenceSummary | None
    flight: FlightRef | None
    viser_url: str | None = Field(
        description="where the dashboard finds the 3D view (a path on this station)"
    )
    rejected: Rejected


class PublicSettings(Model):
    """The settings the operator may change, and the fixed facts of this start."""

    view_requires_token: bool
    record_frames: bool
    jpeg_quality: int
    max_upload_bytes: int
    max_upload_pixels: int
    camera: str
    mavlink: str
    pad_size_m: float
    pad_heading_deg: float
    pad_north_m: float = Field(0.0, description="the pad centre in the local frame (m)")
    pad_east_m: float = 0.0
    camera_hfov_deg: float = Field(60.0, description="the camera's horizontal field of view")
    camera_mount_deg: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0),
        description="how the camera is turned from looking straight down, its picture's top "
        "to the nose: roll, pitch, yaw in degrees, as the vehicle's (--camera-mount)",
    )
    camera_aspect: float = Field(4 / 3, description="image width / height")
    simulated_vehicle: bool


class FlightDeleted(Model):
    id: int
    freed_bytes: int


class ReplayFrame(Model):
    """One processed frame of a recorded flight (UNIX time ``t``)."""

    seq: int
    t: float
    url: str | None = Field(description="its recorded JPEG, if frames were kept")
    detected: bool
    corners_px: list[Point]
    contour_px: list[Point]
    overlay: dict[str, Any] | None
    position_m: list[float] | None
    latency_ms: float | None
    reason: str


class ReplaySample(Model):
    """The vehicle's state at ``t`` (UNIX time), from the flight's .tlog."""

    t: float
    mode: str | None
    armed: bool | None
    n: float | None
    e: float | None
    d: float | None
    roll: float | None
    pitch: float | None
    yaw: float | None
    alt: float | None
    battery_v: float | None


class ReplayText(Model):
    t: float
    severity: int
    text: str


class ReplayState(Model):
    t: float
    state: str
    reason: str


class ReplayMission(Model):
    id: int
    kind: str
    strategy: str | None
    outcome: str | None
    started: float
    ended: float | None
    states: list[ReplayState]


class FlightReplay(Model):
    """A recorded flight as one timeline: frames, telemetry, texts and mission states."""

    id: int
    t0: float
    t1: float
    frames: list[ReplayFrame]
    telemetry: list[ReplaySample]
    texts: list[ReplayText]
    missions: list[ReplayMission]


# --- vehicle parameters, ABORT ------------------------------------------------------------
class ParamInfo(Model):
    """One vehicle parameter, with ArduCopter's documentation where known."""

    name: str
    value: float
    type: int = Field(description="MAV_PARAM_TYPE")
    integer: bool
    description: str
    units: str
    low: float | None
    high: float | None
    values: dict[str, str] = Field(description="the documented choices, value -> meaning")
    reboot: bool = Field(description="takes effect after a reboot")


class ParamListing(Model):
    count: int = Field(description="how many parameters the vehicle says it has")
    received: int
    complete: bool
    fetched_at: float | None
    params: list[ParamInfo]


class ParamWriteResult(Model):
    """A parameter write: what was there, what was asked, what the vehicle said."""

    name: str
    old: float | None
    value: float
    ok: bool
    detail: str


class PrecLandSetup(Model):
    ok: bool
    lag_s: float = Field(description="PLND_LAG written (s)")
    latency_ms: float | None = Field(description="the measured capture -> result latency")
    writes: list[ParamWriteResult]
    reboot: CommandResult | None
    detail: str


class ExtNavSetup(Model):
    """The external-navigation (GPS-denied landing) set-up: what was written, the reboot."""

    ok: bool
    delay_ms: int = Field(description="VISO_DELAY_MS written (ms)")
    latency_ms: float | None = Field(description="the measured capture -> result latency")
    writes: list[ParamWriteResult]
    reboot: CommandResult | None
    detail: str


class BatteryThresholds(Model):
    """The vehicle's BATT_* thresholds (null: no such parameter, or not read yet)."""

    BATT_LOW_VOLT: float | None
    BATT_CRT_VOLT: float | None
    BATT_LOW_MAH: float | None
    BATT_CRT_MAH: float | None
    BATT_CAPACITY: float | None


class SentCommand(Model):
    command: str
    ok: bool
    result_name: str
    detail: str
    reasons: list[str]


class AbortResult(Model):
    """What ABORT did: the mission it stopped and every command it sent."""

    ok: bool
    mission: MissionSnapshot | None
    sent: list[SentCommand]
    detail: str = Field(description="one sentence: what was sent, or why nothing was")


class MissionField(Model):
    name: str
    title: str
    description: str
    default: Any
    kind: Literal["number", "choice"]
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: float | None = None
    unit: str = ""
    choices: list[str] = Field(default_factory=list)
    computed: bool = Field(
        False, description="the default is worked out by the station for its pad and camera"
    )


class MissionDefaults(Model):
    """Every mission parameter the operator may set, with its default and bounds."""

    hover: list[MissionField]
    land: list[MissionField]


# --- a reference from a perspective photo -------------------------------------------------
class PadOutline(Model):
    """The suggested pad outline in the photo's pixels (corners TL, TR, BR, BL)."""

    quad: list[Point]
    ellipse: list[Point] | None = Field(description="the square around a round pad, in view")
    kind: Literal["quad", "ellipse", "h_box"]
    h_box: list[int] | None = Field(description="x, y, w, h of the H-like region found")


class PerspectivePhoto(Model):
    id: str
    name: str
    width: int
    height: int
    photo: str = Field(description="URL of the photo")
    outline: PadOutline


class PerspectivePreview(Model):
    """The rectified picture and what was measured on it; not active until activated."""

    id: str
    draft: str
    pad_size_m: float
    aspect: float
    corners: list[Point]
    image: str = Field(description="URL of the rectified picture")
    corners_image: str = Field(description="URL of it with the H's corners drawn")
    h_corners: int
    symmetric: bool
    detail: str
