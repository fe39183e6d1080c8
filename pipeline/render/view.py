"""Camera poses over the pad: the yaw/tilt helper and random views for benchmarks."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from pipeline.camera import Camera
from pipeline.render.degrade import (
    Exposure,
    Glare,
    Lighting,
    MotionBlur,
    Shadow,
    random_lighting,
)
from pipeline.render.pad import PAD_SIZE_M
from pipeline.render.raster import project_points, render
from pipeline.render.scene import Scene


def _finite(value: float, name: str) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def camera_rotation(
    yaw_deg: float, *, tilt_deg: float = 0.0, tilt_dir_deg: float = 0.0
) -> np.ndarray:
    """R_pad_cam of a downward camera with the given yaw, tilted off nadir.

    The optical axis leans ``tilt_deg`` away from straight down toward the horizontal
    direction ``tilt_dir_deg`` (counter-clockwise from pad +x). The camera's x axis
    (image right) is the unit vector perpendicular to the optical axis whose
    projection on the pad plane points along ``yaw_deg``, so
    ``pipeline.result.yaw_of`` returns ``yaw_deg`` exactly, at any tilt.

    Examples
    --------
    >>> camera_rotation(0.0).round(6).tolist()  # image right = pad +x, down = pad -y
    [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
    """
    yaw = math.radians(_finite(yaw_deg, "yaw_deg"))
    tilt = _finite(tilt_deg, "tilt_deg")
    if not 0 <= tilt < 80:
        raise ValueError(f"tilt_deg must be in [0, 80), got {tilt}")
    tdir = math.radians(_finite(tilt_dir_deg, "tilt_dir_deg"))
    t = math.radians(tilt)
    z = np.array([math.sin(t) * math.cos(tdir), math.sin(t) * math.sin(tdir), -math.cos(t)])
    h = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    # x = h + beta * e_z, perpendicular to z; z[2] < 0 so beta always exists.
    x = h - (h @ z) / z[2] * np.array([0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


@dataclass(frozen=True, eq=False)
class View:
    """One sampled camera pose over the pad and the frame's degradations.

    ``position_m``/``R_pad_cam``: the pose (pad frame, see `render`). ``yaw_deg``,
    ``tilt_deg``, ``tilt_dir_deg``: how ``R_pad_cam`` was made (`camera_rotation`).
    ``snr_db`` None means no noise. The real world's degradations (``motion_blur``,
    ``shadow``, ``glare``, ``exposure``, ``jpeg_quality``) are None when absent.
    """

    position_m: np.ndarray
    R_pad_cam: np.ndarray
    yaw_deg: float
    tilt_deg: float
    tilt_dir_deg: float
    snr_db: float | None
    blur_sigma_px: float
    light: Lighting | None
    motion_blur: MotionBlur | None = None
    shadow: Shadow | None = None
    glare: Glare | None = None
    exposure: Exposure | None = None
    jpeg_quality: int | None = None

    @property
    def altitude_m(self) -> float:
        return float(self.position_m[2])

    def to_dict(self) -> dict:
        return {
            "position_m": [float(v) for v in self.position_m],
            "R_pad_cam": np.asarray(self.R_pad_cam, float).tolist(),
            "yaw_deg": self.yaw_deg,
            "tilt_deg": self.tilt_deg,
            "tilt_dir_deg": self.tilt_dir_deg,
            "snr_db": self.snr_db,
            "blur_sigma_px": self.blur_sigma_px,
            "light": None if self.light is None else vars(self.light).copy(),
            "motion_blur": _as_dict(self.motion_blur),
            "shadow": _as_dict(self.shadow),
            "glare": _as_dict(self.glare),
            "exposure": _as_dict(self.exposure),
            "jpeg_quality": self.jpeg_quality,
        }


def _as_dict(value: object) -> dict | None:
    if value is None:
        return None
    out = {}
    for k, v in vars(value).items():
        out[k] = [list(p) for p in v] if k == "polygon_m" else (list(v) if k == "center_px" else v)
    return out


def _range(value: tuple[float, float] | float, name: str, lo: float) -> tuple[float, float]:
    if isinstance(value, int | float):
        value = (value, value)
    try:
        a, b = (_finite(v, name) for v in value)
    except TypeError as exc:
        raise ValueError(f"{name} must be a number or a (low, high) pair, got {value!r}") from exc
    if a > b or a < lo:
        raise ValueError(f"{name} must be a range (low <= high) with low >= {lo}, got {value!r}")
    return a, b


def random_view(
    rng: np.random.Generator,
    camera: Camera,
    *,
    altitude: tuple[float, float] = (1.0, 6.0),
    max_tilt_deg: float = 12.0,
    snr_db: tuple[float, float] | None = (15.0, 30.0),
    max_blur_px: float = 1.2,
    whole_pad_in_view: bool = True,
    pad_size_m: float = PAD_SIZE_M,
    margin_px: float = 8.0,
    lighting: bool = True,
    realistic: bool = False,
    min_tilt_deg: float = 0.0,
    yaw_deg: float | None = None,
) -> View:
    """A random pose and degradations, as the accuracy benchmark samples them.

    Altitude uniform in ``altitude`` (metres), tilt uniform in [min_tilt_deg,
    max_tilt_deg] (a fixed tilt when they are equal) toward
    a uniform direction, yaw uniform (or ``yaw_deg``: the camera's yaw in the pad
    frame, 0 with the H's strokes along the image's rows and columns), the pad's
    centre at a uniform image position
    such that (with ``whole_pad_in_view``) all four board corners are at least
    ``margin_px`` inside the image; SNR uniform in ``snr_db`` (None: no noise), blur
    sigma uniform in [0, max_blur_px], random lighting (``lighting``). ``realistic``
    adds the real world's degradations (`random_extras`), drawn after all the others
    so that the rest of the view is the same as without them.

    Examples
    --------
    >>> v = random_view(np.random.default_rng(0), Camera.from_fov(640, 480, 60.0))
    >>> 1.0 <= v.altitude_m <= 6.0 and v.tilt_deg <= 12.0
    True
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError("rng must be a numpy.random.Generator")
    if not isinstance(camera, Camera):
        raise ValueError(f"camera must be a pipeline.camera.Camera, got {type(camera).__name__}")
    alt_lo, alt_hi = _range(altitude, "altitude", 0.0)
    if alt_lo <= 0:
        raise ValueError(f"altitude must be above 0 m, got {altitude!r}")
    max_tilt = _finite(max_tilt_deg, "max_tilt_deg")
    if not 0 <= max_tilt < 60:
        raise ValueError(f"max_tilt_deg must be in [0, 60), got {max_tilt}")
    min_tilt = _finite(min_tilt_deg, "min_tilt_deg")
    fixed_yaw = None if yaw_deg is None else _finite(yaw_deg, "yaw_deg")
    if not 0 <= min_tilt <= max_tilt:
        raise ValueError(f"min_tilt_deg must be in [0, max_tilt_deg], got {min_tilt}")
    snr = None if snr_db is None else _range(snr_db, "snr_db", -math.inf)
    blur = _finite(max_blur_px, "max_blur_px")
    if blur < 0:
        raise ValueError(f"max_blur_px must be >= 0, got {blur}")
    size = _finite(pad_size_m, "pad_size_m")
    if size <= 0:
        raise ValueError(f"pad_size_m must be positive, got {size}")
    margin = _finite(margin_px, "margin_px")

    half = size / 2
    corners = np.array([(-half, half), (half, half), (half, -half), (-half, -half)])
    Kinv = np.linalg.inv(camera.K)
    W, H = camera.width, camera.height
    for _attempt in range(200):
        alt = float(rng.uniform(alt_lo, alt_hi))
        yaw = float(rng.uniform(-180.0, 180.0))  # (drawn all the same: the rest as without)
        if fixed_yaw is not None:
            yaw = fixed_yaw
        tilt = float(rng.uniform(min_tilt, max_tilt))
        tdir = float(rng.uniform(0.0, 360.0))
        R = camera_rotation(yaw, tilt_deg=tilt, tilt_dir_deg=tdir)
        if whole_pad_in_view:
            # Where the pad lands with its centre on the optical axis, to bound the
            # image positions that keep all of it inside.
            base = _position_for_pixel(R, Kinv, camera.K[:2, 2], alt)
            px = project_points(camera, base, R, corners)
            ext_lo = camera.K[:2, 2] - px.min(axis=0)
            ext_hi = px.max(axis=0) - camera.K[:2, 2]
            lo = ext_lo + margin
            hi = np.array([W - 1, H - 1]) - ext_hi - margin
            if np.any(lo > hi):
                continue
        else:
            lo, hi = np.zeros(2), np.array([W - 1.0, H - 1.0])
        target = rng.uniform(lo, hi)
        # Aim through the undistorted pixel of the target so distortion is respected.
        und = camera.undistort_points(target[None])[0]
        pos = _position_for_pixel(R, Kinv, und, alt)
        if whole_pad_in_view:
            px = project_points(camera, pos, R, corners)
            inside = (px >= margin).all() and (px[:, 0] <= W - 1 - margin).all()
            if not (inside and (px[:, 1] <= H - 1 - margin).all()):
                continue
        view = View(
            position_m=pos,
            R_pad_cam=R,
            yaw_deg=yaw,
            tilt_deg=tilt,
            tilt_dir_deg=tdir,
            snr_db=None if snr is None else float(rng.uniform(*snr)),
            blur_sigma_px=float(rng.uniform(0.0, blur)),
            light=random_lighting(rng) if lighting else None,
        )
        if realistic:
            view = dataclasses.replace(view, **random_extras(rng, camera, pos, R, size))
        return view
    raise ValueError(
        f"altitude: no pose in {altitude!r} m keeps a {size} m pad inside the "
        f"{W}x{H} image with a {margin} px margin"
    )


def random_extras(
    rng: np.random.Generator,
    camera: Camera,
    position_m: np.ndarray,
    R_pad_cam: np.ndarray,
    pad_size_m: float,
) -> dict:
    """The real world's degradations for one view, each present with some chance.

    Motion blur (60 %: 0.5-5 px, any direction), a soft shadow across the pad (40 %:
    a pole's or branch's band, or a building's edge, taking 30-70 % of the light),
    sun glare on or beside the pad (30 %: saturating), an exposure error (60 %: gain
    0.6-1.7, gamma 0.7-1.4) and JPEG compression (80 %: quality 30-95). Returns
    `View` fields.
    """
    out: dict = {}
    if rng.random() < 0.6:
        out["motion_blur"] = MotionBlur(float(rng.uniform(0.5, 5.0)), float(rng.uniform(0, 180)))
    if rng.random() < 0.4:
        out["shadow"] = _random_shadow(rng, pad_size_m)
    if rng.random() < 0.3:
        centre = project_points(camera, position_m, R_pad_cam, np.zeros((1, 2)))[0]
        span = (
            float(
                np.linalg.norm(
                    project_points(camera, position_m, R_pad_cam, np.array([(0.5, 0.0)])) - centre
                )
            )
            * pad_size_m
        )
        offset = rng.uniform(-1.0, 1.0, 2) * span
        out["glare"] = Glare(
            (float(centre[0] + offset[0]), float(centre[1] + offset[1])),
            float(max(2.0, span * rng.uniform(0.15, 0.6))),
            float(rng.uniform(80.0, 400.0)),
        )
    if rng.random() < 0.6:
        out["exposure"] = Exposure(float(rng.uniform(0.6, 1.7)), float(rng.uniform(0.7, 1.4)))
    if rng.random() < 0.8:
        out["jpeg_quality"] = int(rng.integers(30, 96))
    return out


def _random_shadow(rng: np.random.Generator, size: float) -> Shadow:
    """A band (a pole, a branch) or a half-plane (a wall's edge) across the pad."""
    ang = rng.uniform(0, math.pi)
    d = np.array([math.cos(ang), math.sin(ang)])
    n = np.array([-d[1], d[0]])
    through = rng.uniform(-0.3, 0.3, 2) * size
    if rng.random() < 0.6:
        half_w = rng.uniform(0.04, 0.25) * size
        near, far = -half_w, half_w
    else:
        near, far = 0.0, 20.0 * size  # everything on one side of an edge
    length = 20.0 * size
    pts = [
        through + n * near - d * length,
        through + n * near + d * length,
        through + n * far + d * length,
        through + n * far - d * length,
    ]
    return Shadow(
        tuple((float(p[0]), float(p[1])) for p in pts),
        darkness=float(rng.uniform(0.3, 0.7)),
        softness_px=float(rng.uniform(0.5, 4.0)),
    )


def _position_for_pixel(
    R: np.ndarray, Kinv: np.ndarray, pixel: np.ndarray, alt: float
) -> np.ndarray:
    """The camera centre at height ``alt`` that sees the pad centre at an undistorted pixel."""
    d = R @ (Kinv @ np.array([pixel[0], pixel[1], 1.0]))
    if d[2] >= 0:
        raise ValueError("R_pad_cam: that pixel's ray does not reach the pad plane")
    # c + t d = 0 with t > 0 and c_z = alt gives c = alt / d_z * d.
    return alt / d[2] * d


def render_view(
    scene: Scene, camera: Camera, view: View, rng: np.random.Generator | None
) -> np.ndarray:
    """`render` the scene from ``view`` with its degradations (``rng`` for the noise)."""
    if not isinstance(view, View):
        raise ValueError(f"view must be a View, got {type(view).__name__}")
    return render(
        scene,
        camera,
        view.position_m,
        view.R_pad_cam,
        snr_db=view.snr_db,
        blur_sigma_px=view.blur_sigma_px,
        light=view.light,
        rng=rng,
        shadow=view.shadow,
        glare=view.glare,
        motion_blur=view.motion_blur,
        exposure=view.exposure,
        jpeg_quality=view.jpeg_quality,
    )
