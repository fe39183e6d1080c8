"""The station as a whole: starts, runs, stops cleanly; bad start-up input is refused."""

from __future__ import annotations

import threading
import time

import cv2
import numpy as np
import pytest

from backend.imaging import UnsupportedImage, decode_image, sniff_image
from backend.services.references import NoUsableH
from backend.settings import Settings
from backend.station import Station, build_station
from pipeline.render import make_pad_image


def settings(tmp_path, **kw) -> Settings:
    base = {
        "data_dir": tmp_path,
        "token": "station-test-token",
        "viser_port": 0,
        "sim_ready_after": 0.1,
        "link_timeout_s": 1.0,
    }
    base.update(kw)
    return Settings(**base)


def wait_for(predicate, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    raise AssertionError("condition not met in time")


def test_start_run_stop_leaves_no_threads(tmp_path):
    before = {t.ident for t in threading.enumerate()}
    station = build_station(settings(tmp_path))
    station.start()
    try:
        wait_for(lambda: station.link.telemetry.state == "up", 15)
        wait_for(lambda: station.worker.stats.processed >= 2, 20)
        status = station.status.build_status()
        assert status["link"]["state"] == "up" and status["camera"]["state"] == "streaming"
        assert status["reference"]["name"] == "default pad"
        assert (tmp_path / "visland.db").is_file()
    finally:
        station.stop()
    station.stop()  # idempotent

    def left() -> list[str]:
        return [t.name for t in threading.enumerate() if t.ident not in before and t.is_alive()]

    # threads end as they finish their last loop (each has joined or timed out)
    try:
        wait_for(lambda: not left(), 20)
    except AssertionError:
        raise AssertionError(f"threads left running: {left()}") from None


def test_an_unreachable_vehicle_shows_and_commands_fail_at_once(tmp_path):
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again: nothing listens there
    station = build_station(settings(tmp_path, mavlink=f"tcp:127.0.0.1:{port}"))
    station.start()
    try:
        assert station.stand_in is None
        assert station.status.build_status()["link"]["state"] in ("connecting", "lost")
        result = station.vehicle.command("arm")  # at once: nothing is waited for
        assert not result.ok and result.result_name == "LINK_DOWN"
        assert "nothing was sent" in result.detail
        assert station.status.build_status()["camera"]["frames"] == 0  # no pose, no picture
    finally:
        station.stop()


def test_a_reference_given_at_start_is_used(tmp_path):
    path = tmp_path / "my pad.png"
    cv2.imwrite(str(path), make_pad_image(500))
    station = build_station(settings(tmp_path / "data", reference=path, pad_size=0.9))
    station.start()
    try:
        summary = station.references.active_summary()
        assert summary is not None
        assert summary["name"] == "my pad.png" and summary["pad_size_m"] == 0.9
    finally:
        station.stop()


def test_a_reference_without_h_at_start_is_a_clear_error(tmp_path):
    path = tmp_path / "blank.png"
    cv2.imwrite(str(path), np.zeros((200, 200, 3), np.uint8))
    before = {t.ident for t in threading.enumerate()}
    with pytest.raises(NoUsableH, match=r"white shape|H"):
        build_station(settings(tmp_path / "data", reference=path))
    # Refused while building: no stand-in was started, nothing runs.
    left = [t for t in threading.enumerate() if t.ident not in before and t.is_alive()]
    assert not left, [t.name for t in left]


def test_token_file_is_made_when_no_token_is_given(tmp_path):
    station = build_station(settings(tmp_path, token=None, mavlink="tcp:127.0.0.1:9"))
    station.start()
    try:
        assert (tmp_path / "token").read_text().strip() == station.token
        assert station.token_path == tmp_path / "token"
    finally:
        station.stop()


@pytest.mark.parametrize(
    ("ext", "kind"),
    [(".png", "png"), (".jpg", "jpeg"), (".bmp", "bmp"), (".webp", "webp"), (".tiff", "tiff")],
)
def test_sniff(ext, kind):
    _ok, buf = cv2.imencode(ext, make_pad_image(64))
    assert sniff_image(buf.tobytes()) == kind
    assert sniff_image(buf.tobytes()[:6]) is None  # a header cut short is no picture
    assert sniff_image(b"GIF89a") is None and sniff_image(b"") is None


def test_decode_refuses_non_pictures():
    with pytest.raises(UnsupportedImage, match="not a picture"):
        decode_image(b"plain text")
    with pytest.raises(UnsupportedImage, match="IHDR"):
        decode_image(b"\x89PNG\r\n\x1a\n" + b"\x00" * 64)
    _ok, buf = cv2.imencode(".png", make_pad_image(100))
    with pytest.raises(UnsupportedImage, match="cannot be decoded"):
        decode_image(buf.tobytes()[:200])
    _ok, buf = cv2.imencode(".jpg", make_pad_image(100))
    assert decode_image(buf.tobytes()).shape == (100, 100, 3)


def test_an_opencv_video_file_feeds_the_pipeline(tmp_path):
    from pipeline.camera import Camera
    from pipeline.render import camera_rotation, make_scene, render

    cam = Camera.from_fov(640, 480, 60)
    scene = make_scene(make_pad_image(800), 0.55, rng=np.random.default_rng(4))
    path = tmp_path / "flight.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20, (640, 480))
    for i in range(30):
        writer.write(render(scene, cam, np.array([0.01 * i, 0.0, 2.5]), camera_rotation(10.0)))
    writer.release()
    station: Station = build_station(
        settings(tmp_path / "data", camera=f"opencv:{path}", mavlink="tcp:127.0.0.1:9")
    )
    station.start()
    try:
        wait_for(lambda: station.worker.stats.processed >= 5, 20)
        latest = station.worker.latest
        assert latest.result.detected and latest.result.pose is not None
        assert abs(latest.result.pose.altitude_m - 2.5) < 0.1
        assert station.status.build_status()["camera"]["name"]
    finally:
        station.stop()
