"""Planar pose: the camera's pose over the pad from pad-to-image correspondences."""

from __future__ import annotations

import math

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.jit import compiled, plain, solve
from pipeline.planar_projection import (
    plane_pixels,
    project_plane,
    projected,
    rotation_and_derivatives,
)
from pipeline.result import Pose, yaw_of

# A 180 degree turn about the pad's z axis.
TURN = np.diag([-1.0, -1.0, 1.0])


def _object(points_m: np.ndarray) -> np.ndarray:
    pts = np.asarray(points_m, np.float64).reshape(-1, 2)
    return np.column_stack([pts, np.zeros(len(pts))])


def ippe_candidates(
    points_m: np.ndarray, image_px: np.ndarray, camera: Camera
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Both poses IPPE finds for >= 4 coplanar pad points (z = 0) and their pixels.

    A small or distant plane seen nearly head-on has two poses that fit its
    corners almost equally well (tilted one way or the other); the caller
    decides between them with more evidence. Poses behind the camera are dropped.
    """
    obj = _object(points_m)
    img = np.asarray(image_px, np.float64).reshape(-1, 1, 2)
    if len(obj) < 4:
        return []
    try:
        _, rvecs, tvecs, _ = cv2.solvePnPGeneric(
            obj, img, camera.K, camera.dist, flags=cv2.SOLVEPNP_IPPE
        )
    except cv2.error:
        return []
    return [(r.copy(), t.copy()) for r, t in zip(rvecs, tvecs, strict=True) if t[2, 0] > 0]


def rotation_angle_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """The angle between two rotation matrices, degrees."""
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return math.degrees(math.acos(float(np.clip(c, -1.0, 1.0))))


def tilt_deg(rvec: np.ndarray) -> float:
    """Angle between the camera's optical axis and straight down onto the pad."""
    # The pad's +z in camera coordinates is R_cam_pad[:, 2]; looking down, the
    # optical axis (camera +z) points along pad -z.
    up = pad_normal_in_camera(rvec)
    return _degrees(math.acos(min(max(-float(up[2]), -1.0), 1.0)))


def to_pose(
    rvec: np.ndarray,
    tvec: np.ndarray,
    rms: float,
    symmetric: bool,
    ambiguous: bool = False,
    lean: np.ndarray | None = None,
) -> Pose:
    """Turn OpenCV's pad->camera (rvec, tvec) into the camera's pose in the pad frame
    (``lean``: `lean_rotation`'s, of the pose the pixels alone give)."""
    R_cam_pad, _ = cv2.Rodrigues(rvec)
    R_pad_cam = R_cam_pad.T
    position = -R_pad_cam @ np.asarray(tvec, np.float64).reshape(3)
    lean_deg = None if lean is None else _degrees(math.sqrt(float(lean @ lean)))
    return Pose(position, R_pad_cam, rms, symmetric, ambiguous, lean_deg, lean)


def camera_height_m(rvec: np.ndarray, tvec: np.ndarray) -> float:
    """The camera's height over the pad's plane under OpenCV's pad -> camera pose
    (negative: under it, where no camera sees a pad lying on the ground).

    Examples
    --------
    >>> down = np.diag([1.0, -1.0, -1.0])  # camera axes in the pad frame, looking down
    >>> rvec, _ = cv2.Rodrigues(down.T)
    >>> round(camera_height_m(rvec, -down.T @ np.array([0.2, 0.1, 3.0])), 6)
    3.0
    """
    R, _ = cv2.Rodrigues(np.asarray(rvec, np.float64).reshape(3, 1))
    return float(-(R[:, 2] @ np.asarray(tvec, np.float64).reshape(3)))


def half_turn(centre_m: np.ndarray) -> np.ndarray:
    """The half turn of the pad plane about ``centre_m`` (x, y metres), as a 3 x 3
    homography of pad metres."""
    cx, cy = (float(v) for v in np.asarray(centre_m, np.float64).reshape(2))
    return np.array([[-1.0, 0.0, 2.0 * cx], [0.0, -1.0, 2.0 * cy], [0.0, 0.0, 1.0]])


def turn_about(centre_m: np.ndarray, deg: float) -> np.ndarray:
    """The turn of the pad plane by ``deg`` degrees counter-clockwise about ``centre_m``
    (x, y metres), as a 3 x 3 homography of pad metres.

    >>> np.round(turn_about(np.array([1.0, 0.0]), 90.0) @ [2.0, 0.0, 1.0], 9) + 0.0
    array([1., 1., 1.])
    """
    t = math.radians(float(deg))
    c, s = math.cos(t), math.sin(t)
    cx, cy = (float(v) for v in np.asarray(centre_m, np.float64).reshape(2))
    return np.array([[c, -s, cx - c * cx + s * cy], [s, c, cy - s * cx - c * cy], [0.0, 0.0, 1.0]])


def turned(pose: Pose, centre_m: np.ndarray | None = None) -> Pose:
    """The pose's twin for a pad (or an H centred at ``centre_m`` on it, default the
    pad's centre) that looks the same after a 180 degree turn about that centre."""
    centre = np.zeros(3)
    if centre_m is not None:
        centre[:2] = np.asarray(centre_m, np.float64).reshape(2)
    return Pose(
        centre + TURN @ (pose.position_m - centre),
        TURN @ pose.R_pad_cam,
        pose.reprojection_px,
        True,
        pose.ambiguous,
        pose.lean_deg,  # (the twin lies as level)
        pose.lean_rotation,
    )


def pick_by_yaw(pose: Pose, yaw_hint: float | None, centre_m: np.ndarray | None = None) -> Pose:
    """Of a symmetric pose and its twin (turned about ``centre_m``), the one whose yaw is
    nearer ``yaw_hint``."""
    if yaw_hint is None or not pose.symmetric:
        return pose
    twin = turned(pose, centre_m)
    return pose if _angle_diff(yaw_of(pose.R_pad_cam), yaw_hint) <= 90.0 else twin


def project(points_m: np.ndarray, rvec: np.ndarray, tvec: np.ndarray, camera: Camera) -> np.ndarray:
    """Pixels of pad points (N x 2 on the pad plane, or N x 3)."""
    pts = np.asarray(points_m, np.float64)
    if pts.shape[1] == 2:
        return plane_pixels(pts, rvec, tvec, camera)  # (compiled: a frame asks a few)
    proj, _ = cv2.projectPoints(pts, rvec, tvec, camera.K, camera.dist)
    return proj.reshape(-1, 2)


def pose_to_vectors(pose: Pose) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's pad->camera (rvec, tvec) for a pose."""
    R_cam_pad = np.asarray(pose.R_pad_cam).T
    tvec = -R_cam_pad @ np.asarray(pose.position_m, np.float64)
    rvec, _ = cv2.Rodrigues(R_cam_pad)
    return rvec, tvec.reshape(3, 1)


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def pad_normal_in_camera(rvec: np.ndarray) -> np.ndarray:
    """The pad's up direction (its +z) in the camera frame, for OpenCV's pad->camera rvec."""
    return _third_column(plain(rvec).reshape(3))


@compiled
def _third_column(r):
    """cv2.Rodrigues(r)[0][:, 2], as OpenCV computes it (the same operations in the
    same order: the same numbers; a frame asks for a dozen)."""
    theta = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    out = np.zeros(3)
    if theta < 2.220446049250313e-16:  # (DBL_EPSILON: the identity)
        out[2] = 1.0
        return out
    c, s = math.cos(theta), math.sin(theta)
    c1 = 1.0 - c
    inv = 1.0 / theta
    x, y, z = r[0] * inv, r[1] * inv, r[2] * inv
    # R = c I + c1 r r^T + s [r]x
    out[0] = (c * 0.0 + c1 * (x * z)) + s * y
    out[1] = (c * 0.0 + c1 * (y * z)) + s * -x
    out[2] = (c * 1.0 + c1 * (z * z)) + s * 0.0
    return out


def tilt_from_level_deg(rvec: np.ndarray, gravity_cam: np.ndarray) -> float:
    """Angle between the pad's up and straight up (against gravity), degrees."""
    n = pad_normal_in_camera(rvec)
    c = -float(np.dot(n, gravity_cam))
    return _degrees(math.acos(min(max(c, -1.0), 1.0)))


def lean_rotation(rvec: np.ndarray, gravity_cam: np.ndarray) -> np.ndarray:
    """The rotation (camera frame, a rotation vector in radians) that turns up as
    ``gravity_cam`` gives it onto the pad's up under ``rvec``: how the pose leans the pad
    from level, and which way (its length is `tilt_from_level_deg`'s angle).

    >>> rvec, _ = cv2.Rodrigues(np.diag([1.0, -1.0, -1.0]))  # looking straight down
    >>> tilted = np.array([math.sin(0.1), 0.0, math.cos(0.1)])  # down, 0.1 rad off
    >>> (np.round(lean_rotation(rvec, tilted), 6) + 0.0).tolist()  # (about the camera's y)
    [0.0, -0.1, 0.0]
    """
    up = -np.asarray(gravity_cam, np.float64).reshape(3)
    n = pad_normal_in_camera(rvec)
    # (np.cross's products, written out: its call costs more than a frame's use of it)
    axis = np.array(
        [up[1] * n[2] - up[2] * n[1], up[2] * n[0] - up[0] * n[2], up[0] * n[1] - up[1] * n[0]]
    )
    s = math.sqrt(float(axis @ axis))
    return axis * (math.atan2(s, float(up @ n)) / s) if s > 1e-12 else np.zeros(3)


def _degrees(radians: float) -> float:
    """``np.degrees`` of a float (its multiplication; numpy's call on one number costs more)."""
    return radians * (180.0 / math.pi)


def refine_with_gravity(
    points_m: np.ndarray,
    image_px: np.ndarray,
    camera: Camera,
    rvec: np.ndarray,
    tvec: np.ndarray,
    gravity_cam: np.ndarray,
    *,
    sigma_px: float = 0.3,
    sigma_deg: float = 2.0,
    iterations: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """The pose that fits the pad's pixels and lies level under known gravity.

    Gauss-Newton over OpenCV's (rvec, tvec) on the reprojection errors (each
    ``sigma_px``) and the angle between the pad's up and the gravity hint
    (``sigma_deg``: what the autopilot's attitude and the camera's mount are
    good for). A small pad seen nearly head on pins its tilt poorly from its
    pixels alone; the attitude pins it, and the pixels the rest.

    Examples
    --------
    >>> from pipeline.render import PadGeometry, camera_rotation
    >>> from pipeline.result import Pose
    >>> cam = Camera.from_fov(640, 480, 60.0)
    >>> pts = PadGeometry().h_corners_m
    >>> R = camera_rotation(20.0, tilt_deg=4.0, tilt_dir_deg=60.0)
    >>> r, t = pose_to_vectors(Pose(np.array([0.2, -0.1, 5.0]), R, 0.0, True))
    >>> px = project(pts, r, t, cam)
    >>> g = -pad_normal_in_camera(r)  # the truth's gravity
    >>> r1, t1 = refine_with_gravity(pts, px, cam, r + 0.02, t * 1.05, g)
    >>> bool(np.abs(to_pose(r1, t1, 0.0, True).position_m - [0.2, -0.1, 5.0]).max() < 1e-3)
    True
    """
    pts = plain(points_m).reshape(-1, 2)
    img = plain(image_px).reshape(-1, 2)
    g = np.asarray(gravity_cam, np.float64).reshape(3)
    g = g / math.sqrt(float(g.dot(g)))
    r = np.asarray(rvec, np.float64).reshape(3).copy()
    t = np.asarray(tvec, np.float64).reshape(3).copy()
    w_px = 1.0 / sigma_px
    w_g = 1.0 / np.radians(sigma_deg)
    k = camera.brown_conrady
    if k is not None:  # (a frame takes a few of these fits: their loop compiled)
        _gravity_steps(pts, img, r, t, camera.K, k, g, w_px, w_g, iterations)
        return r.reshape(3, 1), t.reshape(3, 1)
    for _ in range(iterations):
        proj, jac = project_plane(pts, r, t, camera)
        R, dR = cv2.Rodrigues(r)  # dR: d(R's 9 entries, row by row) / d(rvec), 3 x 9
        step, solved = _gravity_step(proj, jac.reshape(-1, 6), img, R, dR, g, w_px, w_g)
        if not solved or _stepped(r, t, step):
            break
    return r.reshape(3, 1), t.reshape(3, 1)


@compiled
def _gravity_steps(pts, img, r, t, K, k, g, w_px, w_g, iterations):
    """`refine_with_gravity`'s steps, ``r`` and ``t`` in place, for a camera of
    OpenCV's Brown-Conrady model (``k``)."""
    dR = np.empty((3, 9))  # (cv2.Rodrigues' layout: d(R row by row) / d(rvec))
    for _ in range(iterations):
        proj, jac = projected(pts, r, t, K, k)
        R, dRr = rotation_and_derivatives(r)
        for i in range(3):
            for a in range(3):
                for b in range(3):
                    dR[i, 3 * a + b] = dRr[a, b, i]
        step, solved = _gravity_step(proj, jac.reshape(-1, 6), img, R, dR, g, w_px, w_g)
        if not solved or _stepped(r, t, step):
            break


@compiled
def _stepped(r, t, step):
    """Adds a Gauss-Newton ``step`` to (``r``, ``t``) in place; True once it is
    under a micro-radian and a micrometre (converged)."""
    r += step[:3]
    t += step[3:]
    return np.abs(step).max() < 1e-6


@compiled
def _gravity_step(proj, jac, img, R, dR, g, w_px, w_g):
    """`refine_with_gravity`'s Gauss-Newton step over (rvec, tvec): the reprojection
    errors (``proj`` - ``img``; ``jac``, their derivatives by the pose, a row per
    pixel coordinate) weighed by ``w_px``, and the pad's up (R's third column)
    against gravity's opposite by ``w_g`` (its Jacobian the third column's rows of
    ``dR``, cv2.Rodrigues')."""
    A = np.zeros((6, 6))
    b = np.zeros(6)
    n = img.shape[0]
    w2 = w_px * w_px
    for i in range(n):
        for c in range(2):
            row = 2 * i + c
            e = proj[i, c] - img[i, c]
            for k in range(6):
                jk = jac[row, k]
                b[k] -= w2 * jk * e
                for m in range(k, 6):
                    A[k, m] += w2 * jk * jac[row, m]
    wg2 = w_g * w_g
    for c in range(3):
        e = R[c, 2] + g[c]
        for k in range(3):
            jk = dR[k, 3 * c + 2]
            b[k] -= wg2 * jk * e
            for m in range(k, 3):
                A[k, m] += wg2 * jk * dR[m, 3 * c + 2]
    for k in range(6):
        A[k, k] += 1e-9
        for m in range(k):
            A[k, m] = A[m, k]
    return solve(A, b)
