"""The vision worker: own thread, newest frame first, drops counted, results on the bus."""

from __future__ import annotations

import itertools
import threading
import time

import numpy as np
import pytest

from backend.camera import ThreadedSource
from backend.framebus import FrameBus
from backend.vision_worker import VisionWorker
from pipeline import Camera, Reference, process_frame
from pipeline.render import camera_rotation, make_pad_image, make_scene, render

CAMERA = Camera.from_fov(640, 480, 60)


class RenderedSource(ThreadedSource):
    """A real source (the camera package's capture thread) serving a rendered view."""

    def __init__(self, image: np.ndarray, rate_hz: float) -> None:
        super().__init__("rendered")
        self.expected_period = 1.0 / rate_hz
        self._image = image
        self._next = 0.0

    def _open(self) -> None:
        self._next = time.monotonic()

    def _grab(self):
        now = time.monotonic()
        if now < self._next and self._sleep(self._next - now):
            return None
        self._next += self.expected_period
        return self._image, time.monotonic(), {}

    def _release(self) -> None:
        pass


@pytest.fixture(scope="module")
def pad_frame():
    pad = make_pad_image(800)
    scene = make_scene(pad, 0.55, rng=np.random.default_rng(1))
    frame = render(scene, CAMERA, np.array([0.05, -0.1, 2.5]), camera_rotation(20.0))
    return Reference.from_image(pad, 0.55), frame


class Collector:
    """A consumer that keeps every result (an on_put callback, called per publish)."""

    def __init__(self, bus: FrameBus) -> None:
        self.got: list = []
        self.slot = bus.subscribe("test", on_put=self._take)

    def _take(self) -> None:
        item = self.slot.take(0.0)
        if item is not None:
            self.got.append(item)


def run_worker(source, reference, until, timeout=30.0, **kw):
    """Run the worker until ``until(worker, got)`` holds (or ``timeout`` s pass)."""
    bus = FrameBus("results")
    worker = VisionWorker(
        source, bus, reference=lambda: reference, camera=CAMERA, process=process_frame, **kw
    )
    collector = Collector(bus)
    got = collector.got
    source.start()
    worker.start()
    try:
        deadline = time.monotonic() + timeout
        while not until(worker, got) and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        worker.close()
        source.close()
    return worker, got


def results(n):
    """``until``: the worker published ``n`` results."""
    return lambda worker, got: len(got) >= n


def test_processes_frames_and_finds_the_pad(pad_frame):
    reference, frame = pad_frame
    asked = {}

    def hints(of) -> dict:
        # (the vehicle's attitude is looked up for the frame's own moment)
        asked[of.seq] = of.t_capture
        return {"yaw_hint": 20.0}

    worker, got = run_worker(RenderedSource(frame, 10), reference, results(3), hints=hints)
    assert len(got) >= 3
    assert all(asked[p.frame.seq] == p.frame.t_capture for p in got)
    assert all(p.result.detected for p in got)
    assert got[-1].result.pose is not None
    assert np.allclose(got[-1].result.pose.position_m, [0.05, -0.1, 2.5], atol=0.1)
    stats = worker.stats
    assert stats.processed == len(got) and stats.detected_rate == 1.0
    assert stats.latency_ms is not None and stats.latency_ms > 0
    assert all(p.latency_ms >= 0 for p in got)


def test_a_fast_camera_drops_frames_and_counts_them(pad_frame):
    reference, frame = pad_frame
    source = RenderedSource(frame, 400)  # far faster than the pipeline
    # until the camera has sent far more frames than were processed
    worker, got = run_worker(source, reference, lambda w, g: len(g) >= 3 and w.stats.dropped > 10)
    stats = worker.stats
    seqs = [p.frame.seq for p in got]
    assert seqs == sorted(seqs)
    gaps = sum(b - a - 1 for a, b in itertools.pairwise(seqs))
    assert stats.dropped == gaps > 0  # every skipped frame counted, none twice


def test_a_consumer_that_never_takes_holds_nothing_up(pad_frame):
    reference, frame = pad_frame
    source = RenderedSource(frame, 20)
    bus = FrameBus("results")
    worker = VisionWorker(
        source, bus, reference=lambda: reference, camera=CAMERA, process=process_frame
    )
    stuck = bus.subscribe("never-reads")
    collector = Collector(bus)
    source.start()
    worker.start()
    try:
        deadline = time.monotonic() + 10
        while len(collector.got) < 4 and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        worker.close()
        source.close()
    assert len(collector.got) >= 4  # the other consumer got every result
    # The stuck one holds only the newest: the rest were replaced, never queued.
    assert stuck.replaced == stuck.received - 1 >= 3
    assert stuck.take(0.0) is collector.got[-1]
    assert worker.stats.errors == 0


def test_no_reference_means_no_processing(pad_frame):
    _, frame = pad_frame
    # 20 frames were offered (an absence needs some time: here the camera's)
    source = RenderedSource(frame, 50)
    worker, got = run_worker(source, None, lambda w, g: source.status.frames >= 20)
    assert got == [] and worker.stats.processed == 0


def test_frames_of_another_size_use_the_scaled_camera(pad_frame):
    reference, frame = pad_frame
    import cv2

    small = cv2.resize(frame, (320, 240), interpolation=cv2.INTER_AREA)
    _, got = run_worker(
        RenderedSource(small, 10), reference, results(1), hints=lambda _frame: {"yaw_hint": 20.0}
    )
    assert got and got[-1].camera.width == 320 and got[-1].result.detected


def test_close_joins_the_thread(pad_frame):
    reference, frame = pad_frame
    before = threading.active_count()
    worker, _ = run_worker(RenderedSource(frame, 30), reference, results(1))
    worker.close()  # idempotent
    assert threading.active_count() <= before


def test_the_camera_seen_is_the_model_at_the_frames_size(pad_frame):
    reference, frame = pad_frame
    wide = np.ascontiguousarray(np.repeat(np.repeat(frame, 2, axis=0), 2, axis=1))  # 1280x960
    source = RenderedSource(wide, rate_hz=30)
    seen = {}

    def until(worker, got):
        seen["camera"] = worker.camera_seen()
        return bool(got)

    run_worker(source, reference, until)
    camera = seen["camera"]
    assert (camera.width, camera.height) == (1280, 960)
    assert camera.fx == pytest.approx(2 * CAMERA.fx)
