"""Where missions can expect to find the pad: the height up to which its H spans enough
of the camera's own pixels (frames are searched at their own resolution, so a finer
camera reaches farther)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame
from pipeline.bench.hint import gravity_hint
from pipeline.render import camera_rotation, make_pad_image, make_scene, render


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(make_pad_image(800), 0.55)


def test_a_finer_camera_reaches_farther_up_to_the_widths_measured(reference):
    vga = reference.reliable_altitude_m(Camera.from_fov(640, 480, 60.0))
    hd = reference.reliable_altitude_m(Camera.from_fov(1280, 720, 60.0))
    full_hd = reference.reliable_altitude_m(Camera.from_fov(1920, 1080, 60.0))
    qvga = reference.reliable_altitude_m(Camera.from_fov(320, 240, 60.0))
    assert hd == pytest.approx(2 * vga)
    assert full_hd == pytest.approx(hd)  # 1920 px counted as the 1280 measured
    assert qvga == pytest.approx(vga / 2)  # an enlarged frame holds no more detail


def test_the_pad_is_found_at_the_reliable_altitude_of_a_1280x720_camera(reference):
    camera = Camera.from_fov(1280, 720, 60.0)
    altitude = reference.reliable_altitude_m(camera)
    found = 0
    for k in range(10):
        rng = np.random.default_rng(300 + k)
        scene = make_scene(make_pad_image(800), 0.55, rng=rng)
        position = np.array([rng.uniform(-3, 3), rng.uniform(-2, 2), altitude])
        R = camera_rotation(rng.uniform(0, 360), tilt_deg=rng.uniform(0, 8),
                            tilt_dir_deg=rng.uniform(0, 360))  # fmt: skip
        frame = render(scene, camera, position, R, snr_db=25, blur_sigma_px=0.8, rng=rng)
        found += process_frame(frame, reference, camera, gravity_hint=gravity_hint(R, [k])).detected
    assert found == 10, found
