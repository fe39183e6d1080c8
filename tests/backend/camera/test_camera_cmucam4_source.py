"""CMUcam4Source (the frame-source interface) against the stand-in board over a pty."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import cv2
import numpy as np
import pytest

from backend.camera import open_source
from backend.camera.cmucam4 import CMUcam4Error, CMUcam4Source, TPacket
from backend.camera.rgb565 import decode_rgb565, encode_rgb565
from sim.camera import PadRenderer, SimCameraConfig, VehiclePose
from sim.cmucam4 import CMUcam4Board, Faults
from tests.polling import wait_until

pytestmark = [pytest.mark.timeout(40), pytest.mark.usefixtures("no_leftover_threads")]
SCALE = 0.02


def quantised(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    return decode_rgb565(encode_rgb565(img), w, h)


@pytest.fixture
def rig() -> Iterator[Callable[..., tuple[CMUcam4Board, CMUcam4Source]]]:
    made: list = []

    def make(board_kw: dict | None = None, **src_kw) -> tuple[CMUcam4Board, CMUcam4Source]:
        board = CMUcam4Board(time_scale=SCALE, **(board_kw or {}))
        board.start()
        made.append(board)
        src_kw.setdefault("stall_after", 0.6)
        src_kw.setdefault("timeout", 0.5)
        src_kw.setdefault("reset_timeout", 0.15)
        src_kw.setdefault("backoff", (0.05, 0.2))
        src = open_source(f"cmucam4:{board.path}", **src_kw)
        assert isinstance(src, CMUcam4Source)
        made.append(src)
        return board, src

    yield make
    for thing in reversed(made):
        thing.close()


def picture(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (120, 160, 3), dtype=np.uint8)


def test_streams_exact_stills(rig) -> None:
    img = picture()
    board, src = rig({"image": img})
    src.start()
    f = src.wait_frame(-1, timeout=5.0)
    assert f is not None
    assert np.array_equal(f.image, quantised(img))
    assert f.info["resolution"] == (160, 120) and f.info["version"] == "1.02"
    assert f.info["sf_started"] <= f.t_capture <= f.info["sf_finished"]
    f2 = src.wait_frame(f.seq, timeout=3.0)
    assert f2 is not None and f2.seq == f.seq + 1 and f2.t_capture > f.t_capture
    assert src.status.state == "streaming" and src.status.errors == 0
    # The board got the seed's settings before the first frame.
    assert {"AG 1", "AW 1", "CB 16", "CC 0", "AP 1", "AT 1"} <= set(board.commands)


def test_other_resolution(rig) -> None:
    _, src = rig({"image": picture()}, resolution="80x60")
    src.start()
    f = src.wait_frame(-1, timeout=5.0)
    assert f is not None and f.image.shape == (60, 80, 3)


def test_stalls_and_recovers(rig) -> None:
    board, src = rig({"image": picture()})
    src.start()
    f = src.wait_frame(-1, timeout=5.0)
    assert f is not None
    board.set_silent(True)  # the camera stops mid-stream
    assert wait_until(lambda: src.status.state == "stalled")
    assert src.status.stalled_since is not None
    # The driver's column timeout and failed resync are recorded soon after.
    assert wait_until(lambda: src.status.errors >= 1)
    st = src.status
    assert st.state == "stalled" and board.path in st.last_error
    board.set_silent(False)  # it comes back: the source reconnects by itself
    f2 = src.wait_frame(src.latest().seq, timeout=8.0)
    assert f2 is not None
    assert src.status.state == "streaming"


def test_camera_timeout_mid_frame_recovers(rig) -> None:
    img = picture(3)
    _, src = rig({"image": img, "faults": Faults(timeout_at_column=50, times=2)})
    src.start()
    f = src.wait_frame(-1, timeout=5.0)
    assert f is not None and np.array_equal(f.image, quantised(img))
    st = src.status
    assert st.errors == 2 and "Camera Timeout Error" in st.last_error


def test_reset_mid_frame_recovers(rig) -> None:
    img = picture(4)
    board, src = rig({"image": img, "faults": Faults(reset_at_column=10)})
    src.start()
    f = src.wait_frame(-1, timeout=8.0)
    assert f is not None and np.array_equal(f.image, quantised(img))
    assert src.status.errors >= 1
    assert board.boots >= 3


def test_port_disappears(rig) -> None:
    _board, src = rig({"image": picture(), "faults": Faults(disappear_at_column=5)})
    src.start()
    deadline = time.monotonic() + 5.0
    while src.status.errors < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    st = src.status
    assert st.frames == 0 and st.errors >= 2
    # The pty number may be handed to another process's pty at once: then the reopen
    # finds no CMUcam4 there, which is reported just as clearly.
    assert any(w in st.last_error for w in ("cannot open", "disappeared", "no CMUcam4 on"))
    assert st.state in ("starting", "error", "stalled")
    src.close()
    assert src._thread is None or not src._thread.is_alive()


def test_nonexistent_port_reports_error() -> None:
    src = CMUcam4Source("/dev/nonexistent-cam", stall_after=0.3, backoff=(0.05, 0.1))
    with src:
        assert wait_until(lambda: src.status.errors >= 1)
        st = src.status
    assert st.state == "error" and "cannot open /dev/nonexistent-cam" in st.last_error


def test_track_borrows_the_port(rig) -> None:
    img = np.zeros((120, 160, 3), np.uint8)
    img[10:30, 20:40] = (0, 0, 255)
    _, src = rig({"image": img})
    src.start()
    first = src.wait_frame(-1, timeout=5.0)
    assert first is not None
    with src.track((200, 255, 0, 50, 0, 50), packet_timeout=0.5) as stream:
        packets = [next(stream) for _ in range(10)]
    assert all(
        isinstance(p, TPacket) and (p.x1, p.y1, p.x2, p.y2) == (20, 10, 39, 29) for p in packets
    )
    # Snapshots resume afterwards.
    assert src.wait_frame(src.latest().seq, timeout=5.0) is not None


def test_track_when_not_connected() -> None:
    src = CMUcam4Source("/dev/nonexistent-cam", backoff=(0.05, 0.1))
    with src, pytest.raises(CMUcam4Error, match="not connected"), src.track(wait=1.0):
        pass


def test_board_serves_the_simulated_camera(rig) -> None:
    renderer = PadRenderer(SimCameraConfig(floor="plain", width=640, height=480))

    def frame() -> np.ndarray:
        return renderer.render(VehiclePose((0, 0, -2.0), 0, 0, 0, time.monotonic()))[0]

    _, src = rig({"frame_source": frame})
    src.start()
    f = src.wait_frame(-1, timeout=5.0)
    assert f is not None
    gray = f.image.mean(axis=2)
    assert gray[60, 80] > 180  # the H's crossbar at the centre
    # Exactly the rendered picture, shrunk by the board and quantised to RGB565.
    expected = cv2.resize(frame(), (160, 120), interpolation=cv2.INTER_AREA)
    assert np.array_equal(f.image, quantised(expected))


def test_bad_source_arguments() -> None:
    with pytest.raises(ValueError, match="resolution"):
        CMUcam4Source("/dev/x", resolution=(100, 100))
    with pytest.raises(ValueError, match="resolution"):
        CMUcam4Source("/dev/x", resolution="big")
