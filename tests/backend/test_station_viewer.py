"""The 3D view adapter: its frames agree with the simulated camera's, and viser serves it."""

from __future__ import annotations

import math
import socket

import httpx
import numpy as np
import pytest
import viser.transforms as tf

from backend.frames import DOWN_MOUNT, mount_rotation, vision_hints
from backend.viewer3d import Viewer3D
from pipeline.render import make_pad_image
from pipeline.result import yaw_of
from sim.camera import (
    SimCameraConfig,
    VehiclePose,
    camera_pose_in_pad_frame,
)
from tests.serve import free_port


@pytest.mark.parametrize(("pad", "yaw_deg"), [(0, 0), (0, 45), (30, 170), (-120, -60)])
def test_yaw_hint_is_the_yaw_the_camera_really_has(pad, yaw_deg):
    # Looking straight down, picture top to the nose: the pad's heading less the
    # vehicle's (headings turn clockwise, the pad frame's yaw counter-clockwise).
    pose = VehiclePose((1.0, 2.0, -3.0), 0.0, 0.0, math.radians(yaw_deg), 0.0)
    _, R_pad_cam = camera_pose_in_pad_frame(pose, SimCameraConfig(pad_heading_deg=pad))
    got = vision_hints(pad, 0.0, 0.0, math.radians(yaw_deg), DOWN_MOUNT)["yaw_hint"]
    assert abs((got - yaw_of(R_pad_cam) + 180) % 360 - 180) < 1e-9
    assert abs((got - (pad - yaw_deg) + 180) % 360 - 180) < 1e-9


@pytest.mark.parametrize("mount", [(0.0, 0.0, 0.0), (3.0, -10.0, 0.0), (0.0, 20.0, 90.0)])
def test_the_hints_are_the_cameras_on_its_mount(mount):
    # The simulated camera on a vehicle rolled, pitched and turned, its mount as set:
    # the hints are its yaw in the pad frame and down in its own frame.
    roll, pitch, yaw = np.radians([4.0, -6.0, 130.0])
    R_body_cam = mount_rotation(*mount)
    config = SimCameraConfig(pad_heading_deg=25.0, mount_rotation=R_body_cam)
    _, R_pad_cam = camera_pose_in_pad_frame(VehiclePose((0, 0, -3.0), roll, pitch, yaw, 0), config)
    hints = vision_hints(25.0, roll, pitch, yaw, R_body_cam)
    assert abs((hints["yaw_hint"] - yaw_of(R_pad_cam) + 180) % 360 - 180) < 1e-9
    np.testing.assert_allclose(hints["gravity_hint"], R_pad_cam.T @ [0.0, 0.0, -1.0], atol=1e-12)


def test_viser_serves_the_scene_and_takes_updates():
    port = free_port()
    viewer = Viewer3D(
        "127.0.0.1",
        port,
        pad_image_bgr=make_pad_image(256),
        pad_size_m=0.55,
        pad_ned=(1.0, -2.0),
        pad_heading_deg=30.0,
    )
    viewer.start()
    try:
        assert viewer.url == "/view3d/"  # browsers come through the station
        assert viewer.bound_port == port
        page = httpx.get(f"http://127.0.0.1:{port}/", timeout=5)
        assert page.status_code == 200 and "<html" in page.text.lower()
        for i in range(5):
            viewer.update(
                position_ned=(0.1 * i, 0.0, -2.0),
                attitude_rpy=(0.0, 0.0, 0.3),
                vision_position_m=np.array([0.0, 0.0, 2.0]),
                vision_R_pad_cam=np.diag([1.0, -1.0, -1.0]),
            )
        viewer.update(position_ned=None, attitude_rpy=None)
        viewer.set_pad(make_pad_image(128), 1.0)
        assert len(viewer._trail) == 5
        # The picture's top edge (image rows run along local +y) faces the pad's heading.
        R_pad_img = tf.SO3(np.asarray(viewer._h["pad"].wxyz)).as_matrix()
        top = R_pad_img @ np.array([0.0, -1.0, 0.0])
        right = R_pad_img @ np.array([1.0, 0.0, 0.0])
        psi = math.radians(30.0)
        assert np.allclose(top, [math.sin(psi), math.cos(psi), 0.0])
        assert np.allclose(right, [math.cos(psi), -math.sin(psi), 0.0])
        # The vision frame sits over the pad: pad origin + 2 m up.
        assert np.allclose(viewer._h["vision"].position, [-2.0, 1.0, 2.0])
        # The camera on the vehicle turns to a mount set while running.
        viewer.set_mount(mount_rotation(0.0, 10.0, 0.0))
        R_body_cam = tf.SO3(np.asarray(viewer._h["camera"].wxyz)).as_matrix()
        assert np.allclose(R_body_cam, mount_rotation(0.0, 10.0, 0.0))
    finally:
        viewer.close()
    viewer.close()  # idempotent
    with socket.socket() as s:  # nothing listens on the port any more
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind(("127.0.0.1", port))


@pytest.mark.parametrize(
    ("host", "shown"),
    [
        ("0.0.0.0", "127.0.0.1"),
        ("::", "127.0.0.1"),
        ("127.0.0.1", "127.0.0.1"),
        ("192.168.1.5", "192.168.1.5"),
    ],
)
def test_urls_name_an_address_a_browser_can_open(host, shown):
    from backend.viewer3d import browsable_host

    assert browsable_host(host) == shown
