"""Perspective rendering of the flat scene through a pinhole camera with lens distortion.

Every output pixel is traced back to the pad plane (an inverse map), so edges land
where `cv2.projectPoints` puts them. The floor is drawn at the output resolution from
a mip level chosen by the pixel footprint; the pictures on it (pad, look-alikes) are
drawn at ``supersample`` times the resolution inside their bounding boxes only and
area-averaged down, so their edges are anti-aliased and exact to a fraction of a pixel.
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.render.degrade import (
    Exposure,
    Glare,
    Lighting,
    MotionBlur,
    Shadow,
    check_degradations,
    check_extras,
    degrade,
)
from pipeline.render.scene import Decal, Scene

SKY_BGR = (215, 200, 185)
"""What a camera tilted above the horizon sees."""

_COARSE_STEP = 8  # stride of the coarse undistortion grid used to find bounding boxes


def check_pose(position_m: np.ndarray, R_pad_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate a camera pose over the pad plane; return float64 copies.

    Raises ValueError when the position is not 3 finite numbers or not above the plane
    (z > 0), or when R_pad_cam is not a rotation or points the camera's optical axis
    at or above the horizon (it would not see the plane).
    """
    try:
        pos = np.asarray(position_m, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"position_m must be 3 numbers: {exc}") from exc
    if pos.shape != (3,) or not np.all(np.isfinite(pos)):
        raise ValueError(f"position_m must be 3 finite numbers, got {position_m!r}")
    if pos[2] <= 0:
        raise ValueError(f"position_m: the camera must be above the pad plane (z > 0), got {pos}")
    try:
        R = np.asarray(R_pad_cam, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"R_pad_cam must be a 3x3 rotation matrix: {exc}") from exc
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ValueError("R_pad_cam must be a finite 3x3 rotation matrix")
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise ValueError("R_pad_cam must be a rotation matrix (orthonormal, det +1)")
    if R[2, 2] >= 0:
        raise ValueError(
            "R_pad_cam: the camera looks away from the pad plane (optical axis not downward)"
        )
    return pos.copy(), R.copy()


def pixel_from_plane(K: np.ndarray, position_m: np.ndarray, R_pad_cam: np.ndarray) -> np.ndarray:
    """Homography from pad-plane points (x, y, 1) to undistorted pixels (u, v, 1) * w."""
    R_cam_pad = R_pad_cam.T
    t = -R_cam_pad @ position_m
    return K @ np.column_stack([R_cam_pad[:, 0], R_cam_pad[:, 1], t])


def project_points(
    camera: Camera, position_m: np.ndarray, R_pad_cam: np.ndarray, points_m: np.ndarray
) -> np.ndarray:
    """Pixel positions (N x 2) of pad-frame points (N x 2 on the plane, or N x 3).

    The same projection as the renderer: ``cv2.projectPoints`` with the camera's K
    and distortion.

    Examples
    --------
    >>> cam = Camera.from_fov(640, 480, 60.0)
    >>> R = np.diag([1.0, -1.0, -1.0])  # looking straight down, yaw 0
    >>> project_points(cam, np.array([0, 0, 2.0]), R, np.zeros((1, 2))).round(2).tolist()
    [[319.5, 239.5]]
    """
    pos, R = check_pose(position_m, R_pad_cam)
    pts = np.asarray(points_m, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"points_m must be N x 2 or N x 3, got shape {pts.shape}")
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    if len(pts) == 0:
        return np.zeros((0, 2))
    R_cam_pad = R.T
    rvec, _ = cv2.Rodrigues(R_cam_pad)
    tvec = -R_cam_pad @ pos
    out, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), rvec, tvec, camera.K, camera.dist)
    return out.reshape(-1, 2)


def render(
    scene: Scene,
    camera: Camera,
    position_m: np.ndarray,
    R_pad_cam: np.ndarray,
    *,
    snr_db: float | None = None,
    blur_sigma_px: float = 0.0,
    light: Lighting | None = None,
    rng: np.random.Generator | None = None,
    supersample: int = 2,
    shadow: Shadow | None = None,
    glare: Glare | None = None,
    motion_blur: MotionBlur | None = None,
    exposure: Exposure | None = None,
    jpeg_quality: int | None = None,
) -> np.ndarray:
    """The camera's picture of the scene, with optional degradations.

    Parameters
    ----------
    scene : from `make_scene`.
    camera : intrinsics; a non-zero ``camera.dist`` is rendered through.
    position_m : the camera centre in the pad frame (z > 0: above the plane).
    R_pad_cam : rotation from camera frame (OpenCV) to pad frame; the optical axis
        must point below the horizon.
    snr_db : white Gaussian noise at this SNR (signal power measured on the image),
        None for none; needs ``rng``.
    blur_sigma_px : Gaussian blur, sigma in pixels (0: none).
    light : illumination gain, gradient and vignetting (None: none).
    rng : numpy Generator for the noise.
    supersample : resolution factor for the pictures on the floor (1..4).
    shadow : a soft shadow cast on the ground (a convex polygon on the pad plane).
    glare, motion_blur, exposure, jpeg_quality : see `pipeline.render.degrade`.

    Returns
    -------
    BGR uint8 image, ``camera.height`` x ``camera.width``.

    Examples
    --------
    >>> from pipeline.render import camera_rotation, make_pad_image, make_scene
    >>> scene = make_scene(make_pad_image(256), 0.55, rng=0, floor="plain")
    >>> cam = Camera.from_fov(160, 120, 60.0)
    >>> img = render(scene, cam, np.array([0, 0, 2.0]), camera_rotation(0.0))
    >>> img.shape, int(img[60, 80].mean()) > 200  # the H's crossbar at the centre
    ((120, 160, 3), True)
    """
    if not isinstance(scene, Scene):
        raise ValueError(f"scene must be a Scene (from make_scene), got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise ValueError(f"camera must be a pipeline.camera.Camera, got {type(camera).__name__}")
    pos, R = check_pose(position_m, R_pad_cam)
    check_degradations(snr_db, blur_sigma_px, light, rng)
    check_extras(motion_blur, glare, exposure, jpeg_quality)
    if shadow is not None and not isinstance(shadow, Shadow):
        raise ValueError(f"shadow must be a Shadow or None, got {shadow!r}")
    if isinstance(supersample, bool) or supersample not in (1, 2, 3, 4):
        raise ValueError(f"supersample must be 1, 2, 3 or 4, got {supersample!r}")
    clean = render_clean(scene, camera, pos, R, supersample=supersample)
    shade = None if shadow is None else shadow_map(shadow, camera, pos, R)
    return degrade(
        clean,
        light=light,
        blur_sigma_px=blur_sigma_px,
        snr_db=snr_db,
        rng=rng,
        shade=shade,
        glare=glare,
        motion_blur=motion_blur,
        exposure=exposure,
        jpeg_quality=jpeg_quality,
    )


def shadow_map(shadow: Shadow, camera: Camera, pos: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Per-pixel light factor (float32) of a shadow on the ground: 1 - darkness inside.

    Every pixel's ray is traced to the plane and tested against the (convex) polygon's
    edges, so the shadow lies on the ground under any perspective and distortion; the
    penumbra is a Gaussian of ``softness_px`` in the image.
    """
    maps = _camera_maps(camera, 1)
    G = np.linalg.inv(pixel_from_plane(camera.K, pos, R))
    u = maps.undistorted
    q = u[..., 0:1] * G[:, 0] + u[..., 1:2] * G[:, 1] + G[:, 2]  # H x W x 3
    w = q[..., 2]
    ground = w > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = q[..., 0] / w, q[..., 1] / w
    pts = np.asarray(shadow.polygon_m, np.float64)
    area2 = np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
    inside = ground.copy()
    for a, b in zip(pts, np.roll(pts, -1, axis=0), strict=True):
        cross = (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
        inside &= (cross >= 0) if area2 > 0 else (cross <= 0)
    mask = inside.astype(np.float32)
    if shadow.softness_px > 0:
        mask = cv2.GaussianBlur(mask, (0, 0), float(shadow.softness_px))
    return (1.0 - np.float32(shadow.darkness) * mask).astype(np.float32)


def render_clean(
    scene: Scene, camera: Camera, pos: np.ndarray, R: np.ndarray, *, supersample: int = 2
) -> np.ndarray:
    """The undegraded picture as float32 BGR (0..255); inputs already validated."""
    W, H = camera.width, camera.height
    maps = _camera_maps(camera, 1)
    G = np.linalg.inv(pixel_from_plane(camera.K, pos, R))  # pixel -> plane
    img = _render_floor(scene, camera, G, maps).astype(np.float32)

    ss = int(supersample)
    ss_cam = camera.scaled(W * ss, H * ss) if ss > 1 else camera
    G_ss = np.linalg.inv(pixel_from_plane(ss_cam.K, pos, R))
    ss_maps = _camera_maps(camera, ss) if camera.has_distortion else None
    for decal in scene.decals:
        roi = _decal_roi(decal, camera, pos, R, maps)
        if roi is None:
            continue
        _draw_decal(img, decal, roi, G_ss, ss, ss_maps)

    sky = _sky_mask(G, maps, W, H)
    if sky is not None:
        img[sky] = SKY_BGR
    return img


class _CameraMaps:
    """Per camera (and supersampling factor): every pixel's undistorted position."""

    def __init__(self, camera: Camera, ss: int) -> None:
        cam = camera.scaled(camera.width * ss, camera.height * ss) if ss > 1 else camera
        W, H = cam.width, cam.height
        self.distorted = camera.has_distortion
        xs, ys = np.meshgrid(np.arange(W, dtype=np.float32), np.arange(H, dtype=np.float32))
        grid = np.dstack([xs, ys])
        if self.distorted:
            crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
            und = cv2.undistortPoints(
                grid.reshape(-1, 1, 2).astype(np.float64), cam.K, cam.dist, P=cam.K, criteria=crit
            )
            grid = und.reshape(H, W, 2).astype(np.float32)
        self.undistorted = grid
        # A coarse copy (every few pixels, borders included) to find bounding boxes fast.
        rows = np.unique(np.r_[np.arange(0, H, _COARSE_STEP), H - 1])
        cols = np.unique(np.r_[np.arange(0, W, _COARSE_STEP), W - 1])
        self.coarse_rows, self.coarse_cols = rows, cols
        self.coarse = grid[np.ix_(rows, cols)]


@functools.lru_cache(maxsize=8)
def _maps_cached(w: int, h: int, K: bytes, dist: bytes, ss: int) -> _CameraMaps:
    cam = Camera(w, h, np.frombuffer(K).reshape(3, 3).copy(), np.frombuffer(dist).copy())
    return _CameraMaps(cam, ss)


def _camera_maps(camera: Camera, ss: int) -> _CameraMaps:
    return _maps_cached(
        camera.width, camera.height, camera.K.tobytes(), camera.dist.tobytes(), int(ss)
    )


def _footprint_texels(G: np.ndarray, A: np.ndarray, pixel: np.ndarray) -> float:
    """Level-0 texels per pixel (geometric mean of the two axes) around ``pixel``."""
    M = A @ G
    p = np.array([[pixel[0], pixel[1], 1.0], [pixel[0] + 1, pixel[1], 1.0]])
    p = np.vstack([p, [pixel[0], pixel[1] + 1, 1.0]])
    q = p @ M.T
    if np.any(q[:, 2] <= 0):
        return 1.0
    q = q[:, :2] / q[:, 2:]
    du, dv = q[1] - q[0], q[2] - q[0]
    return math.sqrt(abs(du[0] * dv[1] - du[1] * dv[0]))


def _pick_level(texels_per_px: float, n_levels: int) -> int:
    """The mip level with about one texel per pixel (rounded in log2)."""
    if texels_per_px <= 1:
        return 0
    return int(min(n_levels - 1, max(0, round(math.log2(texels_per_px)))))


def _render_floor(scene: Scene, camera: Camera, G: np.ndarray, maps: _CameraMaps) -> np.ndarray:
    W, H = camera.width, camera.height
    centre = np.array([camera.K[0, 2], camera.K[1, 2]])
    # Choose the level where the view's centre has ~1 texel per pixel.
    rate = _footprint_texels(G, scene.floor_texel_from_plane(0), centre)
    level = _pick_level(rate, len(scene.floor_levels))
    tex = scene.floor_levels[level]
    M = scene.floor_texel_from_plane(level) @ G
    if not maps.distorted:
        return cv2.warpPerspective(
            tex,
            M,
            (W, H),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_WRAP,
        )
    uv = cv2.perspectiveTransform(maps.undistorted.reshape(-1, 1, 2), M).reshape(H, W, 2)
    return cv2.remap(tex, uv, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)


def _decal_roi(
    decal: Decal, camera: Camera, pos: np.ndarray, R: np.ndarray, maps: _CameraMaps
) -> tuple[int, int, int, int] | None:
    """The output pixels (x0, y0, x1, y1), end exclusive, the decal may cover; None if none."""
    W, H = camera.width, camera.height
    corners = np.column_stack([decal.corners_m, np.zeros(4)])
    cam_pts = (corners - pos) @ R  # rows: R_cam_pad @ (P - pos)
    if np.any(cam_pts[:, 2] <= 1e-6):
        return (0, 0, W, H)  # partly behind the camera: let the per-pixel maps decide
    und = cam_pts[:, :2] / cam_pts[:, 2:] * [camera.fx, camera.fy] + camera.K[:2, 2]
    und[:, 0] += camera.K[0, 1] * cam_pts[:, 1] / cam_pts[:, 2]  # skew, if any
    lo, hi = und.min(axis=0), und.max(axis=0)
    if not maps.distorted:
        x0, y0 = math.floor(lo[0]) - 2, math.floor(lo[1]) - 2
        x1, y1 = math.ceil(hi[0]) + 3, math.ceil(hi[1]) + 3
    else:
        # Which pixels' undistorted positions fall in the box: search the coarse grid.
        c = maps.coarse
        inside = np.all((c >= lo) & (c <= hi), axis=-1)
        if not inside.any():
            # The box may still fall between grid nodes: test its centre's pixel directly.
            mid = np.array([[(lo + hi) / 2]], np.float64)
            px = _distort(camera, mid)
            if not (0 <= px[0] < W and 0 <= px[1] < H):
                return None
            x0 = x1 = int(px[0])
            y0 = y1 = int(px[1])
        else:
            rows = maps.coarse_rows[inside.any(axis=1)]
            cols = maps.coarse_cols[inside.any(axis=0)]
            x0, x1, y0, y1 = cols.min(), cols.max(), rows.min(), rows.max()
        pad = _COARSE_STEP + 2
        x0, y0, x1, y1 = x0 - pad, y0 - pad, x1 + pad + 1, y1 + pad + 1
    x0, y0 = max(0, int(x0)), max(0, int(y0))
    x1, y1 = min(W, int(x1)), min(H, int(y1))
    if x1 <= x0 or y1 <= y0:
        return None
    return (x0, y0, x1, y1)


def _distort(camera: Camera, und_px: np.ndarray) -> np.ndarray:
    """Undistorted pixel -> distorted pixel (for one point)."""
    K = camera.K
    x = (und_px.reshape(-1, 2) - K[:2, 2]) / [K[0, 0], K[1, 1]]
    pts = np.column_stack([x, np.ones(len(x))])
    out, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, camera.dist)
    return out.reshape(-1, 2)[0]


def _draw_decal(
    img: np.ndarray,
    decal: Decal,
    roi: tuple[int, int, int, int],
    G_ss: np.ndarray,
    ss: int,
    ss_maps: _CameraMaps | None,
) -> None:
    """Composite one decal into ``img`` (float32) inside ``roi``, supersampled by ``ss``."""
    x0, y0, x1, y1 = roi
    w, h = (x1 - x0) * ss, (y1 - y0) * ss
    X0, Y0 = x0 * ss, y0 * ss
    centre = np.array([X0 + w / 2, Y0 + h / 2])
    rate = _footprint_texels(G_ss, decal.texel_from_plane[0], centre)
    level = _pick_level(rate, len(decal.levels))
    tex = decal.levels[level]
    M = decal.texel_from_plane[level] @ G_ss
    if ss_maps is None:
        shift = np.array([[1, 0, X0], [0, 1, Y0], [0, 0, 1]], np.float64)
        patch = cv2.warpPerspective(
            tex,
            M @ shift,
            (w, h),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0, 0),
        )
    else:
        und = ss_maps.undistorted[Y0 : Y0 + h, X0 : X0 + w]
        uv = cv2.perspectiveTransform(np.ascontiguousarray(und).reshape(-1, 1, 2), M)
        patch = cv2.remap(
            tex,
            uv.reshape(h, w, 2),
            None,
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0, 0),
        )
    if not patch[..., 3].any():
        return
    patch = patch.astype(np.float32)
    if ss > 1:
        patch = cv2.resize(patch, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
    alpha = patch[..., 3:4] * np.float32(1 / 255)
    view = img[y0:y1, x0:x1]
    view *= 1 - alpha
    view += patch[..., :3]


def _sky_mask(G: np.ndarray, maps: _CameraMaps, W: int, H: int) -> np.ndarray | None:
    """Pixels whose rays miss the plane (above the horizon); None when there are none."""
    g = G[2]
    c = maps.coarse
    if not maps.distorted:
        corners = np.array([[0, 0], [W - 1, 0], [0, H - 1], [W - 1, H - 1]], np.float64)
        if np.all(corners @ g[:2] + g[2] > 0):
            return None
    elif np.all(c[..., 0] * g[0] + c[..., 1] * g[1] + g[2] > 0):
        return None
    u = maps.undistorted
    return (u[..., 0] * g[0] + u[..., 1] * g[1] + g[2]) <= 0
