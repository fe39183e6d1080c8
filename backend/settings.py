"""The ground station's settings: one pydantic-settings class, env prefix ``VISLAND_``.

Every field is also a CLI flag of ``python -m backend serve`` (see ``backend/__main__.py``).
Tests override :func:`get_settings` (FastAPI dependency) or pass a ``Settings`` to
``create_app``.
"""

from __future__ import annotations

import math
import os
import secrets
from functools import lru_cache
from pathlib import Path
from typing import Annotated

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

DEFAULT_PAD_SIZE_M = 0.55
MAX_MOUNT_TILT_DEG = 45.0
MAX_PAD_SIZE_M = 20.0


class Settings(BaseSettings):
    """Start-up configuration of the ground station.

    ``mavlink=None`` starts the in-process ArduCopter stand-in; ``camera="sim"`` renders
    the pad from the vehicle's reported pose; ``reference=None`` uses the default pad
    picture. ``viser_port`` is the loopback port of the 3D view's own server, which
    browsers reach only through the station (``/view3d/``); 0 turns the 3D view off.
    ``allowed_hosts``/``allowed_origins``: names and browser origins the station answers
    to besides its own (comma-separated in the environment and on the command line).
    """

    # A blank variable is not given (compose passes every one through, blank when unset):
    # what the operator set at run time then holds (`backend.services.runtime`).
    model_config = SettingsConfigDict(env_prefix="VISLAND_", extra="ignore", env_ignore_empty=True)

    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    viser_port: int = Field(8080, ge=0, le=65535)
    mavlink: str | None = None
    camera: str = "sim"
    camera_calibration: Path | None = None
    camera_hfov_deg: float = Field(60.0, gt=0, lt=180)
    # How the camera is turned from looking straight down with its picture's top to the
    # nose: roll, pitch and yaw in degrees, as the vehicle's own (`backend.frames.
    # mount_rotation`). The attitude hint is only as right as this: a camera 6 degrees
    # off what is set here put the design bench's poses 8 % of the altitude off.
    # The operator may change it while the station runs (`PUT /api/settings`, kept).
    camera_mount: Annotated[tuple[float, float, float], NoDecode] = (0.0, 0.0, 0.0)
    # Where the simulated camera truly sits, when not where the station is told at start
    # (to see the mount check tell it): it does not follow a mount set at run time.
    sim_camera_mount: Annotated[tuple[float, float, float] | None, NoDecode] = None
    reference: Path | None = None
    pad_size: float = Field(DEFAULT_PAD_SIZE_M, gt=0, le=MAX_PAD_SIZE_M)
    # Where the pad lies in the vehicle's local frame (metres from home) and where its
    # picture's top edge faces (degrees clockwise from north): places the pad for the
    # stand-in, the simulated camera and the 3D view, and resolves the H's 180 degree
    # ambiguity from the vehicle's heading.
    pad_north: float = Field(0.0, ge=-1000, le=1000)
    pad_east: float = Field(0.0, ge=-1000, le=1000)
    pad_heading_deg: float = Field(0.0, ge=-360, le=360)
    data_dir: Path = Path("data")
    token: str | None = None
    view_requires_token: bool = False
    record_frames: bool = True
    jpeg_quality: int = Field(80, ge=10, le=100)
    max_upload_bytes: int = Field(20 * 1024 * 1024, gt=0)
    # Pictures are refused from their header when larger than this (decoding one takes
    # about 3 bytes a pixel, more on the way): 40 MP is a 7300 x 5500 photo.
    max_upload_pixels: int = Field(40_000_000, gt=0, le=1_000_000_000)
    allowed_hosts: Annotated[list[str], NoDecode] = []
    allowed_origins: Annotated[list[str], NoDecode] = []
    signing_key: str | None = None
    # The in-process stand-in vehicle (used when mavlink is None).
    sim_ready_after: float = Field(1.0, gt=0, le=10)
    sim_speedup: float = Field(1.0, gt=0, le=50)
    sim_seed: int = 0
    # Synthetic views the pattern verifier of each reference learns from (a
    # minute or two of CPU in the background after an upload); 0 turns training off.
    verifier_views: int = Field(1000, ge=0, le=20000)
    link_timeout_s: float = Field(3.0, gt=0, le=60)
    command_timeout_s: float = Field(3.0, gt=0, le=60)

    @field_validator("mavlink", "token", "signing_key", mode="before")
    @classmethod
    def _blank_is_none(cls, value: object) -> object:
        # An empty env var (VISLAND_MAVLINK=) means "not given", as on the CLI.
        if isinstance(value, str) and not value.strip():
            return None
        return value

    @field_validator("allowed_hosts", "allowed_origins", mode="before")
    @classmethod
    def _comma_list(cls, value: object) -> object:
        if isinstance(value, str):
            return [part.strip() for part in value.split(",") if part.strip()]
        return value

    @field_validator("allowed_hosts")
    @classmethod
    def _host_names(cls, value: list[str]) -> list[str]:
        for name in value:
            if not name or any(c.isspace() or c in "/?#@" for c in name):
                raise ValueError(f"{name!r} is not a host name (e.g. gcs.local or 192.168.1.20)")
        return value

    @field_validator("allowed_origins")
    @classmethod
    def _origins(cls, value: list[str]) -> list[str]:
        for origin in value:
            scheme, sep, rest = origin.partition("://")
            if scheme not in ("http", "https") or not sep or not rest or "/" in rest.rstrip("/"):
                raise ValueError(f"{origin!r} is not an origin (e.g. https://gcs.example:8443)")
        return value

    @field_validator("camera_mount", "sim_camera_mount", mode="before")
    @classmethod
    def _mount_angles(cls, value: object) -> object:
        if isinstance(value, str):
            try:
                angles = tuple(float(part) for part in value.split(","))
            except ValueError:
                angles = ()
            if len(angles) != 3:
                raise ValueError(
                    f"a camera mount is roll,pitch,yaw in degrees (e.g. 0,10,0), got {value!r}"
                )
            return angles
        return value

    @field_validator("camera_mount", "sim_camera_mount")
    @classmethod
    def _mount_in_range(
        cls, value: tuple[float, float, float] | None
    ) -> tuple[float, float, float] | None:
        return None if value is None else check_mount(value)

    @field_validator("token")
    @classmethod
    def _token_long_enough(cls, value: str | None) -> str | None:
        if value is not None and len(value) < 8:
            raise ValueError("token must be at least 8 characters")
        return value

    @field_validator("camera")
    @classmethod
    def _camera_spec(cls, value: str) -> str:
        kind, _, target = value.strip().partition(":")
        kind = kind.lower()
        if kind not in ("sim", "cmucam4", "opencv"):
            raise ValueError("camera must be 'sim', 'cmucam4:PORT' or 'opencv:SOURCE'")
        if kind == "sim" and target:
            raise ValueError("camera 'sim' takes nothing after it")
        if kind != "sim" and not target.strip():
            raise ValueError(f"camera '{kind}:' needs a port, device, file or URL after the colon")
        return value.strip()

    @field_validator("reference", "camera_calibration")
    @classmethod
    def _existing_file(cls, value: Path | None) -> Path | None:
        if value is not None and not Path(value).is_file():
            raise ValueError(f"no file at {value}")
        return value

    @field_validator("signing_key")
    @classmethod
    def _signing_key_hex(cls, value: str | None) -> str | None:
        if value is None:
            return None
        try:
            key = bytes.fromhex(value)
        except ValueError as exc:
            raise ValueError("signing_key must be hex (64 digits for a 32-byte key)") from exc
        if len(key) != 32:
            raise ValueError("signing_key must be 32 bytes (64 hex digits)")
        return value


def check_mount(angles: tuple[float, float, float]) -> tuple[float, float, float]:
    """A camera mount's roll, pitch and yaw (degrees) as given; ``ValueError`` saying why
    it cannot be one.

    >>> check_mount((0, 8.5, -90))
    (0.0, 8.5, -90.0)
    >>> check_mount((0.0, 60.0, 0.0))
    Traceback (most recent call last):
    ...
    ValueError: a camera mount's roll and pitch must be within 45 degrees of looking ...
    """
    roll, pitch, yaw = (float(a) for a in angles)
    if not all(math.isfinite(a) for a in (roll, pitch, yaw)):
        raise ValueError("a camera mount's angles must be finite")
    if abs(roll) > MAX_MOUNT_TILT_DEG or abs(pitch) > MAX_MOUNT_TILT_DEG:
        raise ValueError(
            f"a camera mount's roll and pitch must be within {MAX_MOUNT_TILT_DEG:g} degrees "
            "of looking straight down (the pad is searched for below the vehicle)"
        )
    if abs(yaw) > 180:
        raise ValueError("a camera mount's yaw must be within -180..180 degrees")
    return roll, pitch, yaw


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    """The process-wide settings from the environment (tests override this)."""
    return Settings()


def resolve_token(settings: Settings) -> tuple[str, Path | None]:
    """The operator token and the file that keeps it.

    A token given in the settings wins and is not written anywhere. Otherwise the token
    lives in ``DATA_DIR/token`` (mode 0600), generated with :mod:`secrets` at first start.
    """
    if settings.token:
        return settings.token, None
    path = Path(settings.data_dir) / "token"
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_file():
        token = path.read_text().strip()
        if len(token) >= 8:
            return token, path
    token = secrets.token_urlsafe(24)
    # Create with 0600 from the start so the token is never world-readable, not even briefly.
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as fh:
        fh.write(token + "\n")
    os.chmod(path, 0o600)
    return token, path
