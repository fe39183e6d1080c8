"""Points of the pad's plane projected into the image, with their derivatives by the
pose: ``cv2.projectPoints`` for the edge fits' few hundred samples a step, compiled.

OpenCV's call also derives every point by the intrinsics and by each distortion
coefficient, which the pose fits never read: on 600 samples it took 70 us a call
here (the fits call it a dozen times a frame), this 14 us. The same model:
a pinhole with OpenCV's radial (k1, k2, k3) and tangential (p1, p2) distortion;
a camera with the rational or thin-prism terms goes to OpenCV.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.jit import compiled, plain


def project_plane(
    pts_m: np.ndarray, rvec: np.ndarray, tvec: np.ndarray, camera: Camera
) -> tuple[np.ndarray, np.ndarray]:
    """Pad points (N x 2 metres, z = 0) in the image (N x 2 pixels) and their
    derivatives by the pose's rotation vector and translation (N x 2 x 6), as
    ``cv2.projectPoints`` gives them."""
    pts = plain(pts_m).reshape(-1, 2)
    r = np.array(rvec, np.float64).reshape(3)
    t = np.array(tvec, np.float64).reshape(3)
    k = camera.brown_conrady
    if k is None:
        obj = np.column_stack([pts, np.zeros(len(pts))])
        proj, jac = cv2.projectPoints(obj, r, t, camera.K, camera.dist)
        return proj.reshape(-1, 2), jac[:, :6].reshape(len(pts), 2, 6)
    return projected(pts, r, t, camera.K, k)


def plane_pixels(
    pts_m: np.ndarray, rvec: np.ndarray, tvec: np.ndarray, camera: Camera
) -> np.ndarray:
    """`project_plane`'s pixels alone (N x 2): a pose's checks project hundreds of
    samples, whose derivatives they never read."""
    pts = plain(pts_m).reshape(-1, 2)
    k = camera.brown_conrady
    if k is None:
        return project_plane(pts, rvec, tvec, camera)[0]
    return _pixels(pts, plain(rvec).reshape(3), plain(tvec).reshape(3), camera.K, k)


@compiled
def _pixels(pts, r, t, K, k):
    R, _ = rotation_and_derivatives(r)
    out = np.empty((pts.shape[0], 2))
    for q in range(pts.shape[0]):
        out[q, 0], out[q, 1] = _pixel(R, t, K, k, pts[q, 0], pts[q, 1])
    return out


def reprojection_rms(
    pts_m: np.ndarray, rvec: np.ndarray, tvec: np.ndarray, camera: Camera, px: np.ndarray
) -> float:
    """The RMS distance (pixels) from pad points (N x 2 metres) projected under the
    pose to ``px`` (N x 2): `project_plane`'s projection, without its derivatives."""
    pts = plain(pts_m).reshape(-1, 2)
    k = camera.brown_conrady
    if k is None:
        err = plane_pixels(pts, rvec, tvec, camera) - px
        return math.sqrt(float(np.sum(err**2)) / len(err))
    r = plain(rvec).reshape(3)
    t = plain(tvec).reshape(3)
    return _rms(pts, r, t, camera.K, k, plain(px).reshape(-1, 2))


@compiled
def _rms(pts, r, t, K, k, px):
    R, _ = rotation_and_derivatives(r)
    acc = 0.0
    for q in range(pts.shape[0]):
        u, v = _pixel(R, t, K, k, pts[q, 0], pts[q, 1])
        acc += (u - px[q, 0]) ** 2 + (v - px[q, 1]) ** 2
    return math.sqrt(acc / pts.shape[0])


@compiled
def _pixel(R, t, K, k, px, py):
    """Where pad point (px, py) lies in the image (`projected`'s arithmetic)."""
    X = R[0, 0] * px + R[0, 1] * py + t[0]
    Y = R[1, 0] * px + R[1, 1] * py + t[1]
    Z = R[2, 0] * px + R[2, 1] * py + t[2]
    iz = 1.0 / Z if Z != 0.0 else 1.0
    x, y = X * iz, Y * iz
    k1, k2, p1, p2, k3 = k[0], k[1], k[2], k[3], k[4]
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return K[0, 0] * xd + K[0, 2], K[1, 1] * yd + K[1, 2]


@compiled
def rotation_and_derivatives(r):
    """R = Rodrigues(r) and dR/dr_i (3 x 3 x 3, i last), by Gallego and Yezzi's
    closed form: dR/dr_i = (r_i [r]x + [r x (I - R) e_i]x) R / |r|^2."""
    theta2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    R = np.eye(3)
    dR = np.zeros((3, 3, 3))
    if theta2 < 1e-24:
        # At the identity dR/dr_i is [e_i]x.
        for i in range(3):
            e = np.zeros(3)
            e[i] = 1.0
            dR[:, :, i] = _skew(e)
        return R, dR
    theta = np.sqrt(theta2)
    u = r / theta
    s, c = np.sin(theta), np.cos(theta)
    U = _skew(u)
    R = c * np.eye(3) + s * U + (1.0 - c) * np.outer(u, u)
    V = _skew(r)
    I_R = np.eye(3) - R
    for i in range(3):
        w = np.cross(r, I_R[:, i])
        A = (r[i] * V + _skew(w)) / theta2
        for a in range(3):
            for b in range(3):
                dR[a, b, i] = A[a, 0] * R[0, b] + A[a, 1] * R[1, b] + A[a, 2] * R[2, b]
    return R, dR


@compiled
def _skew(v):
    out = np.zeros((3, 3))
    out[0, 1], out[0, 2] = -v[2], v[1]
    out[1, 0], out[1, 2] = v[2], -v[0]
    out[2, 0], out[2, 1] = -v[1], v[0]
    return out


@compiled
def projected(pts, r, t, K, k):
    """`project_plane`'s pixels and derivatives, for compiled loops (``k``: the
    camera's `brown_conrady` coefficients)."""
    n = pts.shape[0]
    R, dR = rotation_and_derivatives(r)
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    k1, k2, p1, p2, k3 = k[0], k[1], k[2], k[3], k[4]
    proj = np.empty((n, 2))
    jac = np.empty((n, 2, 6))
    dX = np.zeros((3, 6))
    for i in range(3):
        dX[i, 3 + i] = 1.0
    for q in range(n):
        px, py = pts[q, 0], pts[q, 1]
        X = R[0, 0] * px + R[0, 1] * py + t[0]
        Y = R[1, 0] * px + R[1, 1] * py + t[1]
        Z = R[2, 0] * px + R[2, 1] * py + t[2]
        iz = 1.0 / Z if Z != 0.0 else 1.0
        x, y = X * iz, Y * iz
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        proj[q, 0] = fx * xd + cx
        proj[q, 1] = fy * yd + cy
        # d(xd, yd) / d(x, y)
        dradial = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d radial / d r2
        a11 = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x
        a12 = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y  # (= d yd / d x)
        a22 = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x
        # d(X, Y, Z) / d(r); by t it is the identity (set once, above the loop)
        for i in range(3):
            dX[0, i] = dR[0, 0, i] * px + dR[0, 1, i] * py
            dX[1, i] = dR[1, 0, i] * px + dR[1, 1, i] * py
            dX[2, i] = dR[2, 0, i] * px + dR[2, 1, i] * py
        for m in range(6):
            dx = (dX[0, m] - x * dX[2, m]) * iz
            dy = (dX[1, m] - y * dX[2, m]) * iz
            jac[q, 0, m] = fx * (a11 * dx + a12 * dy)
            jac[q, 1, m] = fy * (a12 * dx + a22 * dy)
    return proj, jac
