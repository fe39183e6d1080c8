"""The OpenCV source reading real video files written with cv2.VideoWriter."""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from backend.camera import Frame, FrameSource, open_source
from backend.camera.opencv_source import OpenCVSource
from tests.polling import wait_until

pytestmark = [pytest.mark.timeout(30), pytest.mark.usefixtures("no_leftover_threads")]


def write_video(path: Path, n: int = 12, size: tuple[int, int] = (64, 48), fps: float = 50.0):
    w, h = size
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (w, h))
    assert writer.isOpened()
    for i in range(n):
        img = np.zeros((h, w, 3), np.uint8)
        img[:, : (i + 1) * w // n] = (0, 200, 0)  # a bar that grows: frame i is recognisable
        writer.write(img)
    writer.release()
    return path


def bar_length(frame: Frame) -> int:
    return int((frame.image[h_mid(frame), :, 1] > 100).sum())


def h_mid(frame: Frame) -> int:
    return frame.image.shape[0] // 2


@pytest.fixture
def sources() -> Iterator[list[FrameSource]]:
    made: list[FrameSource] = []
    yield made
    for s in made:
        s.close()


def collect(src: FrameSource, n: int, timeout: float = 5.0) -> list[Frame]:
    frames: list[Frame] = []
    seq = -1
    end = time.monotonic() + timeout
    while len(frames) < n and time.monotonic() < end:
        f = src.wait_frame(seq, timeout=max(0.0, end - time.monotonic()))
        if f is None:
            break
        frames.append(f)
        seq = f.seq
    return frames


def test_plays_file_once_then_reports_end(tmp_path, sources) -> None:
    path = write_video(tmp_path / "v.avi")
    src = OpenCVSource(str(path), stall_after=0.3)
    sources.append(src)
    src.start()
    frames = collect(src, 12)
    assert len(frames) == 12
    f = frames[-1]
    assert f.image.shape == (48, 64, 3) and f.image.dtype == np.uint8
    assert f.source == f"opencv:{path}" and f.info["resolution"] == (64, 48)
    assert [fr.seq for fr in frames] == list(range(12))
    assert all(b.t_capture > a.t_capture for a, b in itertools.pairwise(frames))
    # Played at the file's 50 fps: 12 frames span at least ~0.2 s.
    assert frames[-1].t_capture - frames[0].t_capture >= 11 / 50 * 0.9
    # The bar grows frame by frame: nothing skipped, nothing repeated.
    lengths = [bar_length(fr) for fr in frames]
    assert lengths == sorted(lengths) and len(set(lengths)) == 12
    assert src.wait_frame(f.seq, timeout=0.5) is None
    st = src.status
    assert st.state == "stalled" and "end of video file" in st.last_error
    assert st.frames == 12 and st.stalled_since is not None
    assert src.latest() is f


def test_loops_file(tmp_path, sources) -> None:
    path = write_video(tmp_path / "v.avi", n=5)
    src = open_source(f"opencv:{path}", loop=True, fps=0)
    sources.append(src)
    src.start()
    frames = collect(src, 12, timeout=20)
    assert len(frames) == 12  # read as fast as it goes: a busy reader may skip some
    # The picture is the frame's place in the file, whichever pass it came from.
    by_place: dict[int, set[int]] = {}
    for fr in frames:
        by_place.setdefault(fr.info["pos_frames"], set()).add(bar_length(fr))
    assert all(len(lengths) == 1 for lengths in by_place.values()), by_place
    ordered = [min(by_place[p]) for p in sorted(by_place)]
    assert ordered == sorted(ordered) and len(set(ordered)) == len(ordered)
    assert frames[-1].info["loops"] >= 2  # 12 frames of a 5-frame file
    assert src.status.state == "streaming" and src.status.fps > 0


def test_missing_file_errors_then_recovers(tmp_path, sources) -> None:
    path = tmp_path / "late.avi"
    src = OpenCVSource(str(path), backoff=(0.05, 0.1), stall_after=0.5)
    sources.append(src)
    src.start()
    assert wait_until(lambda: src.status.errors >= 2)
    st = src.status
    assert st.frames == 0 and "no video file" in st.last_error
    assert st.state == "error"
    write_video(tmp_path / "tmp.avi").rename(path)  # the file "returns"
    assert src.wait_frame(-1, timeout=3.0) is not None
    assert src.status.state == "streaming"


def test_not_a_video(tmp_path, sources) -> None:
    bad = tmp_path / "bad.avi"
    bad.write_bytes(b"this is not a video" * 10)
    src = OpenCVSource(str(bad), backoff=(0.05, 0.1))
    sources.append(src)
    src.start()
    assert src.wait_frame(-1, timeout=0.5) is None
    assert "bad.avi" in src.status.last_error


def test_close_is_prompt_and_idempotent(tmp_path) -> None:
    path = write_video(tmp_path / "v.avi", n=50)
    src = OpenCVSource(str(path), loop=True, fps=5)  # slow playback: close mid-wait
    src.start()
    assert src.wait_frame(-1, timeout=3.0) is not None
    src.close()  # mid-wait for the next frame: the thread still ends
    src.close()
    assert src.status.state == "closed"
    assert src._thread is not None and not src._thread.is_alive()
    with pytest.raises(RuntimeError, match="closed"):
        src.start()


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="target"):
        OpenCVSource(-1)
    with pytest.raises(ValueError, match="target"):
        OpenCVSource("  ")
    with pytest.raises(ValueError, match="loop"):
        OpenCVSource(0, loop=True)
    with pytest.raises(ValueError, match="fps"):
        OpenCVSource("x.avi", fps=-1)
    with pytest.raises(ValueError, match="timeout"):
        OpenCVSource("x.avi").wait_frame(0, timeout=-1)
    assert OpenCVSource("rtsp://127.0.0.1:1/x").kind == "url"
    assert isinstance(open_source("opencv:3"), OpenCVSource)
    assert open_source("opencv:3").target == 3


def test_open_source_specs() -> None:
    for spec in ("", "webcam", "opencv:", "cmucam4:", "sim:extra", "sim"):
        with pytest.raises(ValueError, match="spec"):
            open_source(spec)
    src = open_source("cmucam4:/dev/ttyUSB9", resolution="80x60")
    assert src.name == "cmucam4:/dev/ttyUSB9"
    src.close()


def test_unreachable_stream_url_reports_error(sources) -> None:
    url = "rtsp://127.0.0.1:9/none"  # discard port: nothing serves RTSP there
    src = OpenCVSource(url, open_timeout=1.0, read_timeout=1.0, backoff=(0.1, 0.2))
    sources.append(src)
    src.start()
    assert wait_until(lambda: src.status.errors >= 1, timeout=10.0)
    st = src.status
    assert st.state == "error" and url in st.last_error and st.frames == 0
