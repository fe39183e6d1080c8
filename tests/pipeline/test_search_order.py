"""The order of the whole frame's searches: a far pad's H, located on the working view
but too small there to be judged, sends the search to the enlarged view before the
working view's other thresholds; a frame wider than the working view is searched at
its own resolution before it is enlarged; a first look at the coarse view fits no
mark too small for it (`pipeline.find.FIRST_LOOK_MIN_SPAN_PX`)."""

from __future__ import annotations

import numpy as np

import pipeline.find
import pipeline.frame
from pipeline import Camera, process_frame
from pipeline.find import Tally
from pipeline.frame import COARSE_WIDTH_PX
from tests.pipeline.bench_support import CAM, bench_frames, sweep_frames

ADAPTIVE_640 = (640, "adaptive")
ENLARGED = (1280, "adaptive")


def _searched(monkeypatch) -> list[tuple[int, str]]:
    """The (width, threshold) of the views `process_frame` searches, in turn."""
    log: list[tuple[int, str]] = []
    search = pipeline.frame.search

    def spy(image, channel, *args, **kwargs):
        log.append((image.shape[1], kwargs["method"]))
        return search(image, channel, *args, **kwargs)

    monkeypatch.setattr(pipeline.frame, "search", spy)
    return log


def _position_error(res, view) -> float:
    found = np.asarray(res.pose.position_m)
    return min(
        float(np.linalg.norm(found - view.position_m)),
        float(np.linalg.norm(found * [-1, -1, 1] - view.position_m)),
    )


def _found(log: list[tuple[int, str]], point: int, altitude: float, j: int, camera=CAM):
    """The altitude sweep's frame ``j`` of ``point`` (640 x 480 unless ``camera``), its
    pad found within 5 % of the altitude with ``log`` holding the views searched; its
    empty twin, the attitude hint and the reference."""
    pad, empty, view, hint, reference = sweep_frames("default", camera, point, altitude, j)
    log.clear()
    res = process_frame(pad, reference, camera, gravity_hint=hint)
    assert res.detected and res.pose is not None, res.reason
    assert _position_error(res, view) < 0.05 * altitude
    return empty, hint, reference


def test_a_far_pads_small_h_refused_on_the_working_view_is_looked_at_closer_next(monkeypatch):
    # The altitude sweep's 640 x 480 frames at 16 m (point 12), frames 20 and 25: the
    # H (about 10 px) is located on the working view and refused there as too small;
    # the shadow thresholds would locate and refuse it again, and the whole frame be
    # doubled, before it was found.
    log = _searched(monkeypatch)
    for j in (20, 25):
        empty, hint, reference = _found(log, 12, 16.0, j)
        assert log[:2] == [(COARSE_WIDTH_PX, "adaptive"), ADAPTIVE_640], log
        assert len(log) == 3 and log[2][0] < 200 and log[2][1] == "adaptive", log  # a window
        # Without the pad, every view of the whole frame is still searched: nothing
        # found is no reason to skip a threshold.
        log.clear()
        assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
        whole = [(COARSE_WIDTH_PX, "adaptive"), ADAPTIVE_640, (640, "shadow"), (640, "tophat")]
        assert [t for t in log if t[0] >= COARSE_WIDTH_PX] == [*whole, ENLARGED], log


def test_a_small_h_refused_on_a_shadow_threshold_is_looked_at_closer_as_if_doubled(monkeypatch):
    # The sweep's frames 6 and 30 at 18 m (point 13): the H is located only by the
    # top-hat threshold and refused there as too small; a window doubled around it
    # and thresholded as the doubled frame is finds it (thresholded top-hat, it was
    # refused again): the whole frame is not doubled.
    log = _searched(monkeypatch)
    for j in (6, 30):
        _found(log, 13, 18.0, j)
        assert log[-2:-1] == [(640, "tophat")], log
        assert log[-1][0] < 200 and log[-1][1] == "adaptive", log  # a window


def test_without_a_small_h_refused_the_shadow_thresholds_come_before_the_enlarged_view(
    monkeypatch,
):
    log = _searched(monkeypatch)
    _, empty, _, hint, reference = sweep_frames("default", CAM, 14, 20.0, 0)
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
    assert log == [
        (COARSE_WIDTH_PX, "adaptive"),
        ADAPTIVE_640,
        (640, "shadow"),
        (640, "tophat"),
        ENLARGED,
    ]


def test_a_wide_frames_far_pad_is_looked_for_at_its_own_resolution_before_it_is_doubled(
    monkeypatch,
):
    # The altitude sweep's 1280 x 720 frames at 24 m (point 15): the pad spans 25 px,
    # its H some 7 px of the working view (too small to be located there) and 14 px
    # of the frame, where it is found: the doubled frame (2560 px, some four times the
    # time) is not searched.
    camera = Camera.from_fov(1280, 720, 60.0)
    log = _searched(monkeypatch)
    for j in (0, 1):
        empty, hint, reference = _found(log, 15, 24.0, j, camera)
        assert (1280, "adaptive") in log and max(w for w, _ in log) == 1280, log
        # Without the pad, the doubled frame comes last, after the frame's own.
        log.clear()
        assert not process_frame(empty, reference, camera, gravity_hint=hint).detected
        assert log[-2:] == [(1280, "adaptive"), (2560, "adaptive")], log


def _first_look_fits(monkeypatch) -> list[float]:
    """The spans (view pixels) of the marks the first look fits an H to."""
    spans: list[float] = []
    locate = pipeline.find.locate

    def spy(cand, binary, reference):
        if binary.mask.shape[1] == COARSE_WIDTH_PX:
            spans.append(cand.region.span)
        return locate(cand, binary, reference)

    monkeypatch.setattr(pipeline.find, "locate", spy)
    return spans


def test_the_first_look_fits_no_mark_too_small_for_it_and_the_pad_is_still_found(monkeypatch):
    # The altitude sweep's 640 x 480 frames at 12 m (point 10): the H spans some 8 px
    # of the coarse view, where it was fitted and turned down, to be found on the
    # working view.
    least = pipeline.find.FIRST_LOOK_MIN_SPAN_PX
    spans = _first_look_fits(monkeypatch)
    for j in (4, 5):
        pad, _, view, hint, reference = sweep_frames("default", CAM, 10, 12.0, j)
        monkeypatch.setattr(pipeline.find, "FIRST_LOOK_MIN_SPAN_PX", 0.0)
        spans.clear()
        process_frame(pad, reference, CAM, gravity_hint=hint)
        assert any(s < least for s in spans), spans  # (the H, too small for a first look)
        monkeypatch.setattr(pipeline.find, "FIRST_LOOK_MIN_SPAN_PX", least)
        spans.clear()
        res = process_frame(pad, reference, CAM, gravity_hint=hint)
        assert all(s >= least for s in spans), spans
        assert res.detected and res.pose is not None, res.reason
        assert _position_error(res, view) < 0.05 * 12.0


def test_a_mark_judged_on_the_same_pixels_with_the_same_threshold_is_not_judged_again():
    tally = Tally()
    box = np.array([100.0, 80.0, 112.0, 90.0])  # (frame pixels: a small mark)
    assert not tally.seen_alike(box, 2.0, "adaptive")
    tally.seen.append((box, 2.0, "adaptive"))  # (a closer look, doubled)
    assert tally.seen_alike(box + 0.5, 2.0, "adaptive")  # the whole frame doubled
    assert not tally.seen_alike(box, 1.0, "adaptive")  # other pixels
    assert not tally.seen_alike(box, 2.0, "tophat")  # another threshold
    assert not tally.seen_alike(box + np.array([20.0, 0.0, 20.0, 0.0]), 2.0, "adaptive")


def test_a_pad_whose_h_a_first_look_takes_only_from_nearby_is_searched_without_one(monkeypatch):
    # The paper sheet's H, 7 cm tall: a first look (320 px wide) takes it from 2 m
    # away at most, where a landing follows the pad. The design bench's views of it
    # (0.5-3.3 m) are searched from the working view on, and found; the default pad's
    # H (28 cm, 7.6 m) still gets a first look.
    log = _searched(monkeypatch)
    for i in (0, 1, 2):
        pad, _, hint, view, reference = bench_frames("paper_ring", 0, i, "today")
        log.clear()
        res = process_frame(pad, reference, CAM, gravity_hint=hint)
        assert res.detected and res.pose is not None, res.reason
        assert _position_error(res, view) < 0.05 * view.altitude_m
        assert log[0] == ADAPTIVE_640 and COARSE_WIDTH_PX not in [w for w, _ in log], log
    pad, _, hint, _, reference = bench_frames("default", 0, 0, "today")
    log.clear()
    process_frame(pad, reference, CAM, gravity_hint=hint)
    assert log[0] == (COARSE_WIDTH_PX, "adaptive"), log
