"""The ground station's runtime: owns the link, camera, vision worker, recorder and 3D view.

``Station(settings).start()`` brings everything up (the in-process ArduCopter stand-in
when no vehicle is named, the simulated camera unless another is named, the default
pad picture unless a reference is given or stored) and ``stop()`` takes it down again,
each part with a timeout. The API layer talks only to this object.

Threads: the link's own, the camera's capture thread, the vision worker, the
recorder's writer, and one monitor here (10 Hz: flight start/stop on arm/disarm, the
3D view); while a mission runs, its own thread (``backend.missions.manager``).
Listeners (the WebSocket hub) get events, processed frames and mission states from
those threads and must hand them over without blocking.
"""

from __future__ import annotations

import hashlib
import logging
import math
import secrets
import shutil
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from backend.camera import FrameSource, open_source
from backend.link import CommandResult, LinkEvent, LinkState, Telemetry, VehicleLink
from backend.missions import LandConfig
from backend.missions.manager import MissionManager
from backend.recorder import Recorder
from backend.settings import Settings, resolve_token
from backend.storage import Storage
from backend.verifier_training import VerifierStatus, VerifierTrainer
from backend.viewer3d import Viewer3D
from backend.vision_worker import Processed, VisionWorker
from pipeline import Camera, FrameResult, Reference, process_frame
from pipeline.render import make_pad_image

log = logging.getLogger(__name__)

VERSION = "0.1.0"
REFERENCE_IMAGES = ("original", "threshold", "corners")
# Settings the operator may change at run time (PUT /api/settings); they persist.
RUNTIME_KEYS = ("view_requires_token", "record_frames", "jpeg_quality")

Listener = Callable[[str, Any], None]


class UnsupportedImage(ValueError):
    """The upload is not a picture we can decode (HTTP 415)."""


class NoUsableH(ValueError):
    """The picture decodes but holds no usable H (HTTP 422, the pipeline's reason)."""


@dataclass(frozen=True)
class ActiveReference:
    id: int
    reference: Reference
    row: dict


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port free on ``host`` right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


_MAGIC = (
    (b"\x89PNG\r\n\x1a\n", "png"),
    (b"\xff\xd8\xff", "jpeg"),
    (b"BM", "bmp"),
    (b"II*\x00", "tiff"),
    (b"MM\x00*", "tiff"),
)


def sniff_image(data: bytes) -> str | None:
    """The picture format by its magic bytes (png, jpeg, bmp, tiff, webp) or ``None``."""
    for magic, kind in _MAGIC:
        if data.startswith(magic):
            return kind
    if len(data) >= 12 and data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return "webp"
    return None


def decode_image(data: bytes) -> np.ndarray:
    """Decode an uploaded picture to BGR; :class:`UnsupportedImage` when it is not one."""
    kind = sniff_image(data)
    if kind is None:
        raise UnsupportedImage("The file is not a picture: expected PNG, JPEG, BMP, TIFF or WebP.")
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if image is None or image.size == 0:
        raise UnsupportedImage(f"The file looks like {kind.upper()} but cannot be decoded.")
    return image


def draw_corners(image_bgr: np.ndarray, corners_px: np.ndarray) -> np.ndarray:
    """The picture with the H's corners marked and numbered in their order."""
    out = image_bgr.copy()
    scale = max(out.shape[:2]) / 800.0
    pts = np.asarray(corners_px, float).reshape(-1, 2)
    cv2.polylines(
        out, [np.round(pts).astype(np.int32)], True, (0, 200, 255), max(1, round(2 * scale))
    )
    for i, (x, y) in enumerate(pts):
        c = (round(x), round(y))
        cv2.circle(out, c, max(3, round(7 * scale)), (0, 0, 255), -1)
        cv2.putText(
            out,
            str(i),
            (c[0] + round(8 * scale), c[1] - round(8 * scale)),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.8 * scale,
            (0, 255, 0),
            max(1, round(2 * scale)),
            cv2.LINE_AA,
        )
    return out


def camera_yaw_in_pad(pad_heading_deg: float, vehicle_yaw_rad: float) -> float:
    """The down-looking camera's yaw in the pad frame (``pipeline.result.yaw_of``), degrees.

    The camera's image top is the vehicle's nose, so its yaw is the pad's heading minus
    the vehicle's (headings turn clockwise, the pad-frame yaw counter-clockwise).
    """
    yaw = float(pad_heading_deg) - math.degrees(float(vehicle_yaw_rad))
    return (yaw + 180.0) % 360.0 - 180.0


class Station:
    """Everything that runs behind the API. Build, ``start()``, use, ``stop()``."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.data_dir = Path(settings.data_dir)
        self.token = ""
        self.token_path: Path | None = None
        self.storage: Storage | None = None
        self.link: VehicleLink | None = None
        self.vehicle_server = None
        self.source: FrameSource | None = None
        self.worker: VisionWorker | None = None
        self.recorder: Recorder | None = None
        self.viewer: Viewer3D | None = None
        self.missions: MissionManager | None = None
        self.trainer: VerifierTrainer | None = None
        self.mavlink_url = settings.mavlink or ""
        self.camera_model: Camera | None = None
        self.runtime: dict[str, Any] = {}
        self._active: ActiveReference | None = None
        self._ref_lock = threading.Lock()
        self._listeners: list[Listener] = []
        self._listen_lock = threading.Lock()
        self._stop = threading.Event()
        self._monitor: threading.Thread | None = None
        self._unsubscribe_link: Callable[[], None] | None = None
        self._was_armed: bool | None = None
        self.started = False

    # --- life cycle ----------------------------------------------------------------------
    def start(self) -> None:
        """Bring every part up; on failure, what was started is stopped again."""
        try:
            self._start()
        except BaseException:
            self.stop()
            raise
        self.started = True

    def _start(self) -> None:
        s = self.settings
        self.data_dir.mkdir(parents=True, exist_ok=True)
        self.token, self.token_path = resolve_token(s)
        self.storage = Storage(self.data_dir / "visland.db")
        self.runtime = self._load_runtime()
        self.trainer = VerifierTrainer(
            lambda ref_id: self._reference_dir() / str(ref_id),
            views=s.verifier_views,
            on_change=self._on_verifier_change,
        )
        self._load_initial_reference()

        if s.mavlink is None:
            self._start_stand_in()
        tlog_dir = self.data_dir / "tlogs"
        self.link = VehicleLink(
            self.mavlink_url,
            tlog_dir=tlog_dir,
            signing_key=bytes.fromhex(s.signing_key) if s.signing_key else None,
            heartbeat_timeout_s=s.link_timeout_s,
            command_timeout_s=s.command_timeout_s,
        )
        self._unsubscribe_link = self.link.subscribe(self._on_link_event)
        self.link.start()

        self.camera_model = self._camera_model()
        self.source = self._open_camera()
        self.source.start()

        self.recorder = Recorder(
            self.data_dir / "flights",
            self.storage,
            tlog_dir=tlog_dir,
            record_frames=lambda: bool(self.runtime["record_frames"]),
            jpeg_quality=lambda: int(self.runtime["jpeg_quality"]),
            on_event=self.emit_event,
        )
        self.worker = VisionWorker(
            self.source,
            reference=self._current_reference,
            camera=self.camera_model,
            process=self._process_frame,
            yaw_hint=self._yaw_hint,
        )
        self.worker.add_sink(self.recorder.submit)
        self.worker.add_sink(self._fan_out_frame)
        self.worker.start()
        self.missions = MissionManager(
            self.link,
            lambda: self.worker.latest if self.worker is not None else None,
            self.storage,
            self.emit_event,
            lambda snapshot: self._notify("mission", snapshot),
        )

        if s.viser_port:
            active = self._active
            self.viewer = Viewer3D(
                s.host,
                s.viser_port,
                pad_image_bgr=active.reference.image if active else make_pad_image(512),
                pad_size_m=active.reference.pad_size_m if active else s.pad_size,
                pad_ned=(s.pad_north, s.pad_east),
                pad_heading_deg=s.pad_heading_deg,
                camera_hfov_deg=self.camera_model.hfov_deg,
                aspect=self.camera_model.width / self.camera_model.height,
            )
            self.viewer.start()

        self._stop.clear()
        self._monitor = threading.Thread(target=self._monitor_loop, name="station", daemon=True)
        self._monitor.start()

    def _start_stand_in(self) -> None:
        # The stand-in is only started when the user named no vehicle (DESIGN.md).
        from sim.vehicle import SimConfig, SimVehicle, VehicleServer

        s = self.settings
        config = SimConfig(
            seed=s.sim_seed,
            ready_after_scale=s.sim_ready_after,
            pad_north=s.pad_north,
            pad_east=s.pad_east,
            pad_heading_deg=s.pad_heading_deg,
            signing_key=bytes.fromhex(s.signing_key) if s.signing_key else None,
        )
        # Port 0: the stand-in picks a free loopback port and tells us which.
        server = VehicleServer(SimVehicle(config), "tcp:127.0.0.1:0", speedup=s.sim_speedup)
        server.start()
        self.vehicle_server = server
        self.mavlink_url = server.address

    def stop(self) -> None:
        """Stop every part (each with a timeout); idempotent."""
        self._stop.set()
        if self._monitor is not None:
            self._monitor.join(5.0)
            self._monitor = None
        if self.trainer is not None:
            self.trainer.close()
            self.trainer = None
        if self.missions is not None:
            try:
                self.missions.close()  # a running mission is aborted while the link is up
            except Exception:
                log.exception("stopping the missions failed")
            self.missions = None
        for name in ("worker", "recorder", "source", "viewer"):
            part = getattr(self, name)
            if part is not None:
                try:
                    part.close()
                except Exception:
                    log.exception("stopping %s failed", name)
                setattr(self, name, None)
        if self._unsubscribe_link is not None:
            self._unsubscribe_link()
            self._unsubscribe_link = None
        if self.link is not None:
            try:
                self.link.close()
            except Exception:
                log.exception("closing the link failed")
        if self.vehicle_server is not None:
            try:
                self.vehicle_server.stop()
            except Exception:
                log.exception("stopping the stand-in vehicle failed")
            self.vehicle_server = None
        if self.storage is not None:
            self.storage.close()
            self.storage = None
        self.started = False

    # --- listeners (the WebSocket hub) ---------------------------------------------------
    def add_listener(self, listener: Listener) -> Callable[[], None]:
        """``listener(kind, payload)``: kind "event" (dict), "frame" (Processed) or
        "mission" (the running mission's live state, dict)."""
        with self._listen_lock:
            self._listeners.append(listener)

        def remove() -> None:
            with self._listen_lock:
                if listener in self._listeners:
                    self._listeners.remove(listener)

        return remove

    def _notify(self, kind: str, payload: Any) -> None:
        with self._listen_lock:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                listener(kind, payload)
            except Exception:
                log.exception("a station listener failed")

    def emit_event(self, kind: str, text: str, data: dict | None = None) -> dict:
        """Store an event and pass it to the listeners."""
        t = time.time()
        # The data's own keys never override the message's type, kind, text or time.
        event = {**(data or {}), "type": "event", "kind": kind, "text": text, "t": t}
        if self.storage is not None:
            try:
                self.storage.add_event(kind, text, data, t)
            except Exception:
                log.exception("could not store an event")
        self._notify("event", event)
        return event

    def _on_link_event(self, event: LinkEvent) -> None:
        data = dict(event.data)
        if event.kind == "statustext":
            text = str(data.get("text", ""))
        elif event.kind == "command":
            text = f"{data.get('command', 'command')}: {data.get('result_name', '')}".strip()
            if data.get("reasons"):
                text += " (" + "; ".join(map(str, data["reasons"])) + ")"
        elif event.kind in ("link_up", "link_lost", "link_connecting", "link_closed"):
            reason = data.get("reason")
            text = f"link {event.kind.removeprefix('link_')}" + (f": {reason}" if reason else "")
        else:
            text = event.kind.replace("_", " ")
            if "mode" in data:
                text += f": {data['mode']}"
        self.emit_event(event.kind, text, data)

    def _fan_out_frame(self, processed: Processed) -> None:
        self._notify("frame", processed)

    # --- the monitor thread --------------------------------------------------------------
    def _monitor_loop(self) -> None:
        while not self._stop.wait(0.1):
            try:
                self._tick()
            except Exception:
                log.exception("station monitor tick failed")

    def _tick(self) -> None:
        link, recorder = self.link, self.recorder
        if link is None or recorder is None:
            return
        tel = link.telemetry
        if tel.state == LinkState.UP:
            if tel.armed and not self._was_armed:
                recorder.start("armed")
            elif not tel.armed and self._was_armed and recorder.current is not None:
                recorder.stop("disarmed")
            self._was_armed = tel.armed
        if self.viewer is not None:
            pos = tel.position_ned
            att = tel.attitude
            latest = self.worker.latest if self.worker is not None else None
            pose = None
            if latest is not None and time.monotonic() - latest.t_done < 1.0:
                pose = latest.result.pose
            self.viewer.update(
                position_ned=None if pos is None else (pos.x, pos.y, pos.z),
                attitude_rpy=None if att is None else (att.roll, att.pitch, att.yaw),
                vision_position_m=None if pose is None else pose.position_m,
                vision_R_pad_cam=None if pose is None else pose.R_pad_cam,
            )

    # --- camera --------------------------------------------------------------------------
    def _camera_model(self) -> Camera:
        s = self.settings
        if s.camera_calibration is not None:
            return Camera.from_file(s.camera_calibration)
        return Camera.from_fov(640, 480, s.camera_hfov_deg)

    def _open_camera(self) -> FrameSource:
        s = self.settings
        if s.camera.partition(":")[0].lower() != "sim":
            return open_source(s.camera)
        from sim.camera import SimCamera, SimCameraConfig

        cam = self.camera_model
        config = SimCameraConfig(
            pad_north_m=s.pad_north,
            pad_east_m=s.pad_east,
            pad_heading_deg=s.pad_heading_deg,
            pad_size_m=s.pad_size,
            width=cam.width,
            height=cam.height,
            hfov_deg=cam.hfov_deg,
            seed=s.sim_seed,
        )
        return SimCamera(vehicle_pose=self.vehicle_pose, config=config)

    def vehicle_pose(self):
        """The vehicle's pose from telemetry (LOCAL_POSITION_NED + ATTITUDE), or ``None``."""
        from sim.camera import VehiclePose

        link = self.link
        if link is None:
            return None
        tel = link.telemetry
        if tel.position_ned is None or tel.attitude is None:
            return None
        p, a = tel.position_ned, tel.attitude
        t = tel.local_position_rx_monotonic or time.monotonic()
        return VehiclePose(position_ned=(p.x, p.y, p.z), roll=a.roll, pitch=a.pitch, yaw=a.yaw, t=t)

    def _yaw_hint(self) -> float | None:
        """The camera's expected yaw in the pad frame from the vehicle's heading."""
        link = self.link
        if link is None:
            return None
        att = link.telemetry.attitude
        if att is None:
            return None
        return camera_yaw_in_pad(self.settings.pad_heading_deg, att.yaw)

    # --- runtime settings ----------------------------------------------------------------
    def _load_runtime(self) -> dict[str, Any]:
        s = self.settings
        values = {k: getattr(s, k) for k in RUNTIME_KEYS}
        stored = self.storage.get_settings() if self.storage else {}
        for key in RUNTIME_KEYS:
            # What the operator set at run time persists, unless given explicitly now.
            if key in stored and key not in s.model_fields_set:
                values[key] = stored[key]
        return values

    def update_runtime(self, changes: dict[str, Any]) -> dict[str, Any]:
        unknown = set(changes) - set(RUNTIME_KEYS)
        if unknown:
            raise ValueError(f"unknown settings: {', '.join(sorted(unknown))}")
        self.runtime.update(changes)
        if self.storage is not None:
            self.storage.put_settings(changes)
        self.emit_event("settings", "settings changed", {"changes": changes})
        return self.public_settings()

    def public_settings(self) -> dict[str, Any]:
        s = self.settings
        return {
            **self.runtime,
            "max_upload_bytes": s.max_upload_bytes,
            "camera": s.camera,
            "mavlink": self.mavlink_url,
            "pad_size_m": s.pad_size,
            "pad_heading_deg": s.pad_heading_deg,
            "simulated_vehicle": s.mavlink is None,
        }

    # --- references ----------------------------------------------------------------------
    def _current_reference(self) -> Reference | None:
        active = self._active
        return None if active is None else active.reference

    @property
    def active_reference(self) -> ActiveReference | None:
        return self._active

    def _reference_dir(self) -> Path:
        path = self.data_dir / "references"
        path.mkdir(parents=True, exist_ok=True)
        return path

    def _load_initial_reference(self) -> None:
        s = self.settings
        if s.reference is not None:
            data = Path(s.reference).read_bytes()
            image = decode_image(data)
            self.add_reference(image, Path(s.reference).name, s.pad_size, quiet=True)
            return
        row = self.storage.active_reference()
        if row is not None:
            try:
                self.activate_reference(row["id"], quiet=True)
                return
            except Exception:
                log.exception("the stored active reference %s cannot be loaded", row["id"])
        self.add_reference(make_pad_image(), "default pad", s.pad_size, quiet=True)

    def add_reference(
        self, image_bgr: np.ndarray, name: str, pad_size_m: float, *, quiet: bool = False
    ) -> dict:
        """Measure, store and activate a reference picture.

        Raises :class:`NoUsableH` with the pipeline's reason; on any failure the active
        reference stays as it was.
        """
        try:
            reference = Reference.from_image(image_bgr, pad_size_m)
        except ValueError as exc:
            raise NoUsableH(str(exc)) from exc
        digest = hashlib.sha256(image_bgr.tobytes()).hexdigest()
        for row in self.storage.list_references():
            if row["data"].get("sha256") == digest and row["pad_size_m"] == float(pad_size_m):
                return self._set_active(row["id"], reference, quiet=quiet)
        tmp = self._reference_dir() / f"new-{secrets.token_hex(6)}"
        tmp.mkdir()
        try:
            self._write_reference_images(tmp, reference)
            data = {**reference.to_dict(), "sha256": digest}
            ref_id = self.storage.add_reference(name, pad_size_m, "", data)
            final = self._reference_dir() / str(ref_id)
            tmp.rename(final)
            self.storage.set_reference_dir(ref_id, str(final))
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return self._set_active(ref_id, reference, quiet=quiet)

    @staticmethod
    def _write_reference_images(folder: Path, reference: Reference) -> None:
        image = reference.image
        mask = np.asarray(reference.mask)
        mask = ((mask > 0).astype(np.uint8)) * 255
        if mask.shape[:2] != image.shape[:2]:
            mask = cv2.resize(mask, (image.shape[1], image.shape[0]), cv2.INTER_NEAREST)
        for name, picture in (
            ("original", image),
            ("threshold", mask),
            ("corners", draw_corners(image, reference.corners_px)),
        ):
            if not cv2.imwrite(str(folder / f"{name}.png"), picture):
                raise OSError(f"could not write {folder / name}.png")

    def activate_reference(self, ref_id: int, *, quiet: bool = False) -> dict:
        """Re-activate a stored reference; ``KeyError`` if unknown."""
        row = self.storage.get_reference(ref_id)
        if row is None:
            raise KeyError(ref_id)
        image = cv2.imread(str(Path(row["dir"]) / "original.png"), cv2.IMREAD_COLOR)
        if image is None:
            raise FileNotFoundError(f"reference {ref_id}: its picture is missing")
        try:
            reference = Reference.from_image(image, row["pad_size_m"])
        except ValueError as exc:
            raise NoUsableH(str(exc)) from exc
        return self._set_active(ref_id, reference, quiet=quiet)

    def _set_active(self, ref_id: int, reference: Reference, *, quiet: bool) -> dict:
        with self._ref_lock:
            self.storage.activate_reference(ref_id)
            row = self.storage.get_reference(ref_id)
            self._active = ActiveReference(ref_id, reference, row)
        if self.viewer is not None:
            self.viewer.set_pad(reference.image, reference.pad_size_m)
        if self.trainer is not None:
            self.trainer.request(ref_id, reference)
        summary = self.reference_summary(row)
        if not quiet:
            self.emit_event(
                "reference", f"reference {ref_id} ({row['name']}) active", {"id": ref_id}
            )
        return summary

    def reference_summary(self, row: dict | None = None) -> dict | None:
        """The contract's summary of a stored reference (the active one by default)."""
        if row is None:
            active = self._active
            if active is None:
                return None
            row = self.storage.get_reference(active.id) if self.storage else active.row
        data = row["data"]
        rid = row["id"]
        return {
            "id": rid,
            "name": row["name"],
            "pad_size_m": row["pad_size_m"],
            "created": row["created"],
            "active": bool(row["active"]),
            "corners_m": data["corners_m"],
            "hu": data["hu"],
            "orientation_deg": data["orientation_deg"],
            "eccentricity": data["eccentricity"],
            "symmetric": data["symmetric"],
            "image_size": data["image_size"],
            "images": {k: f"/api/references/{rid}/image/{k}" for k in REFERENCE_IMAGES},
            "verifier": None if self.trainer is None else self.trainer.status(rid).to_dict(),
        }

    def _process_frame(
        self, image_bgr: np.ndarray, reference: Reference, camera: Camera, *, yaw_hint=None
    ) -> FrameResult:
        """process_frame with the active reference's pattern verifier, once it is trained."""
        active = self._active
        verifier = None
        if self.trainer is not None and active is not None and active.reference is reference:
            verifier = self.trainer.verifier(active.id)
        return process_frame(image_bgr, reference, camera, yaw_hint=yaw_hint, verifier=verifier)

    def _on_verifier_change(self, ref_id: int, status: VerifierStatus) -> None:
        # Progress reaches the dashboard in the reference summary of each status
        # message; the outcome is also an event for the log.
        if status.state in ("ready", "unavailable", "failed"):
            self.emit_event(
                "reference",
                f"reference {ref_id}: {status.detail}",
                {"id": ref_id, "verifier": status.to_dict()},
            )

    def list_references(self) -> list[dict]:
        return [self.reference_summary(row) for row in self.storage.list_references()]

    def reference_image_path(self, ref_id: int, kind: str) -> Path | None:
        row = self.storage.get_reference(ref_id)
        if row is None or kind not in REFERENCE_IMAGES:
            return None
        path = Path(row["dir"]) / f"{kind}.png"
        return path if path.is_file() else None

    def recent_events(self, limit: int = 50) -> list[dict]:
        """The last stored events, oldest first, shaped like the WebSocket's event messages."""
        if self.storage is None:
            return []
        return [
            {**e["data"], "type": "event", "kind": e["kind"], "text": e["text"], "t": e["t"]}
            for e in self.storage.recent_events(limit)
        ]

    # --- vehicle -------------------------------------------------------------------------
    def command(self, name: str, *args: Any) -> CommandResult:
        """Run one vehicle command (blocks until ACK or timeout)."""
        link = self.link
        if link is None:
            raise RuntimeError("the station is not running")
        method = {
            "arm": link.arm,
            "disarm": link.disarm,
            "force-disarm": link.force_disarm,
            "land": link.land,
            "rtl": link.rtl,
            "takeoff": link.takeoff,
            "mode": link.set_mode,
        }[name]
        return method(*args)

    def land_config(self, **changes: Any) -> LandConfig:
        """Mission settings for this station's pad (its place and heading from settings)."""
        s = self.settings
        return LandConfig(
            pad_north_m=s.pad_north,
            pad_east_m=s.pad_east,
            pad_heading_deg=s.pad_heading_deg,
            **changes,
        )

    @property
    def telemetry(self) -> Telemetry | None:
        return None if self.link is None else self.link.telemetry

    def telemetry_dict(self) -> dict:
        tel = self.telemetry
        return {} if tel is None else tel.to_dict()

    # --- status --------------------------------------------------------------------------
    def status(self) -> dict:
        link, source, worker = self.link, self.source, self.worker
        tel = link.telemetry if link is not None else None
        link_status = {
            "state": str(link.state) if link is not None else "closed",
            "url": self.mavlink_url,
            "heartbeat_age_s": None if tel is None else tel.heartbeat_age_s,
            "msgs_per_s": 0.0 if tel is None else tel.msgs_per_s,
            "crc_errors": 0 if tel is None else tel.crc_errors,
        }
        camera_status = {
            "name": "",
            "state": "closed",
            "fps": 0.0,
            "frames": 0,
            "errors": 0,
            "last_error": "",
        }
        if source is not None:
            st = source.status
            camera_status = {
                "name": source.name,
                "state": st.state,
                "fps": round(st.fps, 2),
                "frames": st.frames,
                "errors": st.errors,
                "last_error": st.last_error,
            }
        pipeline = worker.stats.to_dict() if worker is not None else None
        return {
            "link": link_status,
            "camera": camera_status,
            "pipeline": pipeline,
            "mission": self.missions.current() if self.missions is not None else None,
            "reference": self.reference_summary() if self.storage is not None else None,
            "flight": self.recorder.current if self.recorder is not None else None,
            "viser_url": self.viewer.url if self.viewer is not None else None,
        }
