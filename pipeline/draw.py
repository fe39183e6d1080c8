"""Annotated pictures of a FrameResult: mask, H contour, numbered corners, pose axes."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.camera import Camera
from pipeline.pose import pose_to_vectors, project
from pipeline.result import FrameResult

GREEN = (80, 220, 80)
CYAN = (230, 200, 40)
MASK_TINT = (255, 120, 0)


def annotate(
    image_bgr: np.ndarray,
    result: FrameResult,
    camera: Camera,
    *,
    mask: np.ndarray | None = None,
    axis_m: float = 0.2,
) -> np.ndarray:
    """A copy of the frame with the pipeline's findings drawn on it.

    ``mask`` (the threshold image, any size) is tinted in; the H contour, its
    corners numbered in reference order and the pad's axes (x red, y green,
    z blue) follow. Drawing is clipped at the picture's edges; marks and text
    grow with the picture (a 4K frame reads like a 640 px one).

    Examples
    --------
    >>> from pipeline.result import FrameResult
    >>> none = FrameResult(False, np.zeros((0, 2)), (0.0,) * 7, 0.0, 0.0, None, {})
    >>> annotate(np.zeros((2160, 3840, 3), np.uint8), none, Camera.from_fov(3840, 2160, 60)).shape
    (2160, 3840, 3)
    """
    out = image_bgr.copy()
    h, w = out.shape[:2]
    k = max(1.0, max(w, h) / 640.0)  # marks scale with the picture
    thin, thick = max(1, round(k)), max(2, round(2 * k))
    if mask is not None:
        m = cv2.resize(mask, (w, h), interpolation=cv2.INTER_NEAREST) > 0
        out[m] = (0.55 * out[m] + 0.45 * np.array(MASK_TINT)).astype(np.uint8)
    if not result.detected:
        org = (round(10 * k), round(24 * k))
        cv2.putText(out, "no H", org, cv2.FONT_HERSHEY_SIMPLEX, 0.7 * k, (0, 0, 255), thick)
        return out
    if len(result.contour_px):
        cv2.polylines(out, [np.round(result.contour_px).astype(np.int32)], True, GREEN, thin)
    for i, (x, y) in enumerate(result.corners_px):
        p = (round(float(x)), round(float(y)))
        cv2.circle(out, p, round(3 * k), CYAN, -1)
        at = (p[0] + round(4 * k), p[1] - round(4 * k))
        cv2.putText(out, str(i), at, cv2.FONT_HERSHEY_SIMPLEX, 0.4 * k, CYAN, thin)
    if result.pose is not None:
        cam = camera if (camera.width, camera.height) == (w, h) else camera.scaled(w, h)
        rvec, tvec = pose_to_vectors(result.pose)
        pts = np.array([[0, 0, 0], [axis_m, 0, 0], [0, axis_m, 0], [0, 0, axis_m]], float)
        o, x, y, z = (tuple(int(v) for v in np.round(p)) for p in project(pts, rvec, tvec, cam))
        cv2.line(out, o, x, (0, 0, 255), thick)
        cv2.line(out, o, y, (0, 255, 0), thick)
        cv2.line(out, o, z, (255, 0, 0), thick)
        pos = result.pose.position_m
        label = f"x {pos[0]:+.2f} y {pos[1]:+.2f} z {pos[2]:.2f} m  yaw {result.pose.yaw_deg:+.0f}"
        org = (round(10 * k), round(24 * k))
        cv2.putText(out, label, org, cv2.FONT_HERSHEY_SIMPLEX, 0.6 * k, (255, 255, 255), thick)
    return out
