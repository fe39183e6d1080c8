"""The frame messages: binary framing, the overlay drawn from a real result, one encoding."""

from __future__ import annotations

import json
import struct
import time

import cv2
import numpy as np
import pytest

from backend.api.messages import BinaryFrameHeader, FrameMessage
from backend.camera import Frame
from backend.encoder import (
    FrameEncoder,
    frame_message,
    overlay_for,
    pack_binary,
    unpack_binary,
)
from backend.framebus import FrameBus
from backend.vision_worker import Processed
from pipeline import Camera, Reference, process_frame
from pipeline.render import camera_rotation, make_pad_image, make_scene, project_points, render

CAMERA = Camera.from_fov(640, 480, 60)


def test_binary_round_trip_and_layout():
    header = {"kind": "camera", "seq": 7, "t_capture": 1.5, "width": 640, "height": 480}
    msg = pack_binary(header, b"\xff\xd8jpeg")
    (n,) = struct.unpack(">I", msg[:4])
    assert json.loads(msg[4 : 4 + n]) == header and msg[4 + n :] == b"\xff\xd8jpeg"
    assert unpack_binary(msg) == (header, b"\xff\xd8jpeg")


@pytest.mark.parametrize("bad", [b"", b"\x00\x00", b"\x00\x00\x00\x09{}"])
def test_unpack_refuses_short_messages(bad):
    with pytest.raises(ValueError):
        unpack_binary(bad)


@pytest.fixture(scope="module")
def seen():
    pad = make_pad_image(800)
    reference = Reference.from_image(pad, 0.55)
    scene = make_scene(pad, 0.55, rng=np.random.default_rng(2))
    position, R = np.array([0.2, 0.1, 2.0]), camera_rotation(35.0, tilt_deg=5.0)
    image = render(scene, CAMERA, position, R)
    result = process_frame(image, reference, CAMERA, yaw_hint=35.0)
    assert result.detected
    t = time.monotonic()
    processed = Processed(Frame(image, t, 3, "test"), result, reference, CAMERA, 12.5, t)
    return processed, position, R


def test_overlay_projects_the_reference_through_the_pose(seen):
    processed, position, R = seen
    overlay = overlay_for(processed)
    corners = np.array(frame_message(processed)["result"]["corners_px"])
    reprojected = np.array(overlay["reference_corners"])
    assert corners.shape == (12, 2) and reprojected.shape == (12, 2)
    # The reference corners, put through the measured pose, land where the true pose
    # puts them (in the reference's order) and on the detected corners.
    truth = project_points(CAMERA, position, R, processed.reference.corners_m)
    assert np.abs(reprojected - truth).max() < 2.0
    nearest = np.linalg.norm(reprojected[:, None] - corners[None], axis=2).min(axis=1)
    assert nearest.max() < 2.0
    # The target cross sits where the true pad centre projects.
    truth = project_points(CAMERA, position, R, np.zeros((1, 3)))[0]
    assert np.hypot(*(np.array(overlay["target"]) - truth)) < 3.0
    assert overlay["axes"]["origin"] == overlay["target"]
    assert len(frame_message(processed)["result"]["contour_px"]) >= 12


def test_frame_message_is_json_and_complete(seen):
    processed, _, _ = seen
    msg = json.loads(json.dumps(frame_message(processed)))
    assert msg["type"] == "frame" and msg["seq"] == 3 and msg["latency_ms"] == 12.5
    assert (msg["width"], msg["height"]) == (640, 480)
    assert msg["result"]["detected"] is True
    assert msg["reference_distance"] is not None
    # The H seen from 2 m has nearly the reference's invariants.
    assert 0 <= msg["reference_distance"] < 0.5


def test_no_pose_means_no_projected_overlay(seen):
    processed, _, _ = seen
    blank = np.zeros((480, 640, 3), np.uint8)
    result = process_frame(blank, processed.reference, CAMERA)
    p = Processed(Frame(blank, 0.0, 1, "t"), result, processed.reference, CAMERA, 1.0, 0.0)
    overlay = overlay_for(p)
    assert overlay["reference_corners"] == [] and overlay["axes"] is None
    assert overlay["target"] is None
    assert frame_message(p)["reference_distance"] is None


def test_one_encoding_serves_the_viewers_and_the_recorder(seen):
    processed, _, _ = seen
    encoder = FrameEncoder(FrameBus("in").subscribe("x"), FrameBus("out"), jpeg_quality=lambda: 80)
    plain = encoder.encode(processed)
    assert plain.threshold_message is None  # nobody asked for it
    encoder.threshold_wanted = True
    enc = encoder.encode(processed)
    msg = FrameMessage.model_validate_json(enc.text)  # the contract's model
    assert msg.seq == 3 and msg.result.detected
    data = json.loads(enc.text)
    # The contour and the corners travel once: in the result, not again in the overlay.
    assert set(data["overlay"]) == {"reference_corners", "axes", "target"}
    assert enc.text.count('"contour_px"') == 1
    assert json.loads(enc.result_json) == data["result"]
    header, jpeg = unpack_binary(enc.camera_message)
    BinaryFrameHeader.model_validate(header)
    assert header["kind"] == "camera" and jpeg == enc.jpeg and jpeg[:2] == b"\xff\xd8"
    # The threshold view is the mask the pipeline worked on.
    header, jpeg = unpack_binary(enc.threshold_message)
    assert header["kind"] == "threshold"
    mask = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert mask.shape == processed.result.mask.shape
    agree = np.mean((mask > 127) == (processed.result.mask > 0))
    assert agree > 0.98  # JPEG blurs the edges a little
