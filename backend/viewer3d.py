"""The 3D view (viser) behind one adapter: pad, vehicle, camera frustum, vision pose, trail.

World frame: ENU about the vehicle's local origin (x east, y north, z up), so the
scene reads like a map. Scene paths:

- ``/pad``: the reference picture laid flat at the pad's place and heading
- ``/vehicle``: the vehicle's body frame (FRD axes) from telemetry
- ``/vehicle/camera``: the camera frustum (looking down, image top = forward)
- ``/vision``: the camera pose the pipeline measured, placed via the pad (compare it
  with ``/vehicle/camera``: they coincide when vision and telemetry agree)
- ``/trail``: the vehicle's recent positions

Handles are created once and their properties assigned; each update is one atomic
batch. The dashboard embeds the view (``/view3d/`` on the station's port) in an iframe.
"""

from __future__ import annotations

import logging
import math
import secrets
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from backend.framebus import FrameBus
from backend.frames import DOWN_MOUNT, rot_ned_body, rot_ned_pad
from backend.link import Telemetry
from backend.tokens import tokens_equal
from backend.vision_worker import Processed

if TYPE_CHECKING:
    import viser

log = logging.getLogger(__name__)

# ENU from NED: swap north/east, flip down.
_ENU_FROM_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
_IMAGE_FLIP = np.diag([1.0, -1.0, -1.0])


def rotation_world_pad(heading_deg: float) -> np.ndarray:
    """Pad frame -> world (ENU) for a pad whose picture top faces ``heading_deg``.

    The heading is clockwise from north. Pad +y (picture top) points along the heading,
    pad +x (picture right) 90 degrees clockwise from it, pad +z up.
    """
    return _ENU_FROM_NED @ rot_ned_pad(heading_deg)


def browsable_host(host: str) -> str:
    """The address a local browser should use for a server bound to ``host``."""
    return "127.0.0.1" if host in ("0.0.0.0", "::", "") else host


def _gate(server: viser.ViserServer, secret: str) -> None:
    """Close each WebSocket to viser's own port that lacks the proxy's secret header.

    viser has no hook for this, so it reaches into its WebSocket server: the connect
    callbacks run (and are awaited) after the connection is registered in
    ``_live_connections`` and before anything is sent to it. If a viser upgrade moves
    these, this raises at start (no ungated 3D view), and the gate's test fails.
    """
    infra = getattr(server, "_websock_server", None)
    if infra is None or not hasattr(infra, "_live_connections"):
        raise RuntimeError("this viser version cannot be gated: the 3D view stays off")

    async def check(client: Any) -> None:
        connection = infra._live_connections.get(client.client_id)
        request = getattr(connection, "request", None)
        given = None if request is None else request.headers.get(PROXY_HEADER)
        if isinstance(given, str) and tokens_equal(given, secret):
            return
        if connection is None:
            raise ConnectionRefusedError("not the station's proxy")  # closes it (1011)
        await connection.close(1008, "The 3D view is reached through the station: /view3d/")

    infra.on_client_connect(check)


def _wxyz(R: np.ndarray) -> np.ndarray:
    import viser.transforms as tf

    return np.asarray(tf.SO3.from_matrix(np.asarray(R, float)).wxyz)


#: Where browsers find the 3D view: on the station's own port, behind its guard.
VIEW_PATH = "/view3d/"
#: The header the station's proxy sends to viser with its per-process secret.
PROXY_HEADER = "X-Visland-View"


class Viewer3D:
    """A viser server on ``host:port`` (loopback) showing the landing scene.

    Browsers never talk to it directly: the station proxies it at ``/view3d/`` under
    its own Host, Origin and token rules (``backend.api.view3d``), and viser's own port
    closes every WebSocket that does not carry :data:`PROXY_HEADER` with
    :attr:`proxy_secret` (a page elsewhere cannot set a header on a WebSocket) before
    anything of the scene is sent.

    Parameters
    ----------
    pad_image_bgr : the reference picture (shown as the pad's texture).
    pad_size_m : the pad's width.
    pad_ned : (north, east) of the pad centre in the local frame.
    pad_heading_deg : where the pad picture's top faces (clockwise from north).
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        pad_image_bgr: np.ndarray,
        pad_size_m: float,
        pad_ned: tuple[float, float] = (0.0, 0.0),
        pad_heading_deg: float = 0.0,
        camera_hfov_deg: float = 60.0,
        aspect: float = 4 / 3,
        mount_rotation: np.ndarray = DOWN_MOUNT,
        trail_points: int = 600,
    ) -> None:
        self.host, self.port = host, int(port)
        self._pad_image = pad_image_bgr
        self._pad_size = float(pad_size_m)
        self._pad_ned = (float(pad_ned[0]), float(pad_ned[1]))
        self._pad_heading = float(pad_heading_deg)
        self._hfov = math.radians(camera_hfov_deg)
        self._aspect = float(aspect)
        self._mount = np.asarray(mount_rotation, float)  # (R_body_cam)
        self._trail: deque[np.ndarray] = deque(maxlen=trail_points)
        self._lock = threading.Lock()
        self._server: viser.ViserServer | None = None
        self._h: dict[str, Any] = {}
        self.proxy_secret = secrets.token_urlsafe(32)

    @property
    def url(self) -> str:
        """Where a browser finds the view: a path on the station's own port."""
        return VIEW_PATH

    @property
    def bound_port(self) -> int | None:
        """The port viser listens on (it takes the next free one if ``port`` is busy)."""
        server = self._server
        return None if server is None else int(server.get_port())

    @property
    def R_world_pad(self) -> np.ndarray:
        return rotation_world_pad(self._pad_heading)

    @property
    def pad_origin_world(self) -> np.ndarray:
        return np.array([self._pad_ned[1], self._pad_ned[0], 0.0])

    def start(self) -> None:
        import viser

        with self._lock:
            if self._server is not None:
                return
            server = viser.ViserServer(host=self.host, port=self.port, verbose=False)
            self._server = server
            _gate(server, self.proxy_secret)
            # The dashboard embeds the view and explains it in its own legend: viser's
            # control panel (empty here) starts folded away, the theme matches the page.
            server.gui.configure_theme(dark_mode=True, show_logo=False, show_share_button=False)
            server.gui.main_panel.minimize()
            scene = server.scene
            scene.set_up_direction("+z")
            # Start looking at the pad from the south-west, a few metres up.
            eye = self.pad_origin_world + np.array([-3.0, -5.0, 4.0])
            server.initial_camera.position = tuple(eye)
            server.initial_camera.look_at = tuple(self.pad_origin_world)
            server.initial_camera.up = (0.0, 0.0, 1.0)
            scene.add_grid("/ground", width=20.0, height=20.0, cell_size=1.0, section_size=5.0)
            self._h["pad"] = self._add_pad()
            self._h["vehicle"] = scene.add_frame(
                "/vehicle", axes_length=0.4, axes_radius=0.02, visible=False
            )
            vfov = 2 * math.atan(math.tan(self._hfov / 2) / self._aspect)
            self._h["camera"] = scene.add_camera_frustum(
                "/vehicle/camera",
                fov=vfov,
                aspect=self._aspect,
                scale=0.3,
                color=(40, 120, 255),
                wxyz=_wxyz(self._mount),
            )
            self._h["vision"] = scene.add_frame(
                "/vision", axes_length=0.25, axes_radius=0.015, visible=False
            )
            self._h["vision_frustum"] = scene.add_camera_frustum(
                "/vision/frustum", fov=vfov, aspect=self._aspect, scale=0.3, color=(255, 140, 0)
            )
            self._h["trail"] = scene.add_point_cloud(
                "/trail",
                np.zeros((1, 3), np.float32),
                colors=np.array([[80, 200, 255]], np.uint8),
                point_size=0.05,
                visible=False,
            )

    def _add_pad(self) -> Any:
        image = self._pad_image[:, :, ::-1]  # viser wants RGB
        h, w = image.shape[:2]
        assert self._server is not None  # called once the server runs
        return self._server.scene.add_image(
            "/pad",
            np.ascontiguousarray(image),
            render_width=self._pad_size,
            render_height=self._pad_size * h / w,
            # viser lays images out like OpenCV (rows along local +y, seen from -z):
            # turn it over about x so the picture's top faces pad +y, seen from above.
            wxyz=_wxyz(self.R_world_pad @ _IMAGE_FLIP),
            position=self.pad_origin_world + np.array([0.0, 0.0, 0.002]),
        )

    def set_pad(self, image_bgr: np.ndarray, size_m: float) -> None:
        """Show a new reference picture as the pad's texture."""
        with self._lock:
            self._pad_image, self._pad_size = image_bgr, float(size_m)
            if self._server is None:
                return
            self._h["pad"].remove()
            self._h["pad"] = self._add_pad()

    def set_mount(self, mount_rotation: np.ndarray) -> None:
        """Turn the camera on the vehicle to the mount now set (``R_body_cam``)."""
        with self._lock:
            self._mount = np.asarray(mount_rotation, float)
            if self._server is not None:
                self._h["camera"].wxyz = _wxyz(self._mount)

    def update(
        self,
        *,
        position_ned: tuple[float, float, float] | None,
        attitude_rpy: tuple[float, float, float] | None,
        vision_position_m: np.ndarray | None = None,
        vision_R_pad_cam: np.ndarray | None = None,
    ) -> None:
        """Move the vehicle (telemetry) and the vision camera pose; one atomic batch."""
        with self._lock:
            server = self._server
            if server is None:
                return
            with server.atomic():
                vehicle = self._h["vehicle"]
                if position_ned is not None and attitude_rpy is not None:
                    p = _ENU_FROM_NED @ np.asarray(position_ned, float)
                    vehicle.position = p
                    vehicle.wxyz = _wxyz(_ENU_FROM_NED @ rot_ned_body(*attitude_rpy))
                    vehicle.visible = True
                    if not self._trail or np.linalg.norm(self._trail[-1] - p) > 0.05:
                        self._trail.append(p)
                        trail = self._h["trail"]
                        trail.points = np.asarray(self._trail, np.float32)
                        trail.colors = np.tile(
                            np.array([[80, 200, 255]], np.uint8), (len(self._trail), 1)
                        )
                        trail.visible = True
                else:
                    vehicle.visible = False
                vision = self._h["vision"]
                if vision_position_m is not None and vision_R_pad_cam is not None:
                    R_wp = self.R_world_pad
                    vision.position = self.pad_origin_world + R_wp @ np.asarray(
                        vision_position_m, float
                    )
                    vision.wxyz = _wxyz(R_wp @ np.asarray(vision_R_pad_cam, float))
                    vision.visible = True
                else:
                    vision.visible = False

    def close(self) -> None:
        with self._lock:
            server, self._server = self._server, None
            self._h.clear()
        if server is not None:
            try:
                server.stop()
            except Exception:
                log.exception("viser did not stop cleanly")


class ViewerFeed:
    """Moves the 3D view at 10 Hz: the vehicle from telemetry, the vision pose from the
    newest result on its own slot of the frame bus (shown for a second after it came)."""

    PERIOD_S = 0.1
    POSE_SHOWN_S = 1.0

    def __init__(
        self,
        viewer: Viewer3D,
        telemetry: Callable[[], Telemetry],
        results: FrameBus[Processed],
    ) -> None:
        self._viewer = viewer
        self._telemetry = telemetry
        self._slot = results.subscribe("viewer3d")
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._latest: Processed | None = None

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="viewer3d-feed", daemon=True)
            self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._slot.close()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(5.0)

    def _run(self) -> None:
        while not self._stop.wait(self.PERIOD_S):
            try:
                self.tick()
            except Exception:
                log.exception("3D view update failed")

    def tick(self) -> None:
        latest = self._slot.take(0.0)
        if latest is not None:
            self._latest = latest
        tel = self._telemetry()
        pos, att = tel.position_ned, tel.attitude
        pose = None
        if self._latest is not None and time.monotonic() - self._latest.t_done < self.POSE_SHOWN_S:
            pose = self._latest.result.pose
        self._viewer.update(
            position_ned=None if pos is None else (pos.x, pos.y, pos.z),
            attitude_rpy=None if att is None else (att.roll, att.pitch, att.yaw),
            vision_position_m=None if pose is None else pose.position_m,
            vision_R_pad_cam=None if pose is None else pose.R_pad_cam,
        )
