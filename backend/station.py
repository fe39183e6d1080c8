"""The composition root: builds every part of the ground station, wires them, runs them.

:func:`build_station` makes every part, fully, before anything runs: the database,
the event log, the references (the start-up picture is measured here, so a picture
without an H is refused before a thread starts), the link, the camera, the frame
buses and their consumers, the missions, the 3D view and the status service. The one
thing switched on while building is the stand-in vehicle, when no vehicle is named:
it is the vehicle, not part of the station, and the link needs its address.
:meth:`Station.start` starts the threads; :meth:`Station.stop` stops them, each with
a timeout. The API depends on the services (``backend.api.deps``), never on this.

One frame's way (docs/architecture.md): camera source -> vision worker -> ``results``
bus -> missions (woken by each result), encoder (JPEG + JSON once) -> ``encoded`` bus
-> WebSocket viewers and the recorder; the 3D view feed takes the newest result at
10 Hz.

The test rig is imported here only where the user asks for it, lazily: the stand-in
vehicle (``sim.vehicle``, no ``mavlink`` given) and the simulated camera
(``sim.camera``, ``camera="sim"``); the import contracts allow exactly these two.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from backend.camera import Frame, FrameSource, open_source
from backend.datadir import prepare_data_dir
from backend.encoder import EncodedFrame, FrameEncoder
from backend.framebus import FrameBus
from backend.frames import mount_rotation, vision_hints
from backend.link import LinkEvent, VehicleLink
from backend.missions import Mount
from backend.missions.manager import MissionManager
from backend.recorder import Recorder
from backend.recovery import recover
from backend.services.abort import AbortService
from backend.services.events import EventLog
from backend.services.flights import FlightService
from backend.services.mount_check import MountCheck
from backend.services.params import ParamService
from backend.services.perspective import PerspectiveDrafts
from backend.services.references import ReferenceService
from backend.services.rejections import Rejections
from backend.services.runtime import RuntimeSettings
from backend.services.status import StatusService
from backend.services.vehicle import VehicleService
from backend.settings import Settings, resolve_token
from backend.storage import Storage
from backend.viewer3d import Viewer3D, ViewerFeed
from backend.vision_worker import Processed, VisionWorker
from pipeline import Camera, FrameResult, Reference

APPROACH_MARGIN = 0.8  # missions look for the pad this far under where it is reliably found

log = logging.getLogger(__name__)

VERSION = "0.1.0"


class StandIn(Protocol):
    """The running stand-in vehicle, as far as the station cares."""

    address: str

    def stop(self) -> None: ...

    def truth(self) -> Any: ...


@dataclass(eq=False)
class Station:
    """Every part of the ground station, built and wired. ``start()``, use, ``stop()``."""

    settings: Settings
    data_dir: Path
    token: str
    token_path: Path | None
    storage: Storage
    events: EventLog
    runtime: RuntimeSettings
    references: ReferenceService
    stand_in: StandIn | None
    link: VehicleLink
    vehicle: VehicleService
    camera: Camera
    source: FrameSource
    results: FrameBus[Processed]
    worker: VisionWorker
    encoded: FrameBus[EncodedFrame]
    encoder: FrameEncoder
    recorder: Recorder
    flights: FlightService
    missions: MissionManager
    viewer: Viewer3D | None
    viewer_feed: ViewerFeed | None
    status: StatusService
    rejections: Rejections
    params: ParamService
    abort: AbortService
    perspective: PerspectiveDrafts
    started: bool = False
    _stopped: bool = field(default=False, repr=False)

    @property
    def mavlink_url(self) -> str:
        return self.vehicle.url

    def start(self) -> None:
        """Start every part's threads; on failure, everything is stopped again."""
        try:
            self.link.start()
            self.source.start()
            self.worker.start()
            self.encoder.start()
            self.recorder.start_writer()
            if self.viewer is not None and self.viewer_feed is not None:
                self.viewer.start()
                self.viewer_feed.start()
            self.status.start()
        except BaseException:
            self.stop()
            raise
        self.started = True

    def stop(self) -> None:
        """Stop every part (each with a timeout), the stand-in, the database; idempotent."""
        if self._stopped:
            return
        self._stopped = True
        self.started = False
        parts = (
            ("status", self.status.close),
            ("3D view feed", self.viewer_feed.close if self.viewer_feed else None),
            # A running mission is aborted while the link is still up.
            ("missions", self.missions.close),
            ("vision worker", self.worker.close),
            ("encoder", self.encoder.close),
            ("recorder", self.recorder.close),
            ("camera", self.source.close),
            ("3D view", self.viewer.close if self.viewer else None),
            ("verifier training", self.references.close),
            ("link", self.link.close),
            ("stand-in vehicle", self.stand_in.stop if self.stand_in else None),
            ("storage", self.storage.close),
        )
        for name, close in parts:
            if close is None:
                continue
            try:
                close()
            except Exception:
                log.exception("stopping the %s failed", name)


def build_station(settings: Settings) -> Station:
    """Build every part of the station (nothing runs yet but the stand-in vehicle).

    Raises what a bad start-up input raises (e.g. ``NoUsableH`` for a reference
    picture without an H), after closing whatever was built.
    """
    with contextlib.ExitStack() as undo:
        data_dir = prepare_data_dir(settings.data_dir)
        token, token_path = resolve_token(settings)
        storage = Storage(data_dir / "visland.db")
        undo.callback(storage.close)
        events = EventLog(storage)
        tlog_dir = data_dir / "tlogs"
        # What a crash of the last run left open is closed before anything runs.
        recover(storage, tlog_dir=tlog_dir, emit=events.emit)
        references = ReferenceService(
            storage, data_dir / "references", events, verifier_views=settings.verifier_views
        )
        undo.callback(references.close)
        references.load_initial(settings.reference, settings.pad_size)

        stand_in = None
        url = settings.mavlink or ""
        if settings.mavlink is None:
            stand_in = _start_stand_in(settings)
            undo.callback(stand_in.stop)
            url = stand_in.address
        runtime = RuntimeSettings(settings, storage, events, mavlink_url=url)
        link = VehicleLink(
            url,
            tlog_dir=tlog_dir,
            signing_key=bytes.fromhex(settings.signing_key) if settings.signing_key else None,
            heartbeat_timeout_s=settings.link_timeout_s,
            command_timeout_s=settings.command_timeout_s,
        )
        # The camera's mount as the station is told it, which the operator may set anew
        # while it runs: the hints follow it frame by frame, the missions from their
        # start, the mount check and the 3D view at once.
        vehicle = VehicleService(
            link,
            settings,
            url=url,
            mount=lambda: Mount(rotation=runtime.mount_rotation),
            # (the worker, started below, before any request can ask)
            approach_alt=lambda: approach_altitude(references.current(), worker.camera_seen()),
        )

        camera = _camera_model(settings)
        # (the simulated camera sits where it was put at start; a mount set later is the
        # station's belief, which the mount check weighs against the pixels)
        true_mount = settings.sim_camera_mount or runtime.camera_mount
        source = _open_camera(settings, camera, mount_rotation(*true_mount), link, stand_in)
        results: FrameBus[Processed] = FrameBus("results")

        def hints(frame: Frame) -> dict[str, Any]:
            # The pad lies level and faces a known heading: the vehicle's attitude
            # tells the pipeline which of the pad's twin and tilted poses is right. The
            # attitude when the frame was taken: the vehicle has tilted on since.
            att = link.attitude_at(frame.t_capture)
            if att is None:
                return {}
            return vision_hints(settings.pad_heading_deg, *att, runtime.mount_rotation)

        mount_check = MountCheck(events.emit, runtime.camera_mount)

        runtime.listen(
            lambda changes: (
                mount_check.set_mount(runtime.camera_mount)
                if "camera_mount_deg" in changes
                else None
            )
        )

        def process(*args: Any, **kwargs: Any) -> FrameResult:
            result = references.process(*args, **kwargs)
            mount_check.observe(result)  # (the mount set, against the pad's pixels)
            return result

        worker = VisionWorker(
            source,
            results,
            reference=references.current,
            camera=camera,
            process=process,
            hints=hints,
        )
        encoded: FrameBus[EncodedFrame] = FrameBus("encoded")
        encoder = FrameEncoder(
            results.subscribe("encoder"), encoded, jpeg_quality=lambda: runtime.jpeg_quality
        )
        recorder = Recorder(
            data_dir / "flights",
            storage,
            encoded,
            tlog_dir=tlog_dir,
            record_frames=lambda: runtime.record_frames,
            on_event=events.emit,
        )
        flights = FlightService(storage, recorder)
        missions = MissionManager(link, results, storage, events.emit)

        viewer = viewer_feed = None
        if settings.viser_port:
            active = references.active
            assert active is not None  # load_initial made one active
            viewer = Viewer3D(
                "127.0.0.1",  # loopback only: browsers come through the station's guard
                settings.viser_port,
                pad_image_bgr=active.reference.image,
                pad_size_m=active.reference.pad_size_m,
                pad_ned=(settings.pad_north, settings.pad_east),
                pad_heading_deg=settings.pad_heading_deg,
                camera_hfov_deg=camera.hfov_deg,
                aspect=camera.width / camera.height,
                mount_rotation=runtime.mount_rotation,
            )
            viewer_feed = ViewerFeed(viewer, lambda: link.telemetry, results)
            shown = viewer
            references.listen(lambda a: shown.set_pad(a.reference.image, a.reference.pad_size_m))
            runtime.listen(
                lambda changes: (
                    shown.set_mount(runtime.mount_rotation)
                    if "camera_mount_deg" in changes
                    else None
                )
            )

        rejections = Rejections()
        status = StatusService(
            vehicle=vehicle,
            source=source,
            worker=worker,
            missions=missions,
            references=references,
            flights=flights,
            viser_url=None if viewer is None else viewer.url,
            rejections=rejections,
        )
        params = ParamService(
            link,
            events,
            latency_ms=lambda: worker.stats.to_dict().get("latency_ms"),
        )
        link.subscribe(params.on_link_event)
        abort = AbortService(link, missions, events)
        perspective = PerspectiveDrafts(data_dir / "references" / "drafts", references)
        # Whoever sees an event (a flight, a mission's state, the link) then reads a
        # status that shows it; a mission's live state moves the status on its own.
        events.before_each(status.refresh_now)
        missions.listen(lambda _snapshot: status.refresh())
        references.listen(lambda _active: status.refresh())
        link.subscribe(_link_event_handler(events, flights))
        undo.pop_all()
    return Station(
        settings=settings,
        data_dir=data_dir,
        token=token,
        token_path=token_path,
        storage=storage,
        events=events,
        runtime=runtime,
        references=references,
        stand_in=stand_in,
        link=link,
        vehicle=vehicle,
        camera=camera,
        source=source,
        results=results,
        worker=worker,
        encoded=encoded,
        encoder=encoder,
        recorder=recorder,
        flights=flights,
        missions=missions,
        viewer=viewer,
        viewer_feed=viewer_feed,
        status=status,
        rejections=rejections,
        params=params,
        abort=abort,
        perspective=perspective,
    )


def link_event_text(event: LinkEvent) -> str:
    """One line for the event log.

    >>> link_event_text(LinkEvent("link_lost", {"reason": "no heartbeat for 3 s"}))
    'link lost: no heartbeat for 3 s'
    >>> link_event_text(LinkEvent("mode_changed", {"mode": "GUIDED"}))
    'mode changed: GUIDED'
    """
    data = event.data
    if event.kind == "statustext":
        return str(data.get("text", ""))
    if event.kind == "command":
        text = f"{data.get('command', 'command')}: {data.get('result_name', '')}".strip()
        if data.get("reasons"):
            text += " (" + "; ".join(map(str, data["reasons"])) + ")"
        return text
    if event.kind in ("link_up", "link_lost", "link_connecting", "link_closed"):
        reason = data.get("reason")
        return f"link {event.kind.removeprefix('link_')}" + (f": {reason}" if reason else "")
    text = event.kind.replace("_", " ")
    if "mode" in data:
        text += f": {data['mode']}"
    return text


def _link_event_handler(events: EventLog, flights: FlightService) -> Callable[[LinkEvent], None]:
    def on_link_event(event: LinkEvent) -> None:
        flights.on_link_event(event)
        events.emit(event.kind, link_event_text(event), dict(event.data))

    return on_link_event


def approach_altitude(reference: Reference | None, camera: Camera) -> float | None:
    """A margin (APPROACH_MARGIN) under the height up to which ``reference``'s pad is
    reliably found with ``camera``, within 2-30 m; None without a reference.

    >>> from pipeline.render import make_pad_image
    >>> pad = Reference.from_image(make_pad_image(400), 0.55)
    >>> approach_altitude(pad, Camera.from_fov(640, 480, 60.0))
    5.5
    >>> approach_altitude(pad, Camera.from_fov(1280, 720, 60.0))
    11.1
    """
    if reference is None:
        return None
    alt = APPROACH_MARGIN * reference.reliable_altitude_m(camera)
    return round(min(30.0, max(2.0, alt)), 1)


def _camera_model(settings: Settings) -> Camera:
    if settings.camera_calibration is not None:
        return Camera.from_file(settings.camera_calibration)
    return Camera.from_fov(640, 480, settings.camera_hfov_deg)


def _start_stand_in(settings: Settings) -> StandIn:
    # The stand-in is started only when the user named no vehicle (DESIGN.md).
    from sim.vehicle import SimConfig, SimVehicle, VehicleServer

    config = SimConfig(
        seed=settings.sim_seed,
        ready_after_scale=settings.sim_ready_after,
        pad_north=settings.pad_north,
        pad_east=settings.pad_east,
        pad_heading_deg=settings.pad_heading_deg,
        signing_key=bytes.fromhex(settings.signing_key) if settings.signing_key else None,
    )
    # Port 0: the stand-in picks a free loopback port and tells us which.
    server = VehicleServer(SimVehicle(config), "tcp:127.0.0.1:0", speedup=settings.sim_speedup)
    server.start()
    return server


def _open_camera(
    settings: Settings,
    camera: Camera,
    mount: np.ndarray,
    link: VehicleLink,
    stand_in: StandIn | None = None,
) -> FrameSource:
    if settings.camera.partition(":")[0].lower() != "sim":
        return open_source(settings.camera)
    # The simulated camera, when the user asked for it: renders the pad from the stand-in's
    # true pose when it runs here (so vision sees what the vehicle's own estimate gets
    # wrong: what a GPS-denied landing corrects), else from the pose the vehicle reports
    # (LOCAL_POSITION_NED + ATTITUDE, e.g. SITL).
    from sim.camera import SimCamera, SimCameraConfig, VehiclePose

    def vehicle_pose() -> VehiclePose | None:
        if stand_in is not None and link.telemetry.position_ned is not None:
            truth = stand_in.truth()
            return VehiclePose(
                tuple(truth.position_ned), truth.roll, truth.pitch, truth.yaw, time.monotonic()
            )
        tel = link.telemetry
        if tel.position_ned is None or tel.attitude is None:
            return None
        p, a = tel.position_ned, tel.attitude
        t = tel.local_position_rx_monotonic or time.monotonic()
        return VehiclePose((p.x, p.y, p.z), a.roll, a.pitch, a.yaw, t)

    config = SimCameraConfig(
        pad_north_m=settings.pad_north,
        pad_east_m=settings.pad_east,
        pad_heading_deg=settings.pad_heading_deg,
        pad_size_m=settings.pad_size,
        width=camera.width,
        height=camera.height,
        hfov_deg=camera.hfov_deg,
        mount_rotation=mount,
        seed=settings.sim_seed,
    )
    return SimCamera(vehicle_pose=vehicle_pose, config=config)
