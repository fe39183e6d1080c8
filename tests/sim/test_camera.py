"""The simulated camera: frame conventions, rendering the pad upright and centred, timing."""

from __future__ import annotations

import math
import threading
import time

import cv2
import numpy as np
import pytest

from pipeline.render import camera_rotation, make_pad_image
from sim.camera import (
    DOWN_MOUNT,
    PadRenderer,
    SimCamera,
    SimCameraConfig,
    VehiclePose,
    camera_pose_in_pad_frame,
    rot_ned_body,
    rot_ned_pad,
)
from tests.polling import wait_until

pytestmark = [pytest.mark.timeout(30), pytest.mark.usefixtures("no_leftover_threads")]


def pose(n=0.0, e=0.0, d=-5.0, roll=0.0, pitch=0.0, yaw=0.0) -> VehiclePose:
    return VehiclePose((n, e, d), roll, pitch, yaw, time.monotonic())


def marked_texture() -> np.ndarray:
    """The pad with a red square at the picture's top-left corner (breaks the symmetry)."""
    tex = make_pad_image(440)
    tex[10:60, 10:60] = (0, 0, 255)
    return tex


def red_centroid(img: np.ndarray) -> np.ndarray:
    b, g, r = (img[..., i].astype(int) for i in range(3))
    mask = (r > 150) & (g < 80) & (b < 80)
    assert mask.sum() > 5, "red marker not visible"
    ys, xs = np.nonzero(mask)
    return np.array([xs.mean(), ys.mean()])


def h_contour(img: np.ndarray):
    """The white H (the largest white blob: the side bars are smaller), and its centroid."""
    gray = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    _, bw = cv2.threshold(gray, 160, 255, cv2.THRESH_BINARY)
    contours, _ = cv2.findContours(bw, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    assert contours, "no white blob found"
    best = max(contours, key=cv2.contourArea)
    m = cv2.moments(best)
    return best, np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])


def test_rotations_are_proper() -> None:
    for args in [(0.1, -0.2, 2.0), (0, 0, 0), (1.0, 0.5, -3.0)]:
        R = rot_ned_body(*args)
        assert np.allclose(R @ R.T, np.eye(3)) and np.isclose(np.linalg.det(R), 1)
    assert np.allclose(rot_ned_body(0, 0, math.pi / 2) @ [1, 0, 0], [0, 1, 0])  # nose east
    assert np.allclose(rot_ned_body(0, 0.3, 0) @ [1, 0, 0], [math.cos(0.3), 0, -math.sin(0.3)])
    assert np.allclose(rot_ned_body(0.3, 0, 0) @ [0, 1, 0], [0, math.cos(0.3), math.sin(0.3)])
    # Pad heading 0: picture top faces north, picture right east, up = -down.
    assert np.allclose(rot_ned_pad(0.0), [[0, 1, 0], [1, 0, 0], [0, 0, -1]])
    # Heading 90: top faces east, right faces south.
    assert np.allclose(rot_ned_pad(90.0) @ [0, 1, 0], [0, 1, 0])
    assert np.allclose(rot_ned_pad(90.0) @ [1, 0, 0], [-1, 0, 0])
    for psi in (0.0, 37.0, 200.0):
        R = rot_ned_pad(psi)
        assert np.isclose(np.linalg.det(R), 1)
    assert np.allclose(DOWN_MOUNT @ [1, 0, 0], [0, 1, 0])  # cam x = body right
    assert np.allclose(DOWN_MOUNT @ [0, 1, 0], [-1, 0, 0])  # cam y = body backward
    assert np.allclose(DOWN_MOUNT @ [0, 0, 1], [0, 0, 1])  # cam z = body down


@pytest.mark.parametrize("heading", [0.0, 90.0, 225.0])
def test_pose_conversion_above_the_pad(heading) -> None:
    cfg = SimCameraConfig(pad_north_m=3.0, pad_east_m=-2.0, pad_heading_deg=heading)
    p = pose(3.0, -2.0, -5.0, yaw=math.radians(heading))
    position, R = camera_pose_in_pad_frame(p, cfg)
    assert np.allclose(position, [0, 0, 5])
    assert np.allclose(R, camera_rotation(0.0), atol=1e-12)


def test_pose_conversion_offsets_and_yaw() -> None:
    cfg = SimCameraConfig(mount_offset_m=(0.2, 0.0, 0.1))
    position, R = camera_pose_in_pad_frame(pose(0, 0, -5, yaw=math.pi / 2), cfg)
    # Nose east: the camera is 0.2 m east (= pad +x) and 0.1 m lower.
    assert np.allclose(position, [0.2, 0, 4.9])
    # Facing east while the pad faces north: image right = body right = south = pad -y.
    assert np.allclose(R[:, 0], [0, -1, 0])


def render_frame(cfg: SimCameraConfig, p: VehiclePose) -> np.ndarray:
    img, _info = PadRenderer(cfg).render(p)
    assert img.shape == (cfg.height, cfg.width, 3) and img.dtype == np.uint8
    return img


def test_level_above_pad_sees_it_upright_and_centred() -> None:
    cfg = SimCameraConfig(pad_heading_deg=30.0, floor="plain", pad_texture=marked_texture())
    img = render_frame(cfg, pose(0, 0, -5, yaw=math.radians(30.0)))
    contour, centroid = h_contour(img)
    assert np.allclose(centroid, [319.5, 239.5], atol=1.5)
    # Upright: the H's 12 corners, legs vertical: its box is square-ish and axis aligned.
    poly = cv2.approxPolyDP(contour, 2.0, True)
    assert len(poly) == 12
    _, _, w, h = cv2.boundingRect(contour)
    side = 0.5 * 0.55 * cfg.camera.fx / 5.0  # H is half the board, seen from 5 m
    assert abs(w - side) < 3 and abs(h - side) < 3
    # The marker at the picture's top-left is up and to the left of the centre.
    red = red_centroid(img)
    assert red[0] < centroid[0] - 15 and red[1] < centroid[1] - 15


def test_yawed_vehicle_sees_pad_turned() -> None:
    cfg = SimCameraConfig(floor="plain", pad_texture=marked_texture())
    # Nose east over a north-facing pad: the picture's top (north) is on the image's left.
    img = render_frame(cfg, pose(yaw=math.pi / 2))
    _, centroid = h_contour(img)
    red = red_centroid(img)
    assert red[0] < centroid[0] - 15 and red[1] > centroid[1] + 15  # top-left -> bottom-left


def test_sideways_offset_moves_pad_the_right_way() -> None:
    cfg = SimCameraConfig(floor="plain")
    # Vehicle 1 m east of the pad, nose north: the pad lies to its left (west).
    _, c_east = h_contour(render_frame(cfg, pose(0, 1.0, -5)))
    assert c_east[0] < 319.5 - 80 and abs(c_east[1] - 239.5) < 2
    expected_px = 1.0 * cfg.camera.fx / 5.0
    assert c_east[0] == pytest.approx(319.5 - expected_px, abs=2)
    # Vehicle 1 m north of the pad: the pad is behind it: lower in the image.
    _, c_north = h_contour(render_frame(cfg, pose(1.0, 0, -5)))
    assert c_north[1] == pytest.approx(239.5 + expected_px, abs=2)
    # Rolling right (right side down) turns the belly camera to look left (west): the
    # pad straight below moves right in the image, by f * tan(roll).
    _, c_roll = h_contour(render_frame(cfg, pose(0, 0, -5, roll=math.radians(5))))
    assert c_roll[0] == pytest.approx(319.5 + cfg.camera.fx * math.tan(math.radians(5)), abs=2)
    # Nose up turns the belly camera to look forward: the pad below falls behind the
    # view centre, i.e. down the image (image down = backward).
    _, c_pitch = h_contour(render_frame(cfg, pose(0, 0, -5, pitch=math.radians(5))))
    assert c_pitch[1] == pytest.approx(239.5 + cfg.camera.fx * math.tan(math.radians(5)), abs=2)


def test_ground_and_sky_cases() -> None:
    cfg = SimCameraConfig(floor="plain")
    r = PadRenderer(cfg)
    img, info = r.render(pose(0, 0, 0.0))  # landed: camera at the ground
    assert info["clamped_height"] and img.shape == (480, 640, 3)
    img, info = r.render(pose(0, 0, -5, pitch=math.radians(120)))  # upside down-ish
    assert info.get("sky") and img.shape == (480, 640, 3)


def test_noise_and_blur_are_applied() -> None:
    clean = render_frame(SimCameraConfig(floor="plain"), pose())
    noisy = render_frame(SimCameraConfig(floor="plain", snr_db=10.0), pose())
    blurred = render_frame(SimCameraConfig(floor="plain", blur_sigma_px=3.0), pose())
    assert np.abs(noisy.astype(int) - clean).mean() > 5
    lap = lambda im: cv2.Laplacian(cv2.cvtColor(im, cv2.COLOR_BGR2GRAY), cv2.CV_64F).var()  # noqa: E731
    assert lap(blurred) < 0.5 * lap(clean)


def test_config_validation() -> None:
    bad = [
        ({"width": 0}, "width"),
        ({"hfov_deg": 200}, "hfov_deg"),
        ({"rate_hz": 0}, "rate_hz"),
        ({"latency_s": -1}, "latency_s"),
        ({"mount_rotation": np.eye(3) * 2}, "mount_rotation"),
        ({"mount_offset_m": (0, 0)}, "mount_offset_m"),
        ({"pad_size_m": 0}, "pad_size_m"),
        ({"pad_texture": np.zeros((4, 4), np.uint8)}, "pad_texture"),
        ({"snr_db": float("nan")}, "snr_db"),
        ({"blur_sigma_px": -1}, "blur_sigma_px"),
    ]
    for kw, word in bad:
        with pytest.raises(ValueError, match=word):
            SimCameraConfig(**kw)
    with pytest.raises(ValueError, match="position_ned"):
        VehiclePose((0, 0, float("nan")), 0, 0, 0, 0)
    with pytest.raises(ValueError, match="vehicle_pose"):
        SimCamera(None)  # type: ignore[arg-type]


class PoseFeed:
    """A thread-safe stand-in for the link's telemetry."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.pose: VehiclePose | None = None

    def set(self, p: VehiclePose | None) -> None:
        with self.lock:
            self.pose = p

    def __call__(self) -> VehiclePose | None:
        with self.lock:
            p = self.pose
        # Telemetry refreshes: the pose is as fresh as the last message.
        return (
            None
            if p is None
            else VehiclePose(p.position_ned, p.roll, p.pitch, p.yaw, time.monotonic())
        )


def test_source_streams_with_latency_and_stalls_without_telemetry() -> None:
    feed = PoseFeed()
    feed.set(pose())
    cfg = SimCameraConfig(floor="plain", width=320, height=240, rate_hz=30, latency_s=0.1)
    src = SimCamera(vehicle_pose=feed, config=cfg, stall_after=0.4)
    try:
        src.start()
        f = src.wait_frame(-1, timeout=5.0)
        assert f is not None and f.image.shape == (240, 320, 3)
        f2 = src.wait_frame(f.seq, timeout=2.0)
        assert f2 is not None and f2.t_capture > f.t_capture
        assert f2.info["delivered_late_s"] >= 0.1  # held back by the latency
        assert f2.info["position_pad_m"] == pytest.approx([0, 0, 5])
        assert wait_until(lambda: src.status.frames >= 8)
        assert src.status.state == "streaming"
        assert src.status.fps == pytest.approx(30, rel=0.5)
        feed.set(None)  # telemetry lost
        assert wait_until(lambda: src.status.state == "stalled")
        st = src.status
        assert st.state == "stalled" and st.stalled_since is not None
        last = src.latest()
        feed.set(pose(0, 0.5, -4))  # back
        f3 = src.wait_frame(last.seq, timeout=2.0)
        assert f3 is not None and f3.info["position_pad_m"][0] == pytest.approx(0.5)
        assert src.status.state == "streaming"
    finally:
        src.close()
    assert src.status.state == "closed"


def test_stale_pose_gives_no_frame() -> None:
    old = VehiclePose((0, 0, -5), 0, 0, 0, time.monotonic() - 10)
    src = SimCamera(lambda: old, SimCameraConfig(floor="plain", width=160, height=120))
    with src:
        assert wait_until(lambda: src.skipped_poses >= 3)
        assert src.latest() is None


def test_failing_telemetry_callable_is_counted() -> None:
    def broken() -> VehiclePose:
        raise RuntimeError("link down")

    src = SimCamera(broken, SimCameraConfig(floor="plain", width=160, height=120))
    with src:
        deadline = time.monotonic() + 5.0
        while src.status.errors == 0 and time.monotonic() < deadline:
            time.sleep(0.02)
        st = src.status
    assert st.errors >= 1 and "link down" in st.last_error
