"""The CMUcam4 driver against the stand-in board over a real pseudo-terminal."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from backend.camera.cmucam4 import (
    CMUcam4,
    CMUcam4CameraError,
    CMUcam4Disconnected,
    CMUcam4Error,
    CMUcam4NCK,
    CMUcam4NotFound,
    CMUcam4Settings,
    CMUcam4Timeout,
    SPacket,
    TPacket,
    sf_seconds,
)
from backend.camera.rgb565 import decode_rgb565, encode_rgb565, read_dump_bmp
from sim.cmucam4 import CMUcam4Board, Faults

pytestmark = [pytest.mark.timeout(30), pytest.mark.usefixtures("no_leftover_threads")]
SCALE = 0.02  # an SF 160x120 takes ~0.1 s instead of ~5 s
ROOT = Path(__file__).resolve().parents[3]


def picture(w: int = 160, h: int = 120, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    return img


def quantised(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    return decode_rgb565(encode_rgb565(img), w, h)


@pytest.fixture
def make_board() -> Iterator[Callable[..., CMUcam4Board]]:
    boards: list[CMUcam4Board] = []

    def make(**kw) -> CMUcam4Board:
        kw.setdefault("time_scale", SCALE)
        board = CMUcam4Board(**kw)
        board.start()
        boards.append(board)
        return board

    yield make
    for board in boards:
        board.close()


@pytest.fixture
def make_cam() -> Iterator[Callable[..., CMUcam4]]:
    cams: list[CMUcam4] = []

    def make(port: str, **kw) -> CMUcam4:
        kw.setdefault("timeout", 0.5)
        kw.setdefault("reset_timeout", 0.15)
        kw.setdefault("tries", 2)
        cam = CMUcam4(port, **kw)
        cams.append(cam)
        return cam

    yield make
    for cam in cams:
        cam.close()


def test_connect_sequence(make_board, make_cam) -> None:
    board = make_board(image=picture())
    cam = make_cam(board.path)
    assert cam.connect() == "1.02"
    # The board booted at 19,200: the 250,000 and 115,200 resets were lost to the
    # baud mismatch, then RS, BM 250000 with the handshake, DM 0.
    assert board.dropped_bytes > 0
    assert board.commands[-3:] == ["RS", "BM 250000", "DM 0"]
    assert board.baud == 250000
    assert cam.get_version() == "CMUcam4 v1.02"


def test_reconnect_when_board_already_fast(make_board, make_cam) -> None:
    board = make_board(image=picture())
    cam = make_cam(board.path)
    cam.connect()
    cam.close()
    cam2 = make_cam(board.path)
    assert cam2.connect() == "1.02"
    # RS at 250,000 reboots the board, whose banner then comes at 19,200 (unreadable at
    # 250,000); the 19,200 round resets it again and reads the banner: 4 boots in all.
    assert board.boots == 4
    assert board.baud == 250000


def test_configure_sends_the_seed_settings(make_board, make_cam) -> None:
    board = make_board(image=picture())
    cam = make_cam(board.path)
    cam.connect()
    cam.configure()
    assert board.commands[-6:] == ["AG 1", "AW 1", "CB 16", "CC 0", "AP 1", "AT 1"]
    cam.configure(CMUcam4Settings(auto_pan=False, auto_tilt=False, brightness=-5))
    assert board.commands[-6:] == ["AG 1", "AW 1", "CB -5", "CC 0", "AP 0", "AT 0"]
    with pytest.raises(ValueError, match="brightness"):
        CMUcam4Settings(brightness=200)


@pytest.mark.parametrize("size", [(160, 120), (80, 60), (320, 60)])
def test_snapshot_is_exact(make_board, make_cam, size) -> None:
    w, h = size
    img = picture(w, h, seed=w)
    # Raw bytes that look like protocol (CR, ':', "ACK") inside the pixels must not matter.
    img[0, 0] = (0, 0, 0)
    board = make_board(image=img)
    cam = make_cam(board.path)
    cam.connect()
    snap = cam.snapshot(w, h)
    assert np.array_equal(snap.image, quantised(img))
    assert snap.t_end >= snap.t_start
    assert snap.nbytes == w * (2 * h + 6) + 1


def test_snapshot_resizes_board_picture(make_board, make_cam) -> None:
    img = picture(640, 480)
    board = make_board(image=img)
    cam = make_cam(board.path)
    cam.connect()
    snap = cam.snapshot(80, 60)
    expected = quantised(cv2.resize(img, (80, 60), interpolation=cv2.INTER_AREA))
    assert np.array_equal(snap.image, expected)


def test_bytes_that_spell_protocol_inside_pixels(make_board, make_cam) -> None:
    # A column full of b"\r:ACK\r" patterns must be read by count, not scanned.
    pattern = np.frombuffer(b"\r:" * 60, dtype="<u2")  # 0x3A0D
    img = np.zeros((120, 160, 3), np.uint8)
    q = np.zeros((120, 160), np.uint16)
    q[:, :] = pattern[0]
    # Build the BGR picture whose RGB565 code is 0x3A0D everywhere.
    r5, g6, b5 = (0x3A0D >> 11) & 31, (0x3A0D >> 5) & 63, 0x3A0D & 31
    img[:] = (b5 << 3, g6 << 2, r5 << 3)
    assert encode_rgb565(img)[:4] == b"\r:\r:"
    board = make_board(image=img)
    cam = make_cam(board.path)
    cam.connect()
    assert np.array_equal(cam.snapshot().image, quantised(img))


def test_tracking_stream_finds_red_blob(make_board, make_cam) -> None:
    img = np.zeros((120, 160, 3), np.uint8)
    img[40:60, 100:130] = (0, 0, 255)  # red, rows 40..59, columns 100..129
    board = make_board(image=img)
    cam = make_cam(board.path)
    cam.connect()
    with cam.track((200, 255, 0, 50, 0, 50)) as stream:
        packets = [next(stream) for _ in range(5)]
    for p in packets:
        assert isinstance(p, TPacket)
        assert (p.x1, p.y1, p.x2, p.y2) == (100, 40, 129, 59)
        assert (p.mx, p.my) == (round(114.5), round(49.5))
        assert p.confidence == 255
        assert p.pixels == round(255 * 600 / (160 * 120))
        assert p.tracked
    # The stream was stopped cleanly: commands work again.
    assert cam.get_tracking_colors() == (200, 255, 0, 50, 0, 50)
    with cam.track((0, 10, 200, 255, 0, 10)) as stream:
        assert not next(stream).tracked  # nothing green: all zeros
    cam.set_tracking_window((100, 40, 109, 49))
    with cam.track((200, 255, 0, 50, 0, 50)) as stream:
        p = next(stream)
        assert (p.x1, p.y1, p.x2, p.y2) == (100, 40, 109, 49)
        assert p.pixels == 255
    with pytest.raises(ValueError, match="colors"):
        cam.track((1, 2, 3))
    with pytest.raises(ValueError, match="window"):
        cam.set_tracking_window((0, 0, 200, 10))


def test_poll_mode_gives_one_packet(make_board, make_cam) -> None:
    board = make_board(image=picture())
    cam = make_cam(board.path)
    cam.connect()
    cam.set_poll_mode(True)
    with cam.track() as stream:
        packets = list(stream)
    assert len(packets) == 1
    assert packets[0].pixels == 255  # default colours: everything is tracked
    assert cam.get_version().startswith("CMUcam4")


def test_statistics_stream(make_board, make_cam) -> None:
    img = np.full((120, 160, 3), (30, 20, 10), np.uint8)  # B, G, R
    board = make_board(image=img)
    cam = make_cam(board.path)
    cam.connect()
    with cam.statistics() as stream:
        s = next(stream)
    assert isinstance(s, SPacket)
    assert s.mean == (10, 20, 30) and s.median == (10, 20, 30) and s.mode == (10, 20, 30)
    assert s.stdev == (0, 0, 0)


def test_dump_frame_to_sd_card(make_board, make_cam, tmp_path) -> None:
    img = picture(160, 120, seed=5)
    board = make_board(image=img, sd_dir=tmp_path)
    cam = make_cam(board.path)
    cam.connect()
    cam.dump_frame(160, 120)
    cam.dump_frame(80, 60)
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files == ["00000BM.BMP", "00001BM.BMP"]
    assert np.array_equal(read_dump_bmp(tmp_path / "00000BM.BMP"), quantised(img))
    small = read_dump_bmp(tmp_path / "00001BM.BMP")
    assert small.shape == (60, 80, 3)


def test_unknown_command_is_nck(make_board, make_cam) -> None:
    board = make_board(image=picture())
    cam = make_cam(board.path)
    cam.connect()
    with pytest.raises(CMUcam4NCK, match="NCK to 'XX 1'"):
        cam.command("XX 1")
    with pytest.raises(CMUcam4NCK):
        cam.command("AG")  # missing argument
    with pytest.raises(ValueError, match="cmd"):
        cam.command("GV\rRS")
    assert cam.get_version() == "CMUcam4 v1.02"


def test_fault_nck_on_snapshot(make_board, make_cam) -> None:
    board = make_board(image=picture(), faults=Faults(nck=("SF",)))
    cam = make_cam(board.path)
    cam.connect()
    with pytest.raises(CMUcam4NCK, match=str(board.path)):
        cam.snapshot()
    assert cam.get_version() == "CMUcam4 v1.02"


def test_fault_camera_timeout_mid_frame(make_board, make_cam) -> None:
    img = picture()
    board = make_board(image=img, faults=Faults(timeout_at_column=40))
    cam = make_cam(board.path)
    cam.connect()
    with pytest.raises(CMUcam4CameraError, match="column 40: Camera Timeout Error") as info:
        cam.snapshot()
    assert info.value.text == "Camera Timeout Error"
    # The stream recovers: the next frame is complete and exact.
    assert np.array_equal(cam.snapshot().image, quantised(img))


def test_fault_garbage_before_banner(make_board, make_cam) -> None:
    img = picture()
    board = make_board(image=img, faults=Faults(garbage_before_banner=300))
    cam = make_cam(board.path)
    assert cam.connect() == "1.02"
    assert np.array_equal(cam.snapshot().image, quantised(img))


def test_fault_garbage_only_is_not_a_cmucam4(make_board, make_cam) -> None:
    board = make_board(faults=Faults(garbage_only=True))
    cam = make_cam(board.path, tries=1)
    with pytest.raises(CMUcam4NotFound) as info:
        cam.connect()
    msg = str(info.value)
    assert board.path in msg and "received b" in msg and "\n" not in msg


def test_silent_port_is_not_a_cmucam4(make_cam) -> None:
    board = CMUcam4Board(time_scale=SCALE)
    board.set_silent(True)  # before it boots: not even a banner
    try:
        cam = make_cam(board.start(), tries=1)
        with pytest.raises(CMUcam4NotFound, match="received nothing"):
            cam.connect()
    finally:
        board.close()


def test_fault_reset_mid_frame(make_board, make_cam) -> None:
    img = picture()
    board = make_board(image=img, faults=Faults(reset_at_column=30))
    cam = make_cam(board.path)
    cam.connect()
    with pytest.raises(CMUcam4Error):
        cam.snapshot()
    # The board is back at 19,200 baud; connecting again recovers.
    assert cam.connect() == "1.02"
    assert np.array_equal(cam.snapshot().image, quantised(img))


def test_fault_reset_mid_tracking_stream(make_board, make_cam) -> None:
    board = make_board(image=picture(), faults=Faults(reset_after_packets=5))
    cam = make_cam(board.path)
    cam.connect()
    with pytest.raises(CMUcam4Error), cam.track() as stream:
        for _ in range(100):
            next(stream)
    assert cam.connect() == "1.02"


def test_fault_port_disappears(make_board, make_cam) -> None:
    board = make_board(image=picture(), faults=Faults(disappear_at_column=20))
    cam = make_cam(board.path)
    cam.connect()
    with pytest.raises(CMUcam4Disconnected, match="disappeared"):
        cam.snapshot()
    cam.close()
    # Usually "cannot open": unless another process got the same pty number meanwhile.
    with pytest.raises(CMUcam4Error, match=board.path):
        cam.connect()


def test_camera_that_goes_quiet_times_out(make_board, make_cam) -> None:
    board = make_board(image=picture())
    cam = make_cam(board.path)
    cam.connect()
    board.set_silent(True)
    with pytest.raises(CMUcam4Timeout):
        cam.snapshot()
    board.set_silent(False)
    cam.resync()
    assert cam.snapshot().image.shape == (120, 160, 3)


def test_nonexistent_port() -> None:
    with pytest.raises(CMUcam4Error, match="cannot open /dev/nonexistent-cmucam4"):
        CMUcam4("/dev/nonexistent-cmucam4").connect()


def test_bad_arguments() -> None:
    for kw, word in [
        ({"timeout": 0}, "timeout"),
        ({"tries": 0}, "tries"),
        ({"baud": 300000}, "baud"),
        ({"reset_timeout": float("nan")}, "reset"),
    ]:
        with pytest.raises(ValueError, match=word):
            CMUcam4("/dev/null", **kw)
    with pytest.raises(ValueError, match="port"):
        CMUcam4("")


def test_sf_seconds_matches_spec() -> None:
    assert sf_seconds(160, 120) == pytest.approx(5.34, abs=0.05)
    assert sf_seconds(640, 480) == pytest.approx(42.7, abs=0.2)


# --- CLI -----------------------------------------------------------------------------


def run_cli(*args: str, timeout: float = 20) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "backend.camera.cmucam4", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def test_cli_snapshot(make_board, tmp_path) -> None:
    img = picture(80, 60, seed=9)
    board = make_board(image=img)
    out = tmp_path / "snap.png"
    res = run_cli(board.path, "--snapshot", str(out), "--res", "80x60", "--reset-timeout", "0.3")
    assert res.returncode == 0, res.stderr
    assert np.array_equal(cv2.imread(str(out)), quantised(img))


def test_cli_nonexistent_port(tmp_path) -> None:
    res = run_cli("/dev/ttyNOPE9", "--snapshot", str(tmp_path / "x.png"))
    assert res.returncode != 0
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "/dev/ttyNOPE9" in lines[0]
    assert not (tmp_path / "x.png").exists()


def test_cli_garbage_port(make_board, tmp_path) -> None:
    board = make_board(faults=Faults(garbage_only=True))
    res = run_cli(board.path, "--snapshot", str(tmp_path / "x.png"), "--reset-timeout", "0.5")
    assert res.returncode != 0
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert board.path in lines[0] and "received b" in lines[0]


def test_cli_bad_resolution(tmp_path) -> None:
    res = run_cli("/dev/null", "--snapshot", str(tmp_path / "x.png"), "--res", "100x100")
    assert res.returncode != 0 and "resolution" in res.stderr
    assert os.path.exists("/dev/null")


def test_line_mode_bitmaps(make_board, make_cam) -> None:
    img = np.zeros((120, 160, 3), np.uint8)
    img[40:60, 100:130] = (0, 0, 255)
    # A tracked column of pixels whose bitmap bytes include CR and ':' (0x0D, 0x3A).
    board = make_board(image=img)
    cam = make_cam(board.path)
    cam.connect()
    cam.set_line_mode(True)
    with cam.track((200, 255, 0, 50, 0, 50)) as stream:
        packets = [next(stream) for _ in range(3)]
    for p in packets:
        assert p.bitmap is not None and p.bitmap.shape == (60, 80)
        expected = np.zeros((60, 80), bool)
        expected[20:30, 50:65] = True
        assert np.array_equal(p.bitmap, expected)
        assert (p.x1, p.y1, p.x2, p.y2) == (100, 40, 129, 59)
    with cam.statistics() as stream:
        s = next(stream)
    assert s.bitmap is not None and s.bitmap.sum() == 150
    cam.set_line_mode(False)
    with cam.track((200, 255, 0, 50, 0, 50)) as stream:
        assert next(stream).bitmap is None
    assert cam.get_version() == "CMUcam4 v1.02"


def test_line_mode_bitmap_with_protocol_bytes(make_board, make_cam) -> None:
    # Bitmap rows made of 0x0D 0x3A bytes ("\r:") must be read by count.
    pattern = np.unpackbits(np.frombuffer(b"\r:" * 5, np.uint8)).astype(bool)  # 80 bits
    img = np.zeros((120, 160, 3), np.uint8)
    for y in range(0, 120, 2):
        img[y, np.repeat(pattern, 2)] = (0, 0, 255)
    board = make_board(image=img)
    cam = make_cam(board.path)
    cam.connect()
    cam.set_line_mode(True)
    with cam.track((200, 255, 0, 50, 0, 50)) as stream:
        p = next(stream)
    assert p.bitmap is not None and np.array_equal(p.bitmap[0], pattern)
    assert cam.get_version() == "CMUcam4 v1.02"
