"""The simulated camera: renders the pad from the vehicle's pose as reported over MAVLink.

It takes a callable ``vehicle_pose() -> VehiclePose | None`` that the ground station
feeds from the link's LOCAL_POSITION_NED and ATTITUDE messages, so it works with the
stand-in vehicle and with ArduCopter SITL alike (it imports nothing from the link).

Frames (conventions written out because sign slips are easy here):

- local NED: x north, y east, z down (MAVLink LOCAL_POSITION_NED);
- body FRD: x forward, y right, z down; ``R_ned_body = Rz(yaw) Ry(pitch) Rx(roll)``
  (MAVLink ATTITUDE, ZYX);
- camera (OpenCV): x image right, y image down, z optical axis. The default mount looks
  straight down with the image top toward the vehicle's nose: cam z = body down,
  cam x = body right, cam y = body backward;
- pad frame (the renderer's): origin at the pad centre, +x toward the pad picture's
  right edge, +y toward its top edge, +z up. With the pad heading ``psi`` (where the
  picture's top edge faces, degrees clockwise from north), in NED:
  ``y_pad = (cos psi, sin psi, 0)``, ``x_pad = (-sin psi, cos psi, 0)``,
  ``z_pad = (0, 0, -1)``.

A vehicle level above the pad and facing ``psi`` therefore sees the pad upright.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from backend.camera import CaptureError, ThreadedSource
from backend.frames import DOWN_MOUNT, rot_ned_body, rot_ned_pad
from pipeline.camera import Camera

MIN_HEIGHT_M = 0.05  # a camera on the ground still sees a patch, never through it


@dataclass(frozen=True)
class VehiclePose:
    """The vehicle's pose as MAVLink reports it.

    ``position_ned``: (north, east, down) metres in the local frame; ``roll``,
    ``pitch``, ``yaw``: radians, body FRD relative to NED (ATTITUDE); ``t``: the
    ``time.monotonic()`` when this pose was true (or received).
    """

    position_ned: tuple[float, float, float]
    roll: float
    pitch: float
    yaw: float
    t: float

    def __post_init__(self) -> None:
        vals = [*self.position_ned, self.roll, self.pitch, self.yaw, self.t]
        if len(self.position_ned) != 3 or not all(math.isfinite(float(v)) for v in vals):
            raise ValueError(
                f"position_ned must be 3 finite numbers and roll/pitch/yaw/t finite, got {self!r}"
            )


@dataclass(frozen=True, eq=False)
class SimCameraConfig:
    """Where the pad is and what the camera is like.

    ``pad_north_m``/``pad_east_m``/``pad_down_m``: the pad centre in local NED;
    ``pad_heading_deg``: the direction the pad picture's top edge faces (clockwise from
    north); ``pad_texture``: BGR picture of the pad (default ``make_pad_image``);
    ``mount_offset_m``: camera centre in body FRD; ``mount_rotation``: ``R_body_cam``
    (default :data:`DOWN_MOUNT`); ``latency_s``: frames are delivered this much later,
    stamped with the true capture time; ``max_pose_age_s``: older poses give no frame
    (telemetry lost: the camera stalls).
    """

    pad_north_m: float = 0.0
    pad_east_m: float = 0.0
    pad_down_m: float = 0.0
    pad_heading_deg: float = 0.0
    pad_size_m: float = 0.55
    pad_texture: np.ndarray | None = None
    floor: str = "textured"
    lookalikes: int = 0
    mount_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mount_rotation: np.ndarray = field(default_factory=lambda: DOWN_MOUNT.copy())
    width: int = 640
    height: int = 480
    hfov_deg: float = 60.0
    rate_hz: float = 15.0
    snr_db: float | None = None
    blur_sigma_px: float = 0.0
    latency_s: float = 0.0
    max_pose_age_s: float = 1.0
    supersample: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("pad_north_m", "pad_east_m", "pad_down_m", "pad_heading_deg"):
            if not math.isfinite(float(getattr(self, name))):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")
        if not (math.isfinite(self.pad_size_m) and self.pad_size_m > 0):
            raise ValueError(f"pad_size_m must be positive, got {self.pad_size_m}")
        if len(self.mount_offset_m) != 3 or not all(math.isfinite(v) for v in self.mount_offset_m):
            raise ValueError(f"mount_offset_m must be 3 finite numbers, got {self.mount_offset_m}")
        R = np.asarray(self.mount_rotation, float)
        if (
            R.shape != (3, 3)
            or not np.allclose(R @ R.T, np.eye(3), atol=1e-6)
            or not np.isclose(np.linalg.det(R), 1.0, atol=1e-6)
        ):
            raise ValueError("mount_rotation must be a 3x3 rotation matrix (R_body_cam)")
        if int(self.width) <= 0 or int(self.height) <= 0:
            raise ValueError(f"width and height must be positive, got {self.width}x{self.height}")
        if not 0 < self.hfov_deg < 180:
            raise ValueError(f"hfov_deg must be in (0, 180), got {self.hfov_deg}")
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ValueError(f"rate_hz must be positive, got {self.rate_hz}")
        if self.snr_db is not None and not math.isfinite(self.snr_db):
            raise ValueError(f"snr_db must be None or finite, got {self.snr_db}")
        if not self.blur_sigma_px >= 0:
            raise ValueError(f"blur_sigma_px must be >= 0, got {self.blur_sigma_px}")
        if not (math.isfinite(self.latency_s) and self.latency_s >= 0):
            raise ValueError(f"latency_s must be >= 0, got {self.latency_s}")
        if not self.max_pose_age_s > 0:
            raise ValueError(f"max_pose_age_s must be positive, got {self.max_pose_age_s}")
        if self.pad_texture is not None:
            tex = np.asarray(self.pad_texture)
            if tex.ndim != 3 or tex.shape[2] != 3 or tex.dtype != np.uint8:
                raise ValueError(f"pad_texture must be BGR uint8, got {tex.dtype} {tex.shape}")

    @property
    def camera(self) -> Camera:
        return Camera.from_fov(int(self.width), int(self.height), float(self.hfov_deg))


def camera_pose_in_pad_frame(
    pose: VehiclePose, config: SimCameraConfig
) -> tuple[np.ndarray, np.ndarray]:
    """The camera's ``(position_m, R_pad_cam)`` in the renderer's pad frame."""
    R_nb = rot_ned_body(pose.roll, pose.pitch, pose.yaw)
    R_np = rot_ned_pad(config.pad_heading_deg)
    pad = np.array([config.pad_north_m, config.pad_east_m, config.pad_down_m])
    cam_ned = np.asarray(pose.position_ned, float) + R_nb @ np.asarray(config.mount_offset_m)
    position = R_np.T @ (cam_ned - pad)
    R_pad_cam = R_np.T @ R_nb @ np.asarray(config.mount_rotation, float)
    return position, R_pad_cam


class PadRenderer:
    """Renders the configured scene for a vehicle pose (no thread; reusable)."""

    def __init__(self, config: SimCameraConfig | None = None) -> None:
        from pipeline.render import make_pad_image, make_scene  # heavy: import when used

        self.config = config or SimCameraConfig()
        cfg = self.config
        texture = cfg.pad_texture if cfg.pad_texture is not None else make_pad_image(1100)
        self.scene = make_scene(
            texture, cfg.pad_size_m, rng=cfg.seed, floor=cfg.floor, lookalikes=cfg.lookalikes
        )
        self.camera = cfg.camera
        self._rng = np.random.default_rng(cfg.seed)

    def render(self, pose: VehiclePose) -> tuple[np.ndarray, dict]:
        """The camera's picture for ``pose`` and facts about it (pad-frame pose)."""
        from pipeline.render import render

        cfg = self.config
        position, R = camera_pose_in_pad_frame(pose, cfg)
        info: dict = {"resolution": (cfg.width, cfg.height)}
        if position[2] < MIN_HEIGHT_M:
            position = position.copy()
            position[2] = MIN_HEIGHT_M
            info["clamped_height"] = True
        info["position_pad_m"] = [float(v) for v in position]
        info["R_pad_cam"] = R.tolist()
        if R[2, 2] > -0.05:
            # The optical axis is at or above the horizon: the renderer draws only the
            # ground, so the picture is the sky: a flat grey.
            info["sky"] = True
            return np.full((cfg.height, cfg.width, 3), 180, np.uint8), info
        image = render(
            self.scene,
            self.camera,
            position,
            R,
            snr_db=cfg.snr_db,
            blur_sigma_px=cfg.blur_sigma_px,
            rng=self._rng if cfg.snr_db is not None else None,
            supersample=cfg.supersample,
        )
        return image, info


class SimCamera(ThreadedSource):
    """A frame source that renders the pad at ``rate_hz`` from ``vehicle_pose()``.

    No pose (``None``) or a pose older than ``max_pose_age_s`` gives no frame, so the
    source reports ``"stalled"`` while telemetry is missing and recovers with it.
    """

    def __init__(
        self,
        vehicle_pose: Callable[[], VehiclePose | None],
        config: SimCameraConfig | None = None,
        *,
        name: str = "sim",
        stall_after: float | None = None,
    ) -> None:
        if not callable(vehicle_pose):
            raise ValueError("vehicle_pose must be a callable returning VehiclePose or None")
        super().__init__(name, stall_after=stall_after, backoff=(0.1, 1.0))
        self.config = config or SimCameraConfig()
        self.expected_period = 1.0 / self.config.rate_hz
        self._vehicle_pose = vehicle_pose
        self._renderer: PadRenderer | None = None
        self._pending: deque[tuple[float, np.ndarray, float, dict]] = deque()
        self._next_tick = 0.0
        self.skipped_poses = 0

    @property
    def renderer(self) -> PadRenderer:
        if self._renderer is None:
            self._renderer = PadRenderer(self.config)
        return self._renderer

    def _open(self) -> None:
        self.renderer  # noqa: B018 - build the scene in the capture thread
        self._next_tick = time.monotonic()

    def _grab(self) -> tuple[np.ndarray, float, dict] | None:
        now = time.monotonic()
        if self._pending and self._pending[0][0] <= now:
            _, image, t, info = self._pending.popleft()
            info["delivered_late_s"] = time.monotonic() - t
            return image, t, info
        if now >= self._next_tick:
            period = self.expected_period
            self._next_tick = max(self._next_tick + period, now - period)
            try:
                pose = self._vehicle_pose()
            except Exception as exc:
                raise CaptureError(f"vehicle_pose failed: {exc}") from exc
            if pose is None or now - pose.t > self.config.max_pose_age_s:
                self.skipped_poses += 1
                return None
            t0 = time.monotonic()
            image, info = self.renderer.render(pose)
            info["render_s"] = time.monotonic() - t0
            info["pose_age_s"] = now - pose.t
            t_capture = min(pose.t, now)
            self._pending.append((t_capture + self.config.latency_s, image, t_capture, info))
            return None
        wake = self._next_tick
        if self._pending:
            wake = min(wake, self._pending[0][0])
        self._sleep(wake - now)
        return None

    def _release(self) -> None:
        self._pending.clear()
